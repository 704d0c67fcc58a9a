"""Message conversions of the ROS graph (DESIGN.md section 4; names in rotor_avc.bag.topics).

Foot measurements: ``foot/<id>/acceleration`` (geometry_msgs/AccelStamped, ``accel.linear``),
``foot/<id>/velocity`` (geometry_msgs/TwistStamped, ``twist.linear``) and
``foot/<id>/displacement`` (geometry_msgs/PointStamped, ``point``), the component of the
actuator's axis (z for the foot mounts), SI units, frame ``foot_<id>``, stamp = ``t_k``. The plant
publishes acceleration for every actuated foot and, for a controller fed back on displacement or
velocity, that signal too. Forces: ``foot/<id>/actuator_force`` (geometry_msgs/WrenchStamped,
``wrench.force``), stamped with the measurement they answer.

Messages are built once and mutated per sample (building a message costs more than sending it);
the foot measurements and forces travel as serialised bytes (:class:`StampedVector`,
:func:`stamped_value`: raw publishers and subscriptions), the same messages on the wire.
"""
from __future__ import annotations

import struct
from typing import Callable

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PointStamped, TwistStamped, WrenchStamped
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from ..bag.msgdefs import DEFINITIONS
from ..bag.topics import NAMESPACE, topic  # noqa: F401  (re-exported for the nodes)

#: lockstep traffic: reliable, deep enough that a burst is never dropped
LOCKSTEP_QOS = QoSProfile(depth=200, reliability=ReliabilityPolicy.RELIABLE,
                          history=HistoryPolicy.KEEP_LAST)
MEASUREMENT_TYPES = {"acceleration": AccelStamped, "velocity": TwistStamped,
                     "displacement": PointStamped}
STAMPED_TYPES = {**MEASUREMENT_TYPES, "actuator_force": WrenchStamped}
_BILLION = 1_000_000_000
_STAMP = struct.Struct("<iI")
_U32 = struct.Struct("<I")
_F64 = struct.Struct("<d")
_CDR_LE = 1                     # second byte of the encapsulation header 00 01 00 00


def foot_topic(foot_id: str, kind: str, namespace: str = NAMESPACE) -> str:
    """``/<ns>/foot/<id>/<kind>`` with kind acceleration, velocity, displacement or
    actuator_force."""
    return topic(f"foot/{foot_id}/{kind}", namespace)


def set_stamp(stamp: Time, time_ns: int) -> None:
    stamp.sec, stamp.nanosec = divmod(int(time_ns), _BILLION)


def stamp_ns(stamp: Time) -> int:
    return stamp.sec * _BILLION + stamp.nanosec


def sample_ns(k: int, sample_period_s: float) -> int:
    """Stamp of sample ``k`` in integer nanoseconds (the identity of a sample)."""
    return time_to_ns(k * sample_period_s)


def time_to_ns(time_s: float) -> int:
    """Sample time ``t_k = k T`` (float seconds, as carried in labelled arrays) -> stamp in ns."""
    return int(round(time_s * 1e9))


class StampedVector:
    """A foot measurement or an actuator force as serialised CDR bytes, the lockstep hot path.

    The four types (AccelStamped, TwistStamped, PointStamped, WrenchStamped) are a Header
    followed by a message whose first field is the Vector3 that carries the value (``accel.linear``,
    ``twist.linear``, ``point``, ``wrench.force``). The bytes come from a template rclpy
    serialises once; ``fill`` writes the stamp and the axis component into it, so publishing
    (``publisher.publish(bytes)``) skips rclpy's Python-message conversion -- with raw
    subscriptions (:func:`stamped_value`) about three times the message rate of typed messages
    (bench/bench_ros_loop.py). Subscribers of the typed message receive the same message."""

    def __init__(self, kind: str, foot_id: str, axis: str = "z"):
        msg = STAMPED_TYPES[kind]()
        msg.header.frame_id = f"foot_{foot_id}"
        self.kind, self.foot_id, self.axis = kind, foot_id, axis
        self._buf = bytearray(serialize_message(msg))
        self._value_at = _vector_offset(self._buf) + 8 * "xyz".index(axis)

    def fill(self, time_ns: int, value: float) -> bytes:
        _STAMP.pack_into(self._buf, 4, *divmod(int(time_ns), _BILLION))
        _F64.pack_into(self._buf, self._value_at, value)
        return bytes(self._buf)


class Measurement(StampedVector):
    """A reusable foot measurement (``foot/<id>/<kind>``) of one kind and axis."""


class Force(StampedVector):
    """A reusable actuator force (``foot/<id>/actuator_force``)."""

    def __init__(self, foot_id: str, axis: str = "z"):
        super().__init__("actuator_force", foot_id, axis)


def _vector_offset(data) -> int:
    """Byte offset of the first Vector3 after the Header (stamp, frame_id string): aligned to
    8 relative to the end of the 4-byte encapsulation header."""
    (n,) = _U32.unpack_from(data, 12)
    return 4 + (12 + n + 7) // 8 * 8


