"""The recorded topics and message types (DESIGN.md section 4), and time series -> bag streams.

Namespace ``/<machine>``, default ``/avc``; all types are standard ROS 2 messages (SI units):

* ``/avc/rotor/joint_state`` -- sensor_msgs/msg/JointState: ``name = ["rotor"]``,
  ``position`` = shaft angle (rad, integrated, not wrapped), ``velocity`` = Omega (rad/s),
  ``effort`` empty;
* ``/avc/foot/<id>/acceleration`` -- geometry_msgs/msg/AccelStamped: ``accel.linear.z``
  (m/s^2), frame ``foot_<id>``; for a controller fed back on velocity or displacement also
  ``/avc/foot/<id>/velocity`` (geometry_msgs/msg/TwistStamped, ``twist.linear.z``, m/s) and
  ``/avc/foot/<id>/displacement`` (geometry_msgs/msg/PointStamped, ``point.z``, m); the
  component is the actuator's axis (z for foot mounts);
* ``/avc/foot/<id>/actuator_force`` -- geometry_msgs/msg/WrenchStamped: ``wrench.force.z`` (N),
  frame ``foot_<id>``, stamp = the measurement it answers;
* ``/avc/plant/observables`` -- std_msgs/msg/Float64MultiArray, labelled (below): the sample
  time ``time_s`` then the plant's measurement vector (foot signals and output quantities);
* ``/avc/balancer/estimate`` and ``/avc/balancer/command`` -- std_msgs/msg/Float64MultiArray,
  labelled ``time_s``, ``<excitation>_re``, ``<excitation>_im``: the estimated unbalance and the
  correction command as complex amplitudes (kg m, kg m^2);
* ``/avc/harmonic/forces`` -- std_msgs/msg/Float64MultiArray, labelled ``time_s``,
  ``<actuator>_f<axis>``: the adaptive harmonic controller's forces (N), added by the plant to
  the feedback forces; ``/avc/harmonic/status`` (after each update): ``time_s``, ``mode``,
  ``updates``, ``E<h>_<sensor>`` and ``U<h>_<actuator>`` (error and force phasor magnitudes),
  ``fallbacks`` (the supervisor's fall-backs so far);
* ``/clock`` -- rosgraph_msgs/msg/Clock: the sim time (lockstep mode);
* ``/diagnostics`` -- diagnostic_msgs/msg/DiagnosticArray: node status and timing.

A **labelled array** is a Float64MultiArray with one dimension whose ``label`` is the
comma-separated list of element names (``bearing_D_vz,bearing_D_vy,...``), ``size = stride =``
the number of elements, ``data_offset = 0``; ``data[i]`` is the value of name ``i``. Names are
the plant's output names (``rotor_avc.models.plant.Output.name``) and units their units. It
carries at most :data:`MAX_ARRAY_ELEMENTS` elements, what PlotJuggler's ROS 2 parser reads; a
longer one is refused (:func:`check_array_size`) where it is made: by a node at start-up, by the
bag writer of an in-process run.

Every message is stamped and logged at its sim time: log time = publish time = header stamp
(the actuator force's stamp may name an earlier measurement). :class:`Stream` holds one topic's
time series; the builders below make them from arrays, and
:meth:`rotor_avc.bag.writer.BagWriter.write_streams` writes them in one vectorised pass.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..block_kinds import (ACTUATOR_FORCE, ACTUATOR_SIGNALS, JOINT_STATE, OBSERVABLES,
                           answer_topics)
from .errors import BagError

NAMESPACE = "avc"
FOOT_IDS = ("DL", "DR", "NL", "NR")
#: topic pattern (relative to the namespace unless absolute) -> message type
TOPIC_TYPES = {
    "rotor/joint_state": "sensor_msgs/msg/JointState",
    "foot/{id}/acceleration": "geometry_msgs/msg/AccelStamped",
    "foot/{id}/velocity": "geometry_msgs/msg/TwistStamped",
    "foot/{id}/displacement": "geometry_msgs/msg/PointStamped",
    "foot/{id}/actuator_force": "geometry_msgs/msg/WrenchStamped",
    "plant/observables": "std_msgs/msg/Float64MultiArray",
    "balancer/estimate": "std_msgs/msg/Float64MultiArray",
    "balancer/command": "std_msgs/msg/Float64MultiArray",
    "harmonic/forces": "std_msgs/msg/Float64MultiArray",
    "harmonic/status": "std_msgs/msg/Float64MultiArray",
    "/clock": "rosgraph_msgs/msg/Clock",
    "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
}
#: the topics with one message per sample of the run: the plant's and every answering block's
#: (rotor_avc.block_kinds)
_PLANT_SAMPLED = ACTUATOR_SIGNALS + (JOINT_STATE, OBSERVABLES, "plant/test_signal")
SAMPLED = re.compile(r"^(/[^/]+/)?(" + "|".join(
    re.escape(t).replace(r"\{id\}", "[^/]+") for t in _PLANT_SAMPLED + answer_topics())
    + r")$|^/clock$")


#: PlotJuggler's ROS 2 parser reads arrays of at most its "maximum array size" (default 100)
#: and clamps or drops longer ones: no labelled array of the package is longer
MAX_ARRAY_ELEMENTS = 100


def check_array_size(name: str, labels: Sequence[str]) -> None:
    """BagError when the labelled array ``name`` has more than MAX_ARRAY_ELEMENTS elements."""
    if len(labels) > MAX_ARRAY_ELEMENTS:
        raise BagError("(stream)", f"{name}: {len(labels)} elements ({labels[0]} ... "
                       f"{labels[-1]}), more than the {MAX_ARRAY_ELEMENTS} that PlotJuggler's "
                       "ROS 2 parser reads (it would clamp or drop the array)",
                       fix="configure fewer of what the names count (the model's outputs, "
                           "the harmonic controller's sensors, actuators or harmonics)")


def topic(name: str, namespace: str = NAMESPACE) -> str:
    """Full topic name: ``rotor/joint_state`` -> ``/avc/rotor/joint_state``; absolute kept."""
    return name if name.startswith("/") else f"/{namespace.strip('/')}/{name}"


#: an actuator signal's kind -> the field path of the vector holding the axis component
SIGNAL_FIELDS = {"acceleration": "accel.linear", "velocity": "twist.linear",
                "displacement": "point"}


#: an actuator's topics by kind (rotor_avc.block_kinds): its signals and its force
ACTUATOR_TOPICS = {t.rsplit("/", 1)[1]: t for t in ACTUATOR_SIGNALS + (ACTUATOR_FORCE,)}


def actuator_topic(actuator_id: str, kind: str, namespace: str = NAMESPACE) -> str:
    """``/avc/foot/<id>/<kind>``: an actuator's acceleration, velocity, displacement or
    actuator_force (``foot/`` is the actuators' topic prefix)."""
    if kind not in ACTUATOR_TOPICS:
        raise BagError("(topic)", f"unknown actuator topic kind {kind!r}",
                       fix="use " + ", ".join(ACTUATOR_TOPICS))
    return topic(ACTUATOR_TOPICS[kind].format(id=actuator_id), namespace)


def message_type(full_topic: str, namespace: str = NAMESPACE) -> str:
    """The message type of one of the package's topics (BagError for any other topic)."""
    for pattern, msg_type in TOPIC_TYPES.items():
        parts = topic(pattern, namespace).split("/")
        given = full_topic.split("/")
        if len(parts) == len(given) and all(p == g or p == "{id}" for p, g in zip(parts, given)):
            return msg_type
    raise BagError("(topic)", f"{full_topic!r} is not one of the package's topics",
                   fix="give the message type explicitly, or use one of "
                       + ", ".join(topic(p, namespace) for p in TOPIC_TYPES))


def to_ns(time_s) -> np.ndarray:
    """Seconds -> integer nanoseconds (rounded), as int64."""
    t = np.asarray(time_s, dtype=float)
    if t.ndim != 1 or not np.all(np.isfinite(t)) or np.any(t < 0):
        raise BagError("(time)", "times must be a 1-D array of finite, non-negative seconds")
    return np.round(t * 1e9).astype(np.int64)


def stamp_fields(prefix: str, time_ns: np.ndarray) -> dict[str, np.ndarray]:
    """``{prefix.sec, prefix.nanosec}`` of builtin_interfaces/Time for each time."""
    sec, nanosec = np.divmod(np.asarray(time_ns, np.int64), 1_000_000_000)
    return {f"{prefix}.sec": sec.astype(np.int32), f"{prefix}.nanosec": nanosec.astype(np.uint32)}


@dataclass
class Stream:
    """One topic's messages: a template giving the structure (strings, sequence lengths) and
    per-message values of numeric fields (``path -> (N,) or (N, count)``)."""

    topic: str
    msg_type: str
    time_ns: np.ndarray
    template: dict
    fields: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self):
        self.time_ns = np.asarray(self.time_ns, np.int64)
        n = self.time_ns.shape[0]
        for path, values in self.fields.items():
            if np.shape(values)[:1] != (n,):
                rows = np.shape(values)[0] if np.ndim(values) else "no"
                raise BagError("(stream)", f"{self.topic}: field {path!r} has {rows} rows, "
                               f"the times have {n}",
                               fix="give one value (row) per message time")


