"""`rotor-avc compare DIR --config MACHINE --map MAP` on rig-style recordings (test/rig_recordings.py):
the Werner 2021 machine with its case-3 loops (Werner 2021), run through stepped speeds drawn at
random between 5 and 120 Hz, recorded as a rig's drivers would -- Imu accelerometers at 1 kHz
on turned axes in g, bearing velocities at 1.25 kHz in mm/s in a turned frame, a tacho pulse
only (missing and bouncing pulses), 40 dB SNR, 20 us stamp jitter, 400 us latency with an
exponential tail, 1.2 % of every topic's messages dropped, half of them in bursts of 5-60 --
and compared with a configuration that holds only the machine (no ``simulation:`` section).

Stated bound: each recovered 1x phasor agrees with an independent least-squares fit of the clean,
complete simulated signal (numpy lstsq, test/rig_recordings.py) within max(0.5 dB, 5 sigma) in
magnitude and max(2 deg, 5 sigma) in phase, sigma the noise's standard error of the phasor
(noise RMS sqrt(2 / N) / |Y| for N samples in the window); every dwell speed within 0.01 %; the
verdict PASS. The same recordings with one sensor's sign or axis wrong FAIL naming that channel.
Broadband with burst gaps gives an estimate averaged between the gaps (never exit 2).
"""
import csv
import json
import re

import numpy as np
import pytest
import yaml

from rotor_avc.cli import main
from rotor_avc.compare.mapped_stream import compare_mapped
from rotor_avc.config import find_config, load_yaml
from rotor_avc.scenario import scenario_from_config

from rig_recordings import Rig, clean_one_x, rig_map, write_rig_bag

UNBALANCE = {"static": {"magnitude": 1.0e-2, "phase_deg": 30.0}}
U = 1.0e-2 * np.exp(1j * np.radians(30.0))
DWELL_S, TRANSITION_S = 2.0, 0.3
CHANNELS = ("foot_DL_az", "foot_DR_az", "foot_NL_az", "bearing_D_vz", "bearing_N_vz")
RATE_HZ = {"foot": Rig().imu_rate_hz, "bearing": Rig().velocity_rate_hz}


def _machine():
    data = load_yaml(find_config("foot_mount_case3"))
    data.pop("simulation", None)
    return data


