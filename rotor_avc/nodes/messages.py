"""Message conversions of the ROS graph (DESIGN.md section 4; names in rotor_avc.bag.topics).

Foot measurements: ``foot/<id>/acceleration`` (geometry_msgs/AccelStamped, ``accel.linear``),
``foot/<id>/velocity`` (geometry_msgs/TwistStamped, ``twist.linear``) and
``foot/<id>/displacement`` (geometry_msgs/PointStamped, ``point``), the component of the
actuator's axis (z for the foot mounts), SI units, frame ``foot_<id>``, stamp = ``t_k``. The plant
publishes acceleration for every actuated foot and, for a controller fed back on displacement or
velocity, that signal too. Forces: ``foot/<id>/actuator_force`` (geometry_msgs/WrenchStamped,
``wrench.force``), stamped with the measurement they answer.

Every message of the lockstep loop travels as serialised CDR bytes (raw publishers and
subscriptions): the nodes fill a template that rclpy serialised once, at the offsets the bags'
codec finds in it (:class:`rotor_avc.bag.cdr.Layout`), and read the fields they need from the
bytes with a bounds-checked cursor (malformed input from the network is a reported fault) -- foot measurements and forces (:class:`StampedVector`, :func:`stamped_value`),
``rotor/joint_state`` and ``/clock`` (:class:`RotorBytes`, :func:`joint_state`), the labelled
arrays (:class:`LabelledBytes`, :func:`labelled_array`). These are the same messages on the wire:
subscribers of the typed messages, the recorder and the bag tools see no difference. rclpy's
conversion of Python messages, not the nodes' arithmetic, was the cost of the loop
(bench/bench_ros_loop.py).
"""
from __future__ import annotations

import os
import socket
import struct
from typing import Callable

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PointStamped, TwistStamped, WrenchStamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState  # noqa: F401  (Imu re-exported)
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from ..bag.cdr import CdrCodec, Layout
from ..bag.msgdefs import DEFINITIONS, known_specs
from ..bag.topics import SIGNAL_FIELDS, NAMESPACE, actuator_topic, topic  # noqa: F401  (re-exported)
from ..bag.topics import check_array_size
from .qos import (DIAGNOSTICS_QOS, LOCKSTEP_DEPTH, LOCKSTEP_QOS,  # noqa: F401  (re-exported)
                  MEASUREMENT_QOS, RECORDER_MARGIN, RELIABLE_QOS, SENSOR_QOS)

#: the recorder's taken-message counts (rotor_avc.nodes.recorder), relative to the namespace
RECORDER_PROGRESS = "recorder/progress"
#: name suffix of the diagnostic status in which a node reports its published counts per topic
PUBLISHED_SUFFIX = ": published"
PROCESS_KEY = "process"
PROCESS_ID = f"{socket.gethostname()}:{os.getpid()}"
MEASUREMENT_TYPES = {"acceleration": AccelStamped, "velocity": TwistStamped,
                     "displacement": PointStamped}
STAMPED_TYPES = {**MEASUREMENT_TYPES, "actuator_force": WrenchStamped}
_BILLION = 1_000_000_000
_STAMP = struct.Struct("<iI")
_U32 = struct.Struct("<I")
_F64 = struct.Struct("<d")
_CDR_LE = 1                     # second byte of the encapsulation header 00 01 00 00
#: the Vector3 (Point) field that carries the value of each stamped kind
VALUE_FIELDS = {**SIGNAL_FIELDS, "actuator_force": "wrench.force"}
_SPECS = known_specs()


def _template(msg, type_name: str) -> tuple[bytes, Layout]:
    """A message (an rclpy message or a dict) serialised once by the bags' codec
    (rotor_avc.bag.cdr), and the byte offsets of its fields
    (:meth:`rotor_avc.bag.cdr.CdrCodec.layout`; ``Layout.end`` is the byte after its last
    field): the hot path fills these bytes, which are then the very bytes the in-process
    recording writes (rotor_avc.recording) -- alignment padding zero, where rclpy's
    ``serialize_message`` leaves it uninitialised."""
    codec = CdrCodec(type_name, _SPECS)
    data = codec.encode(msg)
    return data, codec.layout(data)


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