def _check_len(name: str, values, n: int) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.shape[:1] != (n,):
        count = arr.shape[0] if arr.ndim else "a single value, not"
        raise BagError("(stream)", f"{name}: {count} values for {n} times",
                       fix="give one value per sample time")
    return arr


def joint_state(time_s, angle_rad, speed_rad_s, namespace: str = NAMESPACE) -> Stream:
    """``rotor/joint_state``: shaft angle and speed."""
    t = to_ns(time_s)
    fields = {"position": _check_len("angle_rad", angle_rad, len(t)),
              "velocity": _check_len("speed_rad_s", speed_rad_s, len(t)),
              **stamp_fields("header.stamp", t)}
    template = {"header": {"frame_id": "rotor"}, "name": ["rotor"], "position": [0.0],
                "velocity": [0.0]}
    return Stream(topic("rotor/joint_state", namespace), TOPIC_TYPES["rotor/joint_state"], t,
                  template, fields)


def foot_signal(foot_id: str, kind: str, time_s, values, axis: str = "z",
                namespace: str = NAMESPACE) -> Stream:
    """``foot/<id>/<kind>``: the foot's acceleration, velocity or displacement (axis component)."""
    t = to_ns(time_s)
    fields = {f"{SIGNAL_FIELDS[kind]}.{axis}": _check_len(f"{foot_id} {kind}", values, len(t)),
              **stamp_fields("header.stamp", t)}
    return Stream(actuator_topic(foot_id, kind, namespace), TOPIC_TYPES["foot/{id}/" + kind], t,
                  {"header": {"frame_id": f"foot_{foot_id}"}}, fields)


