"""The mapping file of ``rotor-avc compare BAG --config MACHINE.yaml --map MAP.yaml``: which
recorded topic and field is which model signal (typed, frozen settings as
:mod:`rotor_avc.settings` declares them; unknown keys refused, every error names the field)::

    channels:                      # model signal -> recorded field
      foot_DL_az: {topic: /imu_foot_dl/data, field: linear_acceleration.z, sign: -1, scale: 9.80665}
      bearing_D_vz: {topic: /vel_bearing_d/data, field: data[0]}
    test_force: {topic: /shaker/force, field: wrench.force.z}       # optional
    shaft: {source: pulse, topic: /tacho/pulse}                      # or angle / joint_state
    unbalance: {static: {magnitude: 1.0e-2, phase_deg: 0.0}}         # optional
    resample: {max_missing_samples: 4}

A model signal is a plant output, a foot signal ``foot_<id>_a<axis>`` or an actuator force
``actuator_<id>_f<axis>`` of the machine; its SI value is ``sign * scale * recorded value``.
Stamps come from ``header.stamp`` (the sensor's clock) or the bag's log time (``stamp: log``).
``unbalance`` (the reference of the 1x response, as ``simulation.unbalance``) replaces the
configuration's; ``test_force`` needs the configuration's ``simulation.test_signal`` (actuator,
band).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..config import load_yaml
from ..section import Section
from ..settings import read_settings, setting

STAMPS = ("header", "log")
SHAFT_SOURCES = ("pulse", "angle", "joint_state")
#: the angle field of a shaft source when the mapping does not name one
DEFAULT_ANGLE_FIELD = {"angle": "data", "joint_state": "position[0]"}


@dataclass(frozen=True)
class SignalMap:
    """One recorded field as one model signal."""

    topic: str = setting(doc="recorded topic (absolute name)")
    field: str = setting(doc="numeric field: `linear_acceleration.z`, `data[2]`, a label of a "
                             "labelled array")
    sign: float = setting(1.0, "+1 or -1: the sensor's axis against the model's")
    scale: float = setting(1.0, "SI value per recorded unit (9.80665 for an accelerometer in g)",
                           positive=True)
    stamp: str = setting("header", "`header` (header.stamp, the sensor's clock) or `log` (the "
                         "bag's log time)", choices=STAMPS)

    def check(self, sec: Section) -> None:
        if self.sign not in (-1.0, 1.0):
            raise sec.error("sign", f"must be +1 or -1 (got {self.sign:g})",
                            fix="put the magnitude into scale")
        if not self.topic.startswith("/"):
            raise sec.error("topic", f"{self.topic!r} is not an absolute topic name",
                            fix="write it as `ros2 bag info` lists it, e.g. /imu/data")


@dataclass(frozen=True)
class ShaftMap:
    """Where shaft angle and speed come from."""

    source: str = setting(doc="`pulse` (once-per-revolution tacho), `angle` (encoder angle, rad) "
                              "or `joint_state` (sensor_msgs/JointState)", choices=SHAFT_SOURCES)
    topic: str = setting(doc="recorded topic")
    field: str | None = setting(None, "angle field in rad (default `data` for angle, "
                                "`position[0]` for joint_state; unused for pulse)")
    stamp: str = setting("header", "`header` or `log`", choices=STAMPS)
    pulse_angle_deg: float = setting(0.0, "shaft angle at a pulse, in the unbalance's phase "
                                     "reference (pulse only)", unit="deg")
    dwell_tol: float = setting(0.002, "relative speed spread within a constant-speed dwell",
                               positive=True, maximum=0.1)
    min_dwell_revolutions: int = setting(8, "revolutions of the shortest dwell", minimum=2)


@dataclass(frozen=True)
class ResampleMap:
    """Linear resampling onto the configuration's sample grid."""

    max_missing_samples: int = setting(4, "grid points inside a gap of more consecutive missing "
                                       "samples of a channel are excluded", minimum=0)


@dataclass(frozen=True)
class RecordingMap:
    """The whole mapping file."""

    channels: dict = setting(doc="model signal -> {topic, field, sign, scale, stamp}")
    shaft: ShaftMap = setting(doc="shaft angle and speed")
    test_force: SignalMap | None = setting(None, "the broadband test force (N) on the "
                                           "configuration's test_signal actuator")
    unbalance: dict | None = setting(None, "the unbalance reference (as simulation.unbalance)")
    resample: ResampleMap = setting(ResampleMap, "resampling")


def read_map(path, signal_names) -> tuple[RecordingMap, dict[str, SignalMap]]:
    """Validate a mapping file: ``(map, channel name -> SignalMap)``; ``signal_names`` are the
    machine's model signals a channel may name."""
    sec = Section(load_yaml(path), "", str(path))
    rmap = read_settings(RecordingMap, sec)
    chans = sec.section("channels")
    if not chans.keys():
        raise chans.error("", "maps no channel", fix="map at least one model signal")
    signals = {}
    for name in chans.keys():
        if name not in signal_names:
            raise chans.error(str(name), "is not a signal of the machine",
                              fix="use one of: " + ", ".join(signal_names))
        signals[name] = read_settings(SignalMap, chans.section(name))
    return rmap, signals