def received_time_ns(time_s: float) -> int:
    """:func:`time_to_ns` of a ``time_s`` received in a labelled array; :class:`MessageError`
    unless it is a sim time a stamp can hold (0 <= t < 2**31 s; NaN is not)."""
    if not 0.0 <= time_s < 2.0**31:
        raise MessageError(f"time_s = {time_s} is not a sim time (0 <= time_s < 2**31 s)")
    return time_to_ns(time_s)


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
        data, layout = _template(msg, f"geometry_msgs/msg/{STAMPED_TYPES[kind].__name__}")
        self._buf = bytearray(data)
        self._stamp_at = layout.leaves["header.stamp.sec"][0]
        self._value_at = layout.leaves[f"{VALUE_FIELDS[kind]}.{axis}"][0]

    def fill(self, time_ns: int, value: float) -> bytes:
        _STAMP.pack_into(self._buf, self._stamp_at, *divmod(int(time_ns), _BILLION))
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


#: bytes from the first field after an Imu's Header (orientation) to its linear_acceleration:
#: orientation (4 float64), orientation_covariance (9), angular_velocity (3), its covariance (9)
IMU_ACCELERATION_SKIP = 8 * (4 + 9 + 3 + 9)


def stamped_value(data: bytes, axis: str = "z", skip: int = 0) -> tuple[int, float]:
    """``(stamp in ns, axis component)`` of a serialised foot measurement or actuator force
    (see :class:`StampedVector`), or with ``skip = IMU_ACCELERATION_SKIP`` of a
    ``sensor_msgs/Imu``'s ``linear_acceleration``; ValueError for bytes that are not one."""
    try:
        if data[1] != _CDR_LE:
            raise ValueError("not little-endian CDR")
        sec, nanosec = _STAMP.unpack_from(data, 4)
        (value,) = _F64.unpack_from(data, _vector_offset(data) + skip + 8 * "xyz".index(axis))
    except (struct.error, IndexError) as exc:
        raise ValueError(f"not a stamped vector message ({exc})") from None
    return sec * _BILLION + nanosec, value


def frame_id_prefix(frame_id: str) -> bytes:
    """The serialised ``header.frame_id`` (length, characters, NUL) as it follows the stamp at
    byte 12 of a message that begins with a Header: ``data.startswith(prefix, 12)`` checks it."""
    text = frame_id.encode()
    return _U32.pack(len(text) + 1) + text + b"\0"


class MessageError(ValueError):
    """Serialised bytes that are not a well-formed message of the expected type."""