def _speeds(seed: int) -> list[float]:
    """Four dwell speeds between 5 and 120 Hz, at least 8 Hz apart, drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    while True:
        speeds = np.sort(rng.uniform(5.0, 120.0, 4))
        if np.all(np.diff(speeds) > 8.0):
            return [float(s) for s in speeds]


def _record(root, seed: int, simulation: dict, *, test_force: bool = False, rig=None):
    machine = _machine()
    truth = scenario_from_config({**machine, "simulation": {
        "sample_rate_hz": 5000.0, "unbalance": UNBALANCE, "initial_state": "steady_state",
        **simulation}}, "rig truth")
    ts = truth.run(progress=False)
    root.mkdir()
    config = root / "machine.yaml"
    if test_force:
        machine = {**machine, "simulation": {"test_signal": simulation["test_signal"]}}
    config.write_text(yaml.safe_dump(machine))
    mapping = root / "map.yaml"
    mapping.write_text(yaml.safe_dump({**rig_map(test_force=test_force), "unbalance": UNBALANCE}))
    bag = write_rig_bag(root / "recording", ts, rig or Rig(seed=seed))
    return ts, bag, config, mapping


@pytest.fixture(scope="module", params=[11, 29])
def stepped(request, tmp_path_factory):
    speeds = _speeds(request.param)
    profile = {"type": "stepped", "speeds_hz": speeds, "dwell_s": DWELL_S,
               "transition_s": TRANSITION_S}
    ts, bag, config, mapping = _record(tmp_path_factory.mktemp("rig") / "stepped",
                                       request.param, {"speed": profile})
    return speeds, ts, bag, config, mapping


def _compare(bag, config, mapping, out):
    status = main(["compare", str(bag), "--config", str(config), "--map", str(mapping),
                   "--out", str(out)])
    return status, json.loads((out / "metrics.json").read_text())


def _one_x_rows(out):
    rows = {}
    for r in csv.DictReader(open(out / "frf.csv")):
        if r["kind"] == "1x":
            rows.setdefault(r["channel"], []).append(
                (float(r["speed_hz"]), float(r["measured_mag"]) * np.exp(
                    1j * np.radians(float(r["measured_phase_deg"])))))
    return rows


def test_a_rig_recording_compares_pass_with_the_right_speeds_and_1x(stepped, tmp_path):
    speeds, ts, bag, config, mapping = stepped
    status, metrics = _compare(bag, config, mapping, tmp_path / "report")
    assert status == 0 and metrics["verdict"] == "PASS", metrics["checks"]
    found = metrics["one_x"]["speeds_hz"]
    np.testing.assert_allclose(found, speeds, rtol=1e-4)
    assumed = metrics["assumed"]
    assert assumed["sample_rate_hz"]["value"] == 5000.0
    assert "default rate" in assumed["sample_rate_hz"]["from"]
    assert assumed["unbalance"]["from"] == "the mapping's unbalance"
    rows = _one_x_rows(tmp_path / "report")
    assert set(rows) == set(CHANNELS)
    t = np.asarray(ts.time_s)
    for ch, points in rows.items():
        rate = RATE_HZ[ch.split("_")[0]]
        noise = np.std(ts.channels[ch]) * 10 ** (-Rig().snr_db / 20)
        for k, (speed, measured) in enumerate(points):
            end = (k + 1) * DWELL_S + k * TRANSITION_S
            start = end - 0.5 * (DWELL_S - 0.0)
            truth = clean_one_x(ts, ch, start, end, U)
            n = (1 - Rig().drop_fraction) * 0.5 * DWELL_S * rate
            eps = noise * np.sqrt(2 / n) / abs(truth * U)
            err_db = 20 * np.log10(abs(measured) / abs(truth))
            err_deg = np.degrees(np.angle(measured / truth))
            assert abs(err_db) <= max(0.5, 20 * np.log10(1 + 5 * eps)), (ch, speed, err_db)
            assert abs(err_deg) <= max(2.0, np.degrees(5 * eps)), (ch, speed, err_deg)
            assert t[0] <= start


@pytest.mark.parametrize("stepped", [29], indirect=True)
@pytest.mark.parametrize("fault", ["sign", "axis"])
def test_a_wrong_sensor_sign_or_axis_fails_naming_the_channel(stepped, tmp_path, fault):
    _, _, bag, config, _ = stepped
    wrong = "bearing_N_vz" if fault == "sign" else "foot_DR_az"
    mapping = tmp_path / "wrong.yaml"
    mapping.write_text(yaml.safe_dump({**rig_map(**{f"wrong_{fault}": wrong}),
                                       "unbalance": UNBALANCE}))
    status, metrics = _compare(bag, config, mapping, tmp_path / "report")
    assert status == 1 and metrics["verdict"] == "FAIL"
    failed = [c for c in metrics["checks"] if c["passed"] is False]
    assert failed and all(wrong in c["detail"] for c in failed), failed


def test_broadband_with_burst_gaps_is_averaged_between_the_gaps(tmp_path):
    simulation = {"speed": {"type": "constant", "speed_hz": 23.0}, "duration_s": 6.0,
                  "test_signal": {"actuator": "DL", "kind": "white", "rms_n": 100.0,
                                  "band_hz": [2.0, 150.0], "seed": 3}}
    _, bag, config, mapping = _record(tmp_path / "bb", 5, simulation, test_force=True)
    status, metrics = _compare(bag, config, mapping, tmp_path / "report")
    assert status in (0, 1), metrics.get("no_verdict_reason")
    assert any("Welch segments" in n and "gaps" in n for n in metrics["notes"])
    rows = [r for r in csv.DictReader(open(tmp_path / "report" / "frf.csv"))
            if r["kind"] == "broadband"]
    assert rows and len({r["averages"] for r in rows}) == 1 and int(rows[0]["averages"]) >= 4
    for name in ("foot_DL_az", "foot_DR_az"):
        rs = [r for r in rows if r["channel"] == name and float(r["coherence"]) > 0.9]
        h1 = np.array([float(r["measured_mag"]) for r in rs])
        model = np.array([float(r["sampled_mag"]) for r in rs])
        sigma = np.array([float(r["h1_sigma_rel"]) for r in rs])
        assert len(rs) > 10 and np.mean(np.abs(h1 - model) <= 3 * sigma * h1 + 0.03 * model) > 0.8


def test_broadband_whose_gaps_leave_no_segment_is_no_verdict_not_unreadable(tmp_path):
    simulation = {"speed": {"type": "constant", "speed_hz": 23.0}, "duration_s": 2.2,
                  "test_signal": {"actuator": "DL", "kind": "white", "rms_n": 100.0,
                                  "band_hz": [2.0, 150.0], "seed": 3}}
    _, bag, config, mapping = _record(tmp_path / "bb", 6, simulation, test_force=True,
                                      rig=Rig(seed=6, drop_fraction=0.1))
    dense = yaml.safe_load(mapping.read_text())
    dense["resample"] = {"max_missing_samples": 0}            # every drop is a gap
    mapping.write_text(yaml.safe_dump(dense))
    status, metrics = _compare(bag, config, mapping, tmp_path / "report")
    assert status == 5 and metrics["verdict"] == "NO VERDICT"
    assert "broadband" in metrics["no_verdict_reason"]
    assert any("left out" in n and "gaps" in n for n in metrics["notes"])


def test_a_rig_run_up_is_tracked_over_shaft_windows_and_viewed(tmp_path):
    ramp = {"type": "ramp", "start_hz": 8.0, "stop_hz": 40.0, "duration_s": 8.0}
    ts, bag, config, mapping = _record(tmp_path / "runup", 7, {"speed": ramp})
    status, metrics = _compare(bag, config, mapping, tmp_path / "report")
    assert status in (0, 1) and metrics["one_x"]["method"].startswith("run-up windows")
    speeds = np.asarray(metrics["one_x"]["speeds_hz"])
    revolutions = 0.5 * (8.0 + 40.0) * 8.0
    # windows across a tacho burst (the angle there is not measured while the speed changes)
    # are left out and noted, never tracked at an interpolated angle
    left_out = [n for n in metrics["notes"] if n.startswith("1x window")
                and "the tacho missed" in n]
    assert speeds.size + len(left_out) >= revolutions / 8 - 3
    assert 8.0 <= speeds.min() and speeds.max() <= 40.0 and np.all(np.diff(speeds) > 0)
    views = tmp_path / "views"
    assert main(["runup", str(bag), "--config", str(config), "--map", str(mapping),
                 "--channels", "bearing_D_vz", "--out", str(views)]) == 0
    assert (views / "bode_bearing_D_vz.png").stat().st_size > 0
    assert (views / "index.html").stat().st_size > 0


@pytest.mark.parametrize("stepped", [11], indirect=True)
def test_non_finite_and_overflowing_values_are_excluded_counted_and_the_run_passes(stepped,
                                                                                    tmp_path):
    speeds, ts, _, config, mapping = stepped
    bag = write_rig_bag(tmp_path / "bad", ts, Rig(seed=3, bad_value_every=1000))
    status, metrics = _compare(bag, config, mapping, tmp_path / "report")
    assert status == 0 and metrics["verdict"] == "PASS"
    [note] = [n for n in metrics["notes"] if n.startswith("foot_DL_az")]
    n_bad = int(note.split(", ")[-1].split(" values not finite")[0])
    assert n_bad >= 0.9 * (ts.time_s[-1] * Rig().imu_rate_hz / 1000) and "excluded" in note


@pytest.mark.parametrize("stepped", [11], indirect=True)
@pytest.mark.parametrize("step_s", [86400.0, -2.0])
def test_a_sensor_clock_step_is_refused_naming_channel_and_time(stepped, tmp_path, capsys, step_s):
    _, ts, _, config, mapping = stepped
    bag = write_rig_bag(tmp_path / "clock", ts, Rig(seed=4, clock_step_s=step_s))
    status = main(["compare", str(bag), "--config", str(config), "--map", str(mapping),
                   "--out", str(tmp_path / "report")])
    err = capsys.readouterr().err
    assert status == 2 and "channels.foot_DR_az.stamp" in err and "step by" in err
    assert f"{step_s:+.6g}"[:4] in err and "Traceback" not in err and len(err.splitlines()) <= 3


@pytest.mark.parametrize("stepped", [11], indirect=True)
def test_the_resampling_grid_is_checked_against_the_memory_limit(stepped, tmp_path, capsys,
                                                                  monkeypatch):
    _, _, bag, config, mapping = stepped
    monkeypatch.setenv("ROTOR_AVC_MAX_MEMORY_GB", "0.001")
    status = main(["compare", str(bag), "--config", str(config), "--map", str(mapping),
                   "--out", str(tmp_path / "report"), "--in-memory"])
    err = capsys.readouterr().err
    assert status == 2 and "resampling grid" in err and "--max-memory-gb" in err


@pytest.mark.parametrize("stepped", [29], indirect=True)
@pytest.mark.parametrize("kind", ["stepped", "runup"])
def test_the_streamed_comparison_equals_the_one_read_whole(stepped, tmp_path, kind):
    """Read chunk by chunk (each channel fitted as it comes, one window kept) or whole: the same
    windows, speeds and 1x phasors, and the same stamp statistics per channel."""
    if kind == "stepped":
        speeds, _, bag, config, mapping = stepped
    else:
        ramp = {"type": "ramp", "start_hz": 6.0, "stop_hz": 30.0, "duration_s": 6.0}
        _, bag, config, mapping = _record(tmp_path / "runup", 5, {"speed": ramp})
    streamed = compare_mapped(bag, config, mapping)
    whole = compare_mapped(bag, config, mapping, in_memory=True)
    assert type(streamed.run).__name__ == "MappedStream"
    a, b = streamed.one_x, whole.one_x
    assert a.method == b.method and a.speed_rad_s.size >= 4
    np.testing.assert_allclose(a.speed_rad_s, b.speed_rad_s, rtol=1e-9)
    for name in a.measured:
        np.testing.assert_allclose(a.measured[name], b.measured[name], rtol=1e-6)
    # the rate is 1 / the median stamp interval: streamed, of the first 4096 intervals
    rate = re.compile(r" at ([\d.]+) Hz, ")
    notes = [sorted(n for n in c.notes if " samples at " in n) for c in (streamed, whole)]
    assert notes[0] and [rate.sub(" ", n) for n in notes[0]] == [rate.sub(" ", n) for n in notes[1]]
    np.testing.assert_allclose([float(rate.search(n).group(1)) for n in notes[0]],
                               [float(rate.search(n).group(1)) for n in notes[1]], rtol=1e-3)
    assert streamed.verdict == whole.verdict
    # read whole onto a grid, the interpolation's loss is stated at the highest shaft speed
    top = max(speeds) if kind == "stepped" else 30.0
    [loss] = re.findall(r"interpolation loss at ([\d.]+) Hz", " ".join(whole.notes))
    assert float(loss) == pytest.approx(top, rel=0.02)
