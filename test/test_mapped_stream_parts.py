"""A mapped recording compared without holding it (rotor_avc.compare.mapped_stream.MappedStream)
on a small hand-made bag read chunk by chunk, against hand computations: the run-up windows
inside the time every channel covers (a channel starting exactly at a window's start and one
ending exactly at a window's end keep those windows), each channel's 1x phasor exactly (the
signals are cosines of the shaft angle the pulses give), the notes, the assumed duration and
the refusals (too few values, a sensor clock step mid-stream and at a channel's end, a missing
topic); read whole onto a grid instead (``read_mapped_run``, with a test force or
``--in-memory``): the same clock-step refusal, the duration, the shaft's note and the
interpolation loss stated at the test band's top."""
import contextlib

import numpy as np
import pytest
import yaml

from rotor_avc.compare import mapped_run, mapped_stream
from rotor_avc.compare.comparison import RUNUP_REVOLUTIONS
from rotor_avc.compare.mapped_run import load_machine_and_map
from rotor_avc.config import find_config, load_yaml
from rotor_avc.errors import ConfigError

G = 9.80665
T0_NS = 1_764_600_000_000_000_000
#: pulse times of a run-up from 10 Hz at 10 Hz/s (revolutions 10 t + 5 t^2 = k), in ns
PULSES_NS = T0_NS + np.round(1e9 * (-10.0 + np.sqrt(100.0 + 20.0 * np.arange(41))) / 10.0
                             ).astype(np.int64)
P_S = (PULSES_NS - T0_NS) * 1e-9
AMPS = {"foot_DL_az": 0.3 * np.exp(0.7j), "foot_DR_az": 0.05 * np.exp(-2.0j),
        "bearing_D_vz": 2e-4 * np.exp(1.9j)}


class Series:
    """A topic's series as the bag reader gives it: fields by name, log times."""

    def __init__(self, topic, stamps_ns, log_ns, **fields):
        self.topic, self.time_ns = topic, np.asarray(log_ns, np.int64)
        stamps_ns = np.asarray(stamps_ns, np.int64)
        self.fields = {"header.stamp.sec": stamps_ns // 1_000_000_000,
                       "header.stamp.nanosec": stamps_ns % 1_000_000_000, **fields}

    def __getitem__(self, name):
        return self.fields[name]

    def part(self, sl):
        return Series.__new__(Series).__init_part(self, sl)

    def __init_part(self, whole, sl):
        self.topic, self.time_ns = whole.topic, whole.time_ns[sl]
        self.fields = {k: v[sl] for k, v in whole.fields.items()}
        return self


class Bag:
    def __init__(self, *series, chunks=3):
        self.topics = {s.topic: s for s in series}
        self.path, self.chunks = "rig.mcap", chunks

    def series(self, topic):
        return self.topics[topic]

    def series_chunks(self, topic):
        s = self.topics[topic]
        for idx in np.array_split(np.arange(s.time_ns.size), self.chunks):
            yield s.part(slice(idx[0], idx[-1] + 1))


def angle(t_s):
    """The shaft angle the pulses give: 2 pi k at pulse k, linear between them."""
    return np.interp(t_s, P_S, 2 * np.pi * np.arange(P_S.size))


def channel(first_ns, last_ns, step_ns, amp):
    stamps = np.arange(first_ns, last_ns, step_ns, dtype=np.int64)
    stamps = np.append(stamps, last_ns)
    return stamps, (amp * np.exp(1j * angle((stamps - T0_NS) * 1e-9))).real


def recording(dropout=None, nan_values=0, imu=None, vel=None):
    """/tacho pulses; /imu (two fields, header stamps, 1 kHz) from pulse 8 to pulse 40; /vel
    (log stamps, 500 Hz) from pulse 2 to pulse 32."""
    imu_ns, dl = channel(PULSES_NS[8], PULSES_NS[40], 1_000_000, AMPS["foot_DL_az"])
    _, dr = channel(PULSES_NS[8], PULSES_NS[40], 1_000_000, AMPS["foot_DR_az"])
    vel_ns, vz = channel(PULSES_NS[2], PULSES_NS[32], 2_000_000, AMPS["bearing_D_vz"])
    if nan_values:
        dl[100:100 + nan_values] = np.nan
    keep = np.ones(vel_ns.size, bool)
    if dropout is not None:
        keep = (vel_ns < PULSES_NS[dropout[0]] + 2_000_000) | \
            (vel_ns > PULSES_NS[dropout[1]] - 2_000_000)
    imu = imu or {}
    tacho = Series("/tacho", PULSES_NS, PULSES_NS + 50_000)
    return Bag(tacho,
               Series("/imu", imu.get("stamps", imu_ns), imu_ns + 200_000,
                      **{"a.z": -dl / G, "b.z": dr}),
               Series("/vel", vel_ns[keep] - 7_000_000, vel_ns[keep], data=vz[keep]))


