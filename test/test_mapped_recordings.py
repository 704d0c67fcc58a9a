"""The mapping of a foreign recording (rotor_avc.compare.recording_map, mapped_run) on small
hand-made inputs: the SI value is sign x scale x the recorded value, stamps come from the header
or the log as mapped, the pulse angle sets the shaft angle at every pulse, the shaft's speed and
dwells come from the pulse intervals, and a mapping's errors name the field."""
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from rotor_avc.compare import mapped_run
from rotor_avc.compare.recording_map import SignalMap, ShaftMap, read_map
from rotor_avc.errors import ConfigError

G = 9.80665
SIGNALS = ["foot_DL_az", "foot_DR_az", "actuator_DL_fz"]


class Series:
    """A topic's series as BagReader.series gives it: fields by name, log times."""

    def __init__(self, topic, stamps_ns, log_ns, **fields):
        self.topic = topic
        self.time_ns = np.asarray(log_ns, np.int64)
        self.fields = {"header.stamp.sec": np.asarray(stamps_ns) // 1_000_000_000,
                       "header.stamp.nanosec": np.asarray(stamps_ns) % 1_000_000_000, **fields}

    def __getitem__(self, name):
        return self.fields[name]


def bag_of(*series):
    by_topic = {s.topic: s for s in series}
    return SimpleNamespace(topics=by_topic, path="rig.mcap", series=by_topic.__getitem__)


def write_map(tmp_path, channels, **rest):
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump({"channels": channels,
                                    "shaft": {"source": "pulse", "topic": "/tacho"}, **rest}))
    return path


def test_a_mapped_field_is_sign_times_scale_times_the_recording():
    stamps = 1_764_600_000_000_000_000 + np.arange(5) * 200_000      # 5 kHz sensor clock
    log = stamps + 150_000                                             # transport latency
    raw = np.array([0.1, -0.2, 0.3, np.nan, 0.5])
    bag = bag_of(Series("/imu", stamps, log, **{"linear_acceleration.z": raw}))
    sig = SignalMap(topic="/imu", field="linear_acceleration.z", sign=-1.0, scale=G)
    t, si, excluded = mapped_run._read_field(bag, sig, "channels.foot_DL_az", "map.yaml")
    keep = np.isfinite(raw)
    np.testing.assert_array_equal(t, stamps[keep])                   # the sensor's clock
    np.testing.assert_allclose(si, -G * raw[keep], rtol=1e-15)
    assert excluded == 1
    logged = SignalMap(topic="/imu", field="linear_acceleration.z", stamp="log")
    t, si, _ = mapped_run._read_field(bag, logged, "channels.foot_DL_az", "map.yaml")
    np.testing.assert_array_equal(t, log[keep])
    np.testing.assert_allclose(si, raw[keep], rtol=1e-15)


def test_an_unknown_topic_or_field_is_refused_naming_it():
    bag = bag_of(Series("/imu", np.arange(5), np.arange(5), data=np.ones(5)))
    with pytest.raises(ConfigError, match=r"channels.foot_DL_az.topic.*no topic /acc"):
        mapped_run._read_field(bag, SignalMap(topic="/acc", field="data"), "channels.foot_DL_az",
                               "map.yaml")
    empty = bag_of(Series("/imu", np.arange(5), np.arange(5), data=np.full(5, np.nan)))
    with pytest.raises(ConfigError, match=r"foot_DL_az.field: 'data' of /imu has 0 finite"):
        mapped_run._read_field(empty, SignalMap(topic="/imu", field="data"), "channels.foot_DL_az",
                               "map.yaml")

@pytest.mark.parametrize("pulse_angle_deg", [0.0, 40.0, -90.0])
def test_the_pulse_angle_is_the_shaft_angle_at_every_pulse(pulse_angle_deg):
    speed_hz = 25.0
    pulses = np.arange(40) / speed_hz
    grid = np.linspace(0.0, pulses[-1], 2001)
    shaft_map = ShaftMap(source="pulse", topic="/tacho", pulse_angle_deg=pulse_angle_deg)
    shaft, note = mapped_run.shaft_of(shaft_map, pulses, None, grid)
    # hand computation: angle = pulse angle + 2 pi speed t on a constant-speed shaft
    expected = np.radians(pulse_angle_deg) + 2 * np.pi * speed_hz * grid
    np.testing.assert_allclose(shaft.angle_rad, expected, atol=1e-9)
    np.testing.assert_allclose(shaft.speed_rad_s, 2 * np.pi * speed_hz, rtol=1e-12)
    assert [(a, b) for a, b, _ in shaft.dwells] == [(0.0, pulses[-1])]
    assert shaft.dwells[0][2] == pytest.approx(speed_hz, rel=1e-12)
    assert note.startswith("shaft (pulse, /tacho): ") and "dwells: 25 Hz (0-1.56 s)" in note
    assert mapped_run.top_speed_hz(shaft_map, pulses, None) == pytest.approx(speed_hz, rel=1e-12)


