"""rosbag2 directory bags (rotor_avc.bag.rosbag2), the mapping file (rotor_avc.compare.
recording_map), the resampling of imperfect data (rotor_avc.analysis.resampling) and H1's random
error (rotor_avc.analysis.frf_estimate.h1_random_error), each against an independent result:
rosbags' own reader, analytic shaft motion, explicit interpolation, a Monte Carlo of H1."""
import shutil

import numpy as np
import pytest
import yaml
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from rotor_avc.analysis import resampling as R
from rotor_avc.analysis.frf_estimate import estimate_frf, h1_random_error
from rotor_avc.analysis.one_x_noise import decidable
from rotor_avc.analysis.order_tracking import fit
from rotor_avc.bag import BagError, BagReader
from rotor_avc.bag.rosbag2 import DirectoryBag, open_bag
from rotor_avc.cli import main
from rotor_avc.compare.comparison import compare_bag
from rotor_avc.compare.mapped_stream import compare_mapped
from rotor_avc.config import find_config, load_yaml
from rotor_avc.recording import write_run_bag
from rotor_avc.scenario import scenario_from_config

from rosbag2_corpus import Imperfections, corpus_map, corpus_recording, write_corpus_bag

TOPIC = "/imu_foot_nl/data"


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    """0.4 s of case 3 at 25 Hz as a two-file directory, its machine config and mapping."""
    root = tmp_path_factory.mktemp("dir")
    return root, corpus_recording(root)


def test_a_directory_reads_as_one_bag_over_its_split_files(corpus):
    _, bag = corpus
    ts = get_typestore(Stores.ROS2_JAZZY)
    with Reader(bag) as ref:                                     # rosbags' own reader
        counts = {c.topic: c.msgcount for c in ref.connections}
        [conn] = [c for c in ref.connections if c.topic == TOPIC]
        ref_rows = [(t, ts.deserialize_cdr(raw, conn.msgtype).linear_acceleration.z)
                    for _, t, raw in ref.messages(connections=[conn])]
    with open_bag(bag, require_messages=True) as reader:
        assert isinstance(reader, DirectoryBag)
        assert {t: i.count for t, i in reader.topics.items()} == counts
        assert reader.message_count == sum(counts.values())
        series = reader.series(TOPIC)
        np.testing.assert_array_equal(series.time_ns, [t for t, _ in ref_rows])
        np.testing.assert_array_equal(series["linear_acceleration.z"], [a for _, a in ref_rows])
        merged = list(reader.raw_messages([TOPIC, "/tacho/pulse"]))
        assert [m.time_ns for m in merged] == sorted(m.time_ns for m in merged)
        assert len(merged) == counts[TOPIC] + counts["/tacho/pulse"]
        np.testing.assert_array_equal(reader.log_times(TOPIC), series.time_ns)
        first = next(reader.messages(TOPIC))
        assert first.data["linear_acceleration"]["z"] == ref_rows[0][1]
        assert reader.counts is None
        with pytest.raises(BagError, match="no run configuration"):
            reader.config
    files = sorted(bag.glob("*.mcap"))
    assert len(files) == 2
    with open_bag(files[0]) as single:
        assert isinstance(single, BagReader)


def _broken(tmp_path, bag, what):
    copy = tmp_path / what
    shutil.copytree(bag, copy)
    meta = copy / "metadata.yaml"
    info = yaml.safe_load(meta.read_text())
    if what == "no metadata":
        meta.unlink()
    elif what == "missing file":
        (copy / info["rosbag2_bagfile_information"]["relative_file_paths"][1]).unlink()
    elif what == "sqlite3":
        info["rosbag2_bagfile_information"]["storage_identifier"] = "sqlite3"
        meta.write_text(yaml.safe_dump(info))
    else:
        meta.write_text("rosbag2_bagfile_information: [unclosed\n")
    return copy


@pytest.mark.parametrize("what, message", [
    ("no metadata", "without metadata.yaml"), ("missing file", "which is missing"),
    ("sqlite3", "storage_identifier is 'sqlite3'"), ("bad yaml", "unreadable YAML")])