def stamped_value(data: bytes, axis: str = "z") -> tuple[int, float]:
    """``(stamp in ns, axis component)`` of a serialised foot measurement or actuator force
    (see :class:`StampedVector`); ValueError for bytes that are not one."""
    try:
        if data[1] != _CDR_LE:
            raise ValueError("not little-endian CDR")
        sec, nanosec = _STAMP.unpack_from(data, 4)
        (value,) = _F64.unpack_from(data, _vector_offset(data) + 8 * "xyz".index(axis))
    except (struct.error, IndexError) as exc:
        raise ValueError(f"not a stamped vector message ({exc})") from None
    return sec * _BILLION + nanosec, value


class Labelled:
    """A reusable labelled Float64MultiArray (see rotor_avc.bag.topics). The graph's labelled
    arrays carry the sample time ``t_k`` as their first element, labelled ``time_s`` (the
    message type has no header)."""

    def __init__(self, labels):
        self.msg = Float64MultiArray()
        n = len(labels)
        self.msg.layout.dim = [MultiArrayDimension(label=",".join(labels), size=n, stride=n)]

    def fill(self, values) -> Float64MultiArray:
        self.msg.data = values
        return self.msg


_LABELLED = "std_msgs/msg/Float64MultiArray"


def _stamp_first(data: bytes) -> int | None:
    """Sim time of a serialised message whose first field is a Header or a Time (CDR LE)."""
    if len(data) < 12 or data[1] != _CDR_LE:
        return None
    sec, nanosec = _STAMP.unpack_from(data, 4)
    return sec * _BILLION + nanosec


def _labelled_time(data: bytes) -> int | None:
    """``time_s`` (the first element) of a serialised labelled Float64MultiArray, in ns.

    CDR of ``{layout: {dim: [{label, size, stride}], data_offset}, data}``: offsets count from
    the end of the 4-byte encapsulation header, each primitive aligned to its size."""
    try:
        if data[1] != _CDR_LE or _U32.unpack_from(data, 4)[0] != 1:
            return None
        (n,) = _U32.unpack_from(data, 8)                  # label length with its NUL
        label = data[12:12 + n]
        if not (label.startswith(b"time_s") and label[6:7] in (b",", b"\0")):
            return None
        pos = 4 + (12 + n - 4 + 3) // 4 * 4               # size, stride, data_offset, count
        if _U32.unpack_from(data, pos + 12)[0] < 1:
            return None
        pos = 4 + (pos + 16 - 4 + 7) // 8 * 8
        return time_to_ns(_F64.unpack_from(data, pos)[0])
    except (struct.error, IndexError):
        return None


def raw_time_reader(msg_type: str) -> Callable[[bytes], int | None]:
    """For serialised (CDR) messages of ``msg_type``: a function giving a message's sim time in
    ns without deserialising it -- the header stamp (``/clock``: the clock) for types that begin
    with a Header or a Time, ``time_s`` for labelled arrays -- or None when it has none.
    The recorder logs messages at this time; replay matches answers by it."""
    if msg_type == _LABELLED:
        return _labelled_time
    first = DEFINITIONS.get(msg_type, "").split(maxsplit=1)[:1]
    if first and first[0] in ("std_msgs/Header", "builtin_interfaces/Time"):
        return _stamp_first
    return lambda data: None


def labels(msg: Float64MultiArray) -> list[str]:
    dims = msg.layout.dim
    return dims[0].label.split(",") if len(dims) == 1 and dims[0].label else []


class Rotor:
    """Reusable ``rotor/joint_state`` (angle, speed) and ``/clock`` messages."""

    def __init__(self):
        self.joint = JointState()
        self.joint.header.frame_id = "rotor"
        self.joint.name = ["rotor"]
        self.clock = Clock()

    def fill(self, time_ns: int, angle_rad: float, speed_rad_s: float):
        set_stamp(self.joint.header.stamp, time_ns)
        set_stamp(self.clock.clock, time_ns)
        self.joint.position = [angle_rad]
        self.joint.velocity = [speed_rad_s]
        return self.joint, self.clock


LEVELS = {"ok": DiagnosticStatus.OK, "warn": DiagnosticStatus.WARN,
          "error": DiagnosticStatus.ERROR}


def diagnostics(time_ns: int, statuses) -> DiagnosticArray:
    """``statuses``: iterable of ``(name, level, message, {key: value})``."""
    arr = DiagnosticArray()
    set_stamp(arr.header.stamp, time_ns)
    for name, level, message, values in statuses:
        st = DiagnosticStatus(level=LEVELS[level], name=name, message=message,
                              hardware_id="rotor_avc")
        st.values = [KeyValue(key=str(k), value=_fmt(v)) for k, v in values.items()]
        arr.status.append(st)
    return arr


def _fmt(value) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)