def test_an_encoder_angle_gives_the_shaft_and_its_top_speed():
    t = np.arange(0.0, 1.0, 1e-3)
    speed_hz = 12.0 + 6.0 * t                    # a run-up, 12 -> 18 Hz
    theta = 2 * np.pi * (12.0 * t + 3.0 * t ** 2)
    wrapped = np.mod(theta, 2 * np.pi)
    shaft_map = ShaftMap(source="angle", topic="/enc")
    top = mapped_run.top_speed_hz(shaft_map, t, wrapped)
    # the shortest revolution ends at the record's last crossing: its mean speed is just below 18
    assert 17.0 < top < 18.0 and top == pytest.approx(speed_hz[-1], rel=0.05)
    shaft, _ = mapped_run.shaft_of(shaft_map, t, wrapped, t)
    np.testing.assert_allclose(shaft.angle_rad, theta, atol=1e-9)
    # valid from the first to the last whole revolution: 12 t + 3 t^2 = 14 at t = 0.9439 s
    last = (-12.0 + np.sqrt(144.0 + 12.0 * 14)) / 6.0
    assert shaft.valid[t < last - 1e-3].all() and not shaft.valid[t > last + 1e-3].any()
    assert not shaft.dwells


@pytest.mark.parametrize("change, error", [
    (lambda c: c["foot_DL_az"].update(sign=0.5), r"channels.foot_DL_az.sign: must be \+1 or -1"),
    (lambda c: c["foot_DL_az"].update(sign=-2),
     r"channels.foot_DL_az.sign: must be \+1 or -1 \(got -2\)"),
    (lambda c: c["foot_DL_az"].update(topic="imu"), r"channels.foot_DL_az.topic: 'imu' is not an"),
    (lambda c: c.update(foot_XX_az={"topic": "/x", "field": "data"}),
     r"channels.foot_XX_az.*is not a signal of the machine"),
    (lambda c: c.clear(), r"channels.*maps no channel"),
])
def test_mapping_errors_name_the_field(tmp_path, change, error):
    channels = {"foot_DL_az": {"topic": "/imu", "field": "linear_acceleration.z", "sign": -1,
                               "scale": G}}
    change(channels)
    with pytest.raises(ConfigError, match=error):
        read_map(write_map(tmp_path, channels), SIGNALS)


def test_a_valid_mapping_reads_with_its_defaults(tmp_path):
    rmap, signals = read_map(write_map(tmp_path, {
        "foot_DL_az": {"topic": "/imu", "field": "linear_acceleration.z", "sign": -1, "scale": G},
        "foot_DR_az": {"topic": "/imu2", "field": "data[0]", "stamp": "log"}}), SIGNALS)
    assert signals["foot_DL_az"] == SignalMap("/imu", "linear_acceleration.z", -1.0, G, "header")
    assert signals["foot_DR_az"] == SignalMap("/imu2", "data[0]", 1.0, 1.0, "log")
    assert rmap.shaft == ShaftMap("pulse", "/tacho")
    assert (rmap.shaft.pulse_angle_deg, rmap.shaft.dwell_tol, rmap.shaft.min_dwell_revolutions) \
        == (0.0, 0.002, 8)
    assert rmap.resample.max_missing_samples == 4 and rmap.test_force is None


@pytest.mark.parametrize("section, key, accepted, refused", [
    ("shaft", "dwell_tol", 0.1, 0.11),
    ("shaft", "min_dwell_revolutions", 2, 1),
    ("resample", "max_missing_samples", 0, -1)])
def test_the_bounds_of_the_shaft_and_resampling_settings(tmp_path, section, key, accepted, refused):
    """The declared bounds: a dwell spread of at most 10 %, dwells of at least 2 revolutions,
    no negative gap length; the bound itself is accepted."""
    channels = {"foot_DL_az": {"topic": "/imu", "field": "data"}}
    extra = {"source": "pulse", "topic": "/tacho"} if section == "shaft" else {}
    rmap, _ = read_map(write_map(tmp_path, channels, **{section: {**extra, key: accepted}}),
                       SIGNALS)
    assert getattr(getattr(rmap, section), key) == accepted
    with pytest.raises(ConfigError, match=rf"{section}.{key}: must be"):
        read_map(write_map(tmp_path, channels, **{section: {**extra, key: refused}}), SIGNALS)