def test_broken_directories_give_one_line_errors(corpus, tmp_path, capsys, what, message):
    root, bag = corpus
    broken = _broken(tmp_path, bag, what)
    with pytest.raises(BagError, match=message):
        open_bag(broken)
    args = ["compare", str(broken), "--config", str(root / "machine.yaml"), "--map",
            str(root / "map.yaml"), "--out", str(tmp_path / "r")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "fix:" in err


@pytest.mark.parametrize("change, field", [
    (lambda m: m.update(extra=1), "extra: unknown key"),
    (lambda m: m["channels"].update(foot_XX_az=m["channels"]["foot_DL_az"]),
     "channels.foot_XX_az: is not a signal of the machine"),
    (lambda m: m["channels"]["foot_DR_az"].update(topic="/imu_foot_xx/data"),
     "channels.foot_DR_az.topic: no topic /imu_foot_xx/data"),
    (lambda m: m["channels"]["foot_DR_az"].update(field="linear_acceleration.w"),
     "channels.foot_DR_az.field: 'linear_acceleration.w' is not a numeric field"),
    (lambda m: m["channels"]["foot_DR_az"].update(sign=0.5), "channels.foot_DR_az.sign: must be"),
    (lambda m: m["channels"]["foot_DR_az"].update(scal=2.0), "channels.foot_DR_az.scal: unknown"),
    (lambda m: m["shaft"].update(source="laser"), "shaft.source: unknown value 'laser'"),
    (lambda m: m.pop("shaft"), "shaft: missing"),
    (lambda m: m.update(test_force={"topic": "/imu_foot_nl/data", "field": "linear_acceleration.z"}),
     "test_force: the configuration has no simulation.test_signal")])
def test_mapping_errors_name_the_field(corpus, tmp_path, capsys, change, field):
    root, bag = corpus
    mapping = corpus_map(test_force=False)
    change(mapping)
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(mapping))
    assert main(["compare", str(bag), "--config", str(root / "machine.yaml"), "--map",
                 str(path), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and field in err and "fix:" in err, err


def test_config_and_map_go_together(corpus, capsys):
    root, bag = corpus
    assert main(["compare", str(bag), "--map", str(root / "map.yaml")]) == 2
    assert "--map: a mapped comparison needs the machine too" in capsys.readouterr().err
    assert main(["compare", str(bag)]) == 2          # a directory without rotor_avc metadata
    assert "carries no run configuration" in capsys.readouterr().err


def test_pulses_give_the_analytic_angle_and_speed_despite_a_missing_pulse():
    """theta(t) = 2 pi (f0 t + a t^2 / 2) on a run-up after a 1 s dwell at f0."""
    f0, a = 20.0, 30.0                                             # Hz, Hz/s
    t_dwell = np.arange(0, 20) / f0                                 # 20 revolutions
    k = np.arange(0, 40)                                            # then a ramp from f0
    t_ramp = 1.0 + (-f0 + np.sqrt(f0 ** 2 + 2 * a * k)) / a
    pulses = np.concatenate([t_dwell, t_ramp])
    pulses = np.delete(pulses, 7)                                   # one pulse lost
    grid = np.arange(0.0, 0.9, 1e-3)
    shaft = R.shaft_from_pulses(pulses, grid, min_revolutions=8)
    assert shaft.missing_pulses == 1 and shaft.pulses == pulses.size
    np.testing.assert_allclose(shaft.angle_rad, 2 * np.pi * f0 * grid, atol=1e-9)
    np.testing.assert_allclose(shaft.speed_rad_s, 2 * np.pi * f0, rtol=1e-12)
    [(start, end, hz)] = shaft.dwells
    assert hz == pytest.approx(f0, rel=1e-12) and start == 0.0
    ramp = np.arange(1.2, 2.0, 1e-3)
    shaft = R.shaft_from_pulses(pulses, ramp)
    # between pulses the angle is linear: within the chord error w' dt^2 / 8 of the parabola
    exact = 2 * np.pi * (f0 * ramp + a * (ramp - 1) ** 2 / 2)
    assert np.max(np.abs(shaft.angle_rad - exact)) <= 2 * np.pi * a * (1 / f0) ** 2 / 8
    np.testing.assert_allclose(shaft.speed_rad_s, 2 * np.pi * (f0 + a * (ramp - 1)), rtol=2e-3)


def test_stamp_quality_counts_drops_and_jitter():
    rng = np.random.default_rng(5)
    period, n = 2e-4, 20000
    t = np.arange(n) * period + 3e-6 * rng.standard_normal(n)
    dropped = np.concatenate([[100, 101, 102], rng.choice(np.arange(200, n - 1), 150, False)])
    q = R.stamp_quality("x", np.delete(t, np.unique(dropped)))
    assert q.dropouts == np.unique(dropped).size
    assert q.rate_hz == pytest.approx(1 / period, rel=1e-3)
    assert q.jitter_s == pytest.approx(np.sqrt(2) * 3e-6, rel=0.05)
    assert q.longest_gap_s == pytest.approx(4 * period, rel=0.1)


def test_resampling_excludes_long_gaps_and_states_the_interpolation_loss():
    """A 300 Hz sine sampled at 2.5 kHz, interpolated onto a 5 kHz grid: the amplitude a
    least-squares fit finds is the stated loss, and a gap of 5 missing samples is excluded."""
    f, p = 300.0, 4e-4
    t = np.arange(2500) * p
    keep = np.ones(t.size, bool)
    keep[1000:1005] = False
    grid = np.arange(0.01, 0.99, 2e-4)
    y, valid = R.resample(t[keep], np.sin(2 * np.pi * f * t[keep]), grid, 4)
    assert not valid[(grid > t[1000]) & (grid < t[1004])].any() and valid.mean() > 0.99
    basis = np.column_stack([np.sin(2 * np.pi * f * grid), np.cos(2 * np.pi * f * grid)])
    amp = np.hypot(*np.linalg.lstsq(basis[valid], y[valid], rcond=None)[0])
    loss = R.interpolation_loss_db(t[keep], grid[valid], f)
    assert -20 * np.log10(amp) == pytest.approx(loss, abs=0.02)
    # on a grid of another period every fraction a is as likely: linear interpolation's
    # frequency response sinc^2(f p) on average
    other = np.arange(0.01, 0.99, 1.9e-4)
    assert R.interpolation_loss_db(t, other, f) == pytest.approx(
        -20 * np.log10(np.sinc(f * p) ** 2), abs=0.01)
    assert R.interpolation_loss_db(grid, grid, f) == pytest.approx(0.0, abs=1e-12)


def test_h1_random_error_matches_a_monte_carlo_of_the_estimate():
    """y = h * x + noise, many records: the spread of |H1| / |H| is eps (Bendat & Piersol)."""
    rng = np.random.default_rng(7)
    h = np.array([0.5, 0.3, -0.2])
    mags, coherences = [], []
    for _ in range(300):
        x = rng.standard_normal(4096)
        y = np.convolve(x, h)[:x.size] + 0.3 * rng.standard_normal(x.size)
        est = estimate_frf(x, y, 1.0, nperseg=256)
        mags.append(np.abs(est.h1))
        coherences.append(est.coherence)
    sel = slice(5, 100)
    f = est.freq_hz[sel]
    true = np.abs(sum(c * np.exp(-2j * np.pi * f * k) for k, c in enumerate(h)))
    spread = np.std(np.array(mags)[:, sel], axis=0) / true
    eps = h1_random_error(np.mean(np.array(coherences)[:, sel], axis=0), est.averages)
    # 50 % overlap of Hann segments makes neighbouring averages correlate a little
    np.testing.assert_allclose(np.median(spread / eps), 1.0, atol=0.15)
    assert h1_random_error(np.array([1.0]), 4)[0] == 0.0
    assert np.isinf(h1_random_error(np.array([0.0]), 4)[0])


def test_a_bag_of_this_package_compares_the_same_through_a_mapping(tmp_path):
    """A second path to the same numbers: a simulated bag read natively (its configuration,
    exact speed) and through a mapping (JointState angle, speed and dwells from its whole
    revolutions, labelled-array fields, log-time stamps) gives the same 1x phasors."""
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"sample_rate_hz": 5000.0, "initial_state": "steady_state",
                          "speed": {"type": "stepped", "speeds_hz": [30.0, 60.0],
                                    "dwell_s": 1.0, "transition_s": 0.2},
                          "unbalance": {"static": {"magnitude": 1e-2, "phase_deg": 0.0}}}
    config = tmp_path / "machine.yaml"
    config.write_text(yaml.safe_dump(data))
    sc = scenario_from_config(data, "own")
    bag = write_run_bag(tmp_path / "own.mcap", sc, sc.run(progress=False))
    mapping = {"channels": {"foot_DL_az": {"topic": "/avc/foot/DL/acceleration",
                                           "field": "accel.linear.z"},
                            "bearing_D_vz": {"topic": "/avc/plant/observables",
                                             "field": "bearing_D_vz", "stamp": "log"}},
               "shaft": {"source": "joint_state", "topic": "/avc/rotor/joint_state"}}
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(mapping))
    native = compare_bag(bag).one_x
    mapped = compare_mapped(bag, config, tmp_path / "map.yaml").one_x
    np.testing.assert_allclose(mapped.speed_rad_s, native.speed_rad_s, rtol=1e-6)
    for name in mapping["channels"]:
        np.testing.assert_allclose(mapped.measured[name], native.measured[name], rtol=2e-3)
    # the mapping's unbalance reference replaces the configuration's: per unit of twice the
    # unbalance the measured 1x is half, the model's is the same
    mapping["unbalance"] = {"static": {"magnitude": 2e-2, "phase_deg": 0.0}}
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(mapping))
    doubled = compare_mapped(bag, config, tmp_path / "map.yaml").one_x
    for name in mapping["channels"]:
        np.testing.assert_allclose(doubled.measured[name], mapped.measured[name] / 2, rtol=1e-12)
        np.testing.assert_allclose(doubled.model["sampled"][name],
                                   mapped.model["sampled"][name], rtol=1e-12)


def test_one_x_random_error_matches_a_monte_carlo():
    rng = np.random.default_rng(11)
    theta = 2 * np.pi * 25.0 * np.arange(2000) / 5000.0            # 10 revolutions
    Y = 0.3 - 0.4j
    fits = [fit(theta, np.real(Y * np.exp(1j * theta)) + 0.7
                + 0.5 * rng.standard_normal(theta.size)) for _ in range(400)]
    phasors = np.array([p for p, _ in fits])
    assert np.mean(phasors) == pytest.approx(Y, abs=0.01)
    spread = np.std(np.abs(phasors)) / abs(Y)
    assert np.median([s / abs(p) for p, s in fits]) == pytest.approx(spread, rel=0.15)
    assert decidable(0.01, 0.5) == (True, pytest.approx(20 * np.log10(1.02)))
    assert not decidable(0.05, 0.5)[0]