def write_map(path, **rest):
    path.write_text(yaml.safe_dump({
        "channels": {"foot_DL_az": {"topic": "/imu", "field": "a.z", "sign": -1, "scale": G},
                     "foot_DR_az": {"topic": "/imu", "field": "b.z"},
                     "bearing_D_vz": {"topic": "/vel", "field": "data", "stamp": "log"}},
        "shaft": {"source": "pulse", "topic": "/tacho"}, **rest}))
    return path


@pytest.fixture(scope="module")
def loaded(tmp_path_factory):
    path = write_map(tmp_path_factory.mktemp("map") / "map.yaml")
    return load_machine_and_map("foot_mount_case3", path), path


def stream(monkeypatch, loaded, bag):
    monkeypatch.setattr(mapped_stream, "open_bag", lambda path, **kw: contextlib.nullcontext(bag))
    return mapped_stream.MappedStream("rig.mcap", None, loaded[1], loaded[0])


def whole(monkeypatch, loaded, bag):
    """The recording read whole onto a grid (``read_mapped_run``, as with ``--in-memory``)."""
    monkeypatch.setattr(mapped_run, "open_bag", lambda path, **kw: contextlib.nullcontext(bag))
    return mapped_run.read_mapped_run("rig.mcap", None, loaded[1], loaded[0])


def test_run_up_windows_inside_every_channel_and_their_exact_1x(monkeypatch, loaded):
    run = stream(monkeypatch, loaded, recording(nan_values=3))
    # 40 revolutions in windows of 8: [p0, p8] ... [p32, p40]; /imu starts at p8, /vel ends at
    # p32, exactly: [p8, p16], [p16, p24], [p24, p32]
    assert RUNUP_REVOLUTIONS == 8 and not run.shaft.dwells
    np.testing.assert_allclose([w[:2] for w in run.windows], [(P_S[i], P_S[i + 8])
                                                              for i in (8, 16, 24)], atol=1e-12)
    names = list(AMPS)
    track, method, settings = run.tracking(names, 1.0, RUNUP_REVOLUTIONS)
    assert method.startswith("run-up") and settings["windows_left_out"] == 0
    np.testing.assert_allclose(track.speed_rad_s, [2 * np.pi * 8 / (P_S[i + 8] - P_S[i])
                                                   for i in (8, 16, 24)], rtol=1e-12)
    for name in names:
        np.testing.assert_allclose(track.phasors[name], AMPS[name], rtol=1e-9)
    # the time every channel covers: from /imu's first stamp to /vel's last
    span = P_S[32] - P_S[8]
    assert run.assumptions["duration_s"]["value"] == pytest.approx(span, abs=1e-12)
    assert run.scenario.duration_s == pytest.approx(span, abs=1e-12)
    notes = run.notes
    by_channel = {n.split(" ")[0]: n for n in notes if " samples at " in n}
    assert set(by_channel) == set(names)
    assert by_channel["foot_DL_az"].startswith("foot_DL_az (/imu): ")
    assert by_channel["foot_DL_az"].endswith(", 3 values not finite or beyond 1e+100 excluded")
    assert "excluded" not in by_channel["foot_DR_az"]
    assert " samples at 500 Hz" in by_channel["bearing_D_vz"]
    assert any(n.startswith("shaft (pulse, /tacho): 41 pulses") for n in notes)
    assert "order tracking streamed: each channel fitted at its own stamps in 3 shaft windows, " \
           "read chunk by chunk (no resampling grid)" in notes
    assert [n for n in notes if n.startswith("assumed: ")] == [
        "assumed: " + mapped_stream.describe_assumptions(run.assumptions)]
    assert f"duration_s {span:.6g} (the time every mapped channel covers)" in notes[-1]
    assert list(run.dwells()) == [] and sorted(run.channel_names) == sorted(names)
    assert run.sample_period_s == run.scenario.sample_period_s
    with pytest.raises(ValueError, match="cut for 8 revolutions"):
        run.tracking(names, 1.0, 4)


def test_a_window_a_channel_has_too_few_samples_in_is_left_out_and_counted(monkeypatch, loaded):
    run = stream(monkeypatch, loaded, recording(dropout=(16, 24)))
    track, _, settings = run.tracking(list(AMPS), 1.0, RUNUP_REVOLUTIONS)
    assert track.speed_rad_s.size == 2 and settings["windows_left_out"] == 1
    assert sum("bearing_D_vz have fewer than 4 samples per revolution" in n
               for n in run.notes) == 1