def foot_acceleration(foot_id: str, time_s, accel_m_s2, namespace: str = NAMESPACE) -> Stream:
    """``foot/<id>/acceleration``: vertical foot acceleration (linear.z)."""
    return foot_signal(foot_id, "acceleration", time_s, accel_m_s2, "z", namespace)


def actuator_force(foot_id: str, time_s, force_n, stamp_s=None, axis: str = "z",
                   namespace: str = NAMESPACE) -> Stream:
    """``foot/<id>/actuator_force``: force.<axis>, stamped with the measurement it answers."""
    t = to_ns(time_s)
    stamp = t if stamp_s is None else to_ns(stamp_s)
    _check_len("stamp_s", stamp, len(t))
    fields = {f"wrench.force.{axis}": _check_len(f"{foot_id} force", force_n, len(t)),
              **stamp_fields("header.stamp", stamp)}
    return Stream(actuator_topic(foot_id, "actuator_force", namespace),
                  TOPIC_TYPES["foot/{id}/actuator_force"], t,
                  {"header": {"frame_id": f"foot_{foot_id}"}}, fields)


def labelled_array(name: str, time_s, labels: Sequence[str], values,
                   namespace: str = NAMESPACE) -> Stream:
    """A labelled Float64MultiArray topic (``plant/observables``, ``balancer/...``)."""
    labels = [str(label) for label in labels]
    bad = [label for label in labels if not label or "," in label or label != label.strip()]
    if bad or len(set(labels)) != len(labels):
        raise BagError("(stream)", f"{name}: labels must be unique, non-empty, without commas "
                       f"or surrounding spaces (got {labels})")
    check_array_size(name, labels)
    t = to_ns(time_s)
    data = _check_len(name, values, len(t)).reshape(len(t), -1)
    if data.shape[1] != len(labels):
        raise BagError("(stream)", f"{name}: {data.shape[1]} columns for {len(labels)} labels")
    n = len(labels)
    template = {"layout": {"dim": [{"label": ",".join(labels), "size": n, "stride": n}]},
                "data": np.zeros(n)}
    return Stream(topic(name, namespace), TOPIC_TYPES["plant/observables"], t, template,
                  {"data": data})


def clock(time_s) -> Stream:
    """``/clock``: the sim time itself."""
    t = to_ns(time_s)
    return Stream("/clock", TOPIC_TYPES["/clock"], t, {}, stamp_fields("clock", t))


def labels_of(message: dict) -> list[str]:
    """Element names of a decoded labelled array message (see the module docstring)."""
    dims = message.get("layout", {}).get("dim", [])
    if len(dims) != 1 or dims[0]["size"] != len(message.get("data", ())):
        return []
    return dims[0]["label"].split(",") if dims[0]["label"] else []
