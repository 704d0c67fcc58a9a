"""Rig-style recordings for the tests: a simulated run of a shipped machine as a test rig's
drivers would record it, written by rosbags as a split rosbag2 directory (no rotor_avc metadata),
with the imperfections of a real rig (:class:`Rig`):

* foot accelerometers as sensor_msgs/Imu at ``imu_rate_hz``, each mounted on another axis
  (the model's vertical is the sensor's ``-y``, ``x`` or ``-z``) and publishing in g;
* bearing-housing velocities as geometry_msgs/Vector3Stamped at ``velocity_rate_hz``, in mm/s,
  in a frame turned 90 degrees about y (the model's vertical is the sensor's ``-x``);
* a once-per-revolution tacho pulse only (std_msgs/Header), with missing pulses (the drops),
  duplicate pulses (contact bounce ``bounce_s`` after a fraction ``bounce_fraction``) and jitter;
* white noise ``snr_db`` below each channel's RMS, stamp jitter ``jitter_s`` on the sensor clock,
  log time = stamp + latency (``latency_s`` + an exponential tail of mean ``latency_tail_s``),
  and ``drop_fraction`` of every topic's messages dropped, half of them singly and half in
  bursts of ``burst_samples`` consecutive messages.

Sensors sample the simulated signals at the simulator's own samples (their rates divide its
rate), so the signals are exact and only the stated imperfections differ. :func:`clean_one_x`
is the independent truth: a least-squares 1x fit (numpy's lstsq, written here) of the clean,
complete simulated signal at the simulator's angle over a dwell's second half.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rosbags.typesys.stores.ros2_jazzy import (geometry_msgs__msg__Quaternion as Quaternion,
                                               geometry_msgs__msg__Vector3 as Vector3,
                                               geometry_msgs__msg__Vector3Stamped as Vector3Stamped,
                                               geometry_msgs__msg__Wrench as Wrench,
                                               geometry_msgs__msg__WrenchStamped as WrenchStamped,
                                               sensor_msgs__msg__Imu as Imu,
                                               std_msgs__msg__Header as Header)
from rosbag2_corpus import EPOCH_NS, G, TYPESTORE, _header, pulse_times, write_split_bag

#: per foot: (Imu axis carrying the model's vertical, its sign)
IMU_AXES = {"DL": ("y", -1.0), "DR": ("x", 1.0), "NL": ("z", -1.0)}
#: bearing velocity sensors: the model's vertical is the sensor's -x, in mm/s
VELOCITY_AXIS, VELOCITY_SIGN, MM = "x", -1.0, 1e-3


@dataclass(frozen=True)
class Rig:
    imu_rate_hz: float = 1000.0
    velocity_rate_hz: float = 1250.0
    snr_db: float = 40.0
    jitter_s: float = 20e-6
    latency_s: float = 400e-6
    latency_tail_s: float = 300e-6
    drop_fraction: float = 0.012
    burst_samples: tuple[int, int] = (5, 60)
    bounce_fraction: float = 0.005
    bounce_s: float = 150e-6
    #: hostile cases: every this many samples of the DL accelerometer a NaN (0: none), plus
    #: one value of 1.7e308; the DR accelerometer's clock stepping by this much halfway
    bad_value_every: int = 0
    clock_step_s: float = 0.0
    seed: int = 0


def _drops(n: int, rig: Rig, rng) -> np.ndarray:
    """Keep-mask: half of the dropped fraction single, half in bursts."""
    keep = rng.random(n) >= 0.5 * rig.drop_fraction
    lo, hi = rig.burst_samples
    budget = int(0.5 * rig.drop_fraction * n)
    while budget > 0:
        length = int(rng.integers(lo, hi + 1))
        start = int(rng.integers(0, max(1, n - length)))
        keep[start:start + length] = False
        budget -= length
    return keep


def _stamps(t, rig: Rig, rng):
    stamp = EPOCH_NS + np.round((t + rig.jitter_s * rng.standard_normal(t.size)) * 1e9)
    log = stamp + np.round((rig.latency_s + rng.exponential(rig.latency_tail_s, t.size)) * 1e9)
    return stamp.astype(np.int64), log.astype(np.int64)


def _imu(t_ns, value, axis, frame):
    z = np.zeros(9)
    acc = {k: 0.0 for k in "xyz"}
    acc[axis] = float(value)
    return Imu(_header(t_ns, frame), Quaternion(0.0, 0.0, 0.0, 1.0), z, Vector3(0.0, 0.0, 0.0),
               z, Vector3(acc["x"], acc["y"], acc["z"]), z)


def _velocity(t_ns, value, frame):
    v = {k: 0.0 for k in "xyz"}
    v[VELOCITY_AXIS] = float(value)
    return Vector3Stamped(_header(t_ns, frame), Vector3(v["x"], v["y"], v["z"]))


def _sensor(ts, name: str, rate_hz: float, rig: Rig, rng):
    """``(sample times s, noisy values in SI)`` of one channel at ``rate_hz``."""
    fs = 1.0 / float(ts.time_s[1] - ts.time_s[0])
    step = int(round(fs / rate_hz))
    assert abs(fs / step - rate_hz) < 1e-6 * rate_hz, "sensor rates must divide the run's"
    t, y = np.asarray(ts.time_s)[::step], np.asarray(ts.channels[name])[::step]
    return t, y + rng.standard_normal(y.size) * np.std(y) * 10 ** (-rig.snr_db / 20)


def rig_messages(ts, rig: Rig = Rig()) -> list:
    """``(log ns, topic, msg type, CDR bytes)`` of the run ``ts`` (unsorted)."""
    rng = np.random.default_rng(rig.seed)
    out = []

    def emit(topic, cls, t, make):
        keep = _drops(t.size, rig, rng)
        stamp, log = _stamps(t, rig, rng)
        if topic == "/rig/imu_dr/data":
            stamp[t.size // 2:] += int(round(rig.clock_step_s * 1e9))
        for k in np.flatnonzero(keep):
            out.append((int(log[k]), topic, cls.__msgtype__,
                        TYPESTORE.serialize_cdr(make(k, int(stamp[k])), cls.__msgtype__)))

    for foot, (axis, sign) in IMU_AXES.items():
        t, y = _sensor(ts, f"foot_{foot}_az", rig.imu_rate_hz, rig, rng)
        if foot == "DL" and rig.bad_value_every:
            y[::rig.bad_value_every] = np.nan
            y[rig.bad_value_every // 2] = 1.7e308 * G
        emit(f"/rig/imu_{foot.lower()}/data", Imu, t,
             lambda k, s, y=y, axis=axis, sign=sign, f=foot: _imu(s, sign * y[k] / G, axis, f))
    for b in ("D", "N"):
        t, y = _sensor(ts, f"bearing_{b}_vz", rig.velocity_rate_hz, rig, rng)
        emit(f"/rig/bearing_{b.lower()}/velocity", Vector3Stamped, t,
             lambda k, s, y=y, b=b: _velocity(s, VELOCITY_SIGN * y[k] / MM, b))
    if "test_signal_DL_fz" in ts.channels:          # the shaker's force, sampled with the Imus
        t, f = _sensor(ts, "test_signal_DL_fz", rig.imu_rate_hz, rig, rng)
        emit("/rig/shaker/force", WrenchStamped, t,
             lambda k, s, f=f: WrenchStamped(_header(s, "shaker"), Wrench(
                 Vector3(0.0, 0.0, float(f[k])), Vector3(0.0, 0.0, 0.0))))
    pulses = pulse_times(np.asarray(ts.time_s), np.asarray(ts.angle_rad))
    bounce = pulses[rng.random(pulses.size) < rig.bounce_fraction] + rig.bounce_s
    ticks = np.sort(np.concatenate([pulses, bounce]))
    emit("/rig/tacho", Header, ticks, lambda k, s: _header(s, "tacho"))
    return out


def write_rig_bag(directory, ts, rig: Rig = Rig()):
    return write_split_bag(directory, rig_messages(ts, rig))


def rig_map(*, wrong_sign: str | None = None, wrong_axis: str | None = None,
            test_force: bool = False) -> dict:
    """The mapping file of a rig bag; ``wrong_sign`` / ``wrong_axis`` (a channel name) maps that
    channel with the sign flipped or from an axis that does not carry the vertical."""
    channels = {}
    for foot, (axis, sign) in IMU_AXES.items():
        channels[f"foot_{foot}_az"] = {"topic": f"/rig/imu_{foot.lower()}/data",
                                       "field": f"linear_acceleration.{axis}",
                                       "sign": sign, "scale": G}
    for b in ("D", "N"):
        channels[f"bearing_{b}_vz"] = {"topic": f"/rig/bearing_{b.lower()}/velocity",
                                       "field": f"vector.{VELOCITY_AXIS}",
                                       "sign": VELOCITY_SIGN, "scale": MM}
    if wrong_sign is not None:
        channels[wrong_sign]["sign"] *= -1
    if wrong_axis is not None:
        field = channels[wrong_axis]["field"]
        others = [a for a in "xyz" if not field.endswith(a)]
        channels[wrong_axis]["field"] = field[:-1] + others[0]
    out = {"channels": channels, "shaft": {"source": "pulse", "topic": "/rig/tacho"}}
    if test_force:
        out["test_force"] = {"topic": "/rig/shaker/force", "field": "wrench.force.z"}
    return out


def clean_one_x(ts, name: str, start_s: float, stop_s: float, unbalance: complex) -> complex:
    """The independent truth: least squares of ``y = a cos(theta) + b sin(theta) + c`` over the
    clean simulated samples in ``[start_s, stop_s)`` at the simulator's angle; ``(a - j b) / u``."""
    t = np.asarray(ts.time_s)
    sel = (t >= start_s) & (t < stop_s)
    theta = np.asarray(ts.angle_rad)[sel]
    A = np.column_stack([np.cos(theta), np.sin(theta), np.ones(theta.size)])
    (a, b, _), *_ = np.linalg.lstsq(A, np.asarray(ts.channels[name])[sel], rcond=None)
    return complex(a, -b) / unbalance