def test_a_channel_with_fewer_than_three_values_is_refused(monkeypatch, loaded):
    bag = recording()
    vel = bag.topics["/vel"]
    vel.fields["data"] = np.full(vel.time_ns.size, np.nan)
    vel.fields["data"][:2] = 1.0
    with pytest.raises(ConfigError, match=rf"channels.bearing_D_vz.field: 'data' of /vel has 2 "
                                          rf"finite values of {vel.time_ns.size}"):
        stream(monkeypatch, loaded, bag)
    bag = recording()
    data = bag.topics["/vel"].fields["data"]
    data[1:-1] = np.nan
    data[data.size // 2] = 1.0
    run = stream(monkeypatch, loaded, bag)             # three are enough to be read
    assert any(n.startswith("bearing_D_vz (/vel): 3 samples") for n in run.notes)


@pytest.mark.parametrize("at", [500, -10])
def test_a_sensor_clock_step_is_refused_naming_the_channel_and_its_time(monkeypatch, loaded, at):
    """The /imu header clock jumps 2 s ahead at sample ``at`` (mid-stream, or among the last
    samples, judged when the channel ends)."""
    imu_ns, _ = channel(PULSES_NS[8], PULSES_NS[40], 1_000_000, 1.0)
    stepped = imu_ns.copy()
    stepped[at:] += 2_000_000_000
    bag = recording(imu={"stamps": stepped})
    with pytest.raises(ConfigError) as err:
        stream(monkeypatch, loaded, bag)
    # the step at its log time (stamp + 0.2 ms) from the first pulse's stamp
    log_s = (imu_ns[at] + 200_000 - T0_NS) * 1e-9
    assert err.value.field == "channels.foot_DL_az.stamp" or \
        err.value.field == "channels.foot_DR_az.stamp"
    text = str(err.value)
    assert "the header stamps of /imu step by +2 s" in text and "(1 clock step(s)" in text
    assert f"at {log_s:.6g} s into the recording" in text
    with pytest.raises(ConfigError, match=r"the header stamps of /imu step by \+2 s .*\(1 clock "
                                          r"step\(s\)") as err:
        whole(monkeypatch, loaded, bag)                  # read whole: refused the same way
    assert err.value.field == "channels.foot_DL_az.stamp"


def test_a_mapped_topic_missing_from_the_bag_is_refused(monkeypatch, loaded):
    bag = recording()
    del bag.topics["/vel"]
    with pytest.raises(ConfigError, match=r"channels.bearing_D_vz.topic: no topic /vel"):
        stream(monkeypatch, loaded, bag)


def test_compare_streams_a_recording_without_a_test_force_or_reads_it_whole(monkeypatch,
                                                                           tmp_path):
    """``compare_mapped``: streamed by default, read whole onto a grid with ``in_memory``; the
    same windows and 1x phasors either way (each channel fitted at its own stamps)."""
    bag = recording()
    for module in (mapped_stream, mapped_run):
        monkeypatch.setattr(module, "open_bag", lambda path, **kw: contextlib.nullcontext(bag))
    path = write_map(tmp_path / "map.yaml",
                     unbalance={"static": {"magnitude": 1e-2, "phase_deg": 0.0}})
    streamed = mapped_stream.compare_mapped("rig.mcap", "foot_mount_case3", path)
    whole = mapped_stream.compare_mapped("rig.mcap", "foot_mount_case3", path, in_memory=True)
    assert type(streamed.run).__name__ == "MappedStream"
    assert type(whole.run).__name__ == "RecordedRun"
    assert any("order tracking streamed" in n for n in streamed.notes)
    assert any(n.startswith("resampling: linear interpolation") for n in whole.notes)
    a, b = streamed.one_x, whole.one_x
    assert a.method == b.method and a.speed_rad_s.size == 3
    np.testing.assert_allclose(a.speed_rad_s, b.speed_rad_s, rtol=1e-12)
    for name in a.measured:
        np.testing.assert_allclose(a.measured[name], b.measured[name], rtol=1e-9)


def test_read_whole_with_a_test_force_states_the_loss_at_the_band_top(monkeypatch, tmp_path):
    """Read whole onto a grid (a test force on /shaker from pulse 4 to 36): the duration is the
    time every channel covers (from /imu's first stamp to /vel's last), the shaft is described,
    and the interpolation loss is stated at the test band's top, 400 Hz, above the 30 Hz top
    shaft speed (10 + 10 t Hz at t = 2 s)."""
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"test_signal": {"actuator": "DL", "kind": "white", "rms_n": 100.0,
                                          "band_hz": [2.0, 400.0]}}
    config = tmp_path / "machine.yaml"
    config.write_text(yaml.safe_dump(data))
    path = write_map(tmp_path / "map.yaml", test_force={"topic": "/shaker", "field": "data"})
    bag = recording()
    shaker_ns = np.arange(PULSES_NS[4], PULSES_NS[36], 500_000, dtype=np.int64)
    bag.topics["/shaker"] = Series("/shaker", shaker_ns, shaker_ns + 100_000,
                                   data=np.sin(2 * np.pi * 100.0 * (shaker_ns - T0_NS) * 1e-9))
    run = whole(monkeypatch, (load_machine_and_map(config, path), path), bag)
    span = P_S[32] - P_S[8]
    assert run.assumptions["duration_s"]["value"] == pytest.approx(span, abs=1e-12)
    assert any(n.startswith("shaft (pulse, /tacho): 41 pulses") for n in run.notes)
    [loss] = [n for n in run.notes if n.startswith("resampling: linear interpolation")]
    assert "interpolation loss at 400 Hz: " in loss
    assert run.test_source == "recorded (/shaker)"