class _Cdr:
    """Reading cursor over little-endian CDR bytes (XCDR1 as rmw serialises them): each primitive
    aligned to its size, counted from the end of the 4-byte encapsulation header; a sequence of
    float64 is aligned to 8 only when it has elements. Every read checks the bounds and raises
    :class:`MessageError` naming the message type and the field."""

    __slots__ = ("data", "pos", "what")

    def __init__(self, data, what: str):
        if len(data) < 4 or data[1] != _CDR_LE:
            raise MessageError(f"{what}: not little-endian CDR ({len(data)} bytes, header "
                               f"{bytes(data[:4]).hex()})")
        self.data, self.pos, self.what = data, 4, what

    def _truncated(self, field: str, at: int, n: int) -> MessageError:
        return MessageError(f"{self.what}: truncated -- {field} needs bytes {at}..{at + n} of "
                            f"{len(self.data)}")

    def u32(self, field: str) -> int:
        at = self.pos + -self.pos % 4
        self.pos = at + 4
        if self.pos > len(self.data):
            raise self._truncated(field, at, 4)
        return _U32.unpack_from(self.data, at)[0]

    def stamp_ns(self) -> int:
        """The Header's / Time's stamp (the first field) in ns."""
        if len(self.data) < 12:
            raise self._truncated("the stamp", 4, 8)
        self.pos = 12
        sec, nanosec = _STAMP.unpack_from(self.data, 4)
        return sec * _BILLION + nanosec

    def string(self, field: str) -> str:
        n = self.u32(field)
        at = self.pos
        self.pos = end = at + n
        if end > len(self.data):
            raise self._truncated(field, at, n)
        if n < 1 or self.data[end - 1] != 0:
            raise MessageError(f"{self.what}: {field} is not a NUL-terminated string (length {n})")
        try:
            return str(self.data[at:end - 1], "utf-8")
        except UnicodeDecodeError as exc:
            raise MessageError(f"{self.what}: {field} is not UTF-8 ({exc})") from None

    def f64_block(self, field: str) -> tuple[int, int]:
        """``(byte offset, count)`` of a float64 sequence, skipped."""
        n = self.u32(field)
        at = self.pos + (-(self.pos - 4) % 8 if n else 0)
        self.pos = at + 8 * n
        if self.pos > len(self.data):
            raise self._truncated(field, at, 8 * n)
        return at, n


_F64S: dict[int, struct.Struct] = {}


def _float64s(n: int) -> struct.Struct:
    packer = _F64S.get(n)
    if packer is None:
        packer = _F64S[n] = struct.Struct(f"<{n}d")
    return packer


_JOINT_STATE = "sensor_msgs/msg/JointState"
_LABELLED = "std_msgs/msg/Float64MultiArray"


def _joint_state_blocks(data) -> tuple[int, tuple[int, int], tuple[int, int]]:
    """``(stamp ns, (offset, count) of position, of velocity)`` of a serialised JointState:
    header (stamp, frame_id), name (strings), position, velocity, effort (float64 sequences)."""
    r = _Cdr(data, _JOINT_STATE)
    stamp = r.stamp_ns()
    r.string("header.frame_id")
    for _ in range(r.u32("name")):
        r.string("name[i]")
    position = r.f64_block("position")
    velocity = r.f64_block("velocity")
    r.f64_block("effort")
    return stamp, position, velocity


def joint_state(data) -> tuple[int, tuple[float, ...], tuple[float, ...]]:
    """``(stamp in ns, position, velocity)`` of a serialised sensor_msgs/JointState (the
    ``rotor/joint_state`` of :class:`RotorBytes` or any other); :class:`MessageError` for bytes
    that are not one."""
    stamp, (p_at, n_p), (v_at, n_v) = _joint_state_blocks(data)
    return stamp, _float64s(n_p).unpack_from(data, p_at), _float64s(n_v).unpack_from(data, v_at)


def _labelled_layout(data) -> tuple[str, int, int]:
    """``(label, byte offset of data, element count)`` of a serialised Float64MultiArray:
    ``{layout: {dim: [{label, size, stride}], data_offset}, data}``. The label is that of the
    only dimension ("" unless there is exactly one)."""
    r = _Cdr(data, _LABELLED)
    dims = []
    for _ in range(r.u32("layout.dim")):
        dims.append(r.string("layout.dim[i].label"))
        r.u32("layout.dim[i].size")
        r.u32("layout.dim[i].stride")
    r.u32("layout.data_offset")
    at, n = r.f64_block("data")
    return (dims[0] if len(dims) == 1 else ""), at, n


def labelled_array(data) -> tuple[str, tuple[float, ...]]:
    """``(label, values)`` of a serialised labelled Float64MultiArray (see :class:`Labelled`;
    the label is the comma-separated element names); :class:`MessageError` for bytes that are
    not a Float64MultiArray."""
    label, at, n = _labelled_layout(data)
    return label, _float64s(n).unpack_from(data, at)


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


class LabelledBytes:
    """A labelled array ``time_s, *names`` as serialised bytes (the graph's hot path, as
    :class:`StampedVector`): a template of :class:`Labelled` serialised once, ``fill`` writes
    the values into it. More names than PlotJuggler reads are refused (a node at start-up,
    rotor_avc.bag.topics.check_array_size)."""

    def __init__(self, names):
        self.names = ("time_s",) + tuple(names)
        check_array_size("labelled array", self.names)
        self.label = ",".join(self.names)
        data, layout = _template(Labelled(self.names).fill([0.0] * len(self.names)), _LABELLED)
        at, _, n, _ = layout.leaves["data"]
        self._buf = bytearray(data[:layout.end])     # without trailing bytes (see RotorBytes)
        self._values = np.frombuffer(self._buf, dtype="<f8", count=n, offset=at)

    def fill(self, time_s: float, values) -> bytes:
        """The message with ``data = [time_s, *values]``, one value per name."""
        if len(values) != len(self.names) - 1:
            raise ValueError(f"{len(values)} values for the {len(self.names) - 1} names "
                             f"{self.label[7:]}")
        self._values[0] = time_s
        self._values[1:] = values
        return bytes(self._buf)


def _stamp_first(data: bytes) -> int | None:
    """Sim time of a serialised message whose first field is a Header or a Time (CDR LE)."""
    if len(data) < 12 or data[1] != _CDR_LE:
        return None
    sec, nanosec = _STAMP.unpack_from(data, 4)
    return sec * _BILLION + nanosec


def _labelled_time(data: bytes) -> int | None:
    """``time_s`` (the first element) of a serialised labelled Float64MultiArray, in ns."""
    try:
        label, at, n = _labelled_layout(data)
    except MessageError:
        return None
    if n < 1 or label.split(",", 1)[0] != "time_s":
        return None
    return time_to_ns(_F64.unpack_from(data, at)[0])


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


class RotorBytes:
    """``rotor/joint_state`` and ``/clock`` of :class:`Rotor` as serialised bytes (the hot path):
    templates serialised once (:func:`template`), ``fill`` writes stamp, angle and speed into
    them."""

    def __init__(self):
        joint, clock = Rotor().fill(0, 0.0, 0.0)
        data, layout = _template(joint, _JOINT_STATE)
        self._angle_at = layout.leaves["position"][0]
        self._speed_at = layout.leaves["velocity"][0]
        self._joint = bytearray(data[:layout.end])
        data, layout = _template(clock, "rosgraph_msgs/msg/Clock")
        self._clock = bytearray(data[:layout.end])

    def fill(self, time_ns: int, angle_rad: float, speed_rad_s: float) -> tuple[bytes, bytes]:
        sec_nsec = divmod(int(time_ns), _BILLION)
        _STAMP.pack_into(self._joint, 4, *sec_nsec)
        _STAMP.pack_into(self._clock, 4, *sec_nsec)
        _F64.pack_into(self._joint, self._angle_at, angle_rad)
        _F64.pack_into(self._joint, self._speed_at, speed_rad_s)
        return bytes(self._joint), bytes(self._clock)


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


def published_status(node) -> tuple:
    """The diagnostic status ``"<node>: published"`` with the messages ``node`` has published
    per topic (rotor_avc.nodes.taps), for :func:`diagnostics`: the publishers' side of a bag's
    counts. It is published on ``/diagnostics``, counts the message that carries it, and names
    the process (``process``: host and process id), so a recorder does not count twice what it
    counts itself in its own process."""
    from .taps import published_counts
    counts = published_counts(node)
    counts["/diagnostics"] = counts.get("/diagnostics", 0) + 1    # the array carrying this status
    return (f"{node.get_name()}{PUBLISHED_SUFFIX}", "ok", "messages published per topic",
            {PROCESS_KEY: PROCESS_ID, **counts})


def _fmt(value) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)
