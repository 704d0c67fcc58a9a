"""Message conversions of the ROS graph (DESIGN.md section 4; names in rotor_avc.bag.topics).

Foot measurements: ``foot/<id>/acceleration`` (geometry_msgs/AccelStamped, ``accel.linear``),
``foot/<id>/velocity`` (geometry_msgs/TwistStamped, ``twist.linear``) and
``foot/<id>/displacement`` (geometry_msgs/PointStamped, ``point``), the component of the
actuator's axis (z for the foot mounts), SI units, frame ``foot_<id>``, stamp = ``t_k``. The plant
publishes acceleration for every actuated foot and, for a controller fed back on displacement or
velocity, that signal too. Forces: ``foot/<id>/actuator_force`` (geometry_msgs/WrenchStamped,
``wrench.force``), stamped with the measurement they answer.

Messages are built once and mutated per sample (building a message costs more than sending it).
"""
from __future__ import annotations

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PointStamped, TwistStamped, WrenchStamped
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from ..bag.topics import NAMESPACE, topic  # noqa: F401  (re-exported for the nodes)

#: lockstep traffic: reliable, deep enough that a burst is never dropped
LOCKSTEP_QOS = QoSProfile(depth=200, reliability=ReliabilityPolicy.RELIABLE,
                          history=HistoryPolicy.KEEP_LAST)
MEASUREMENT_TYPES = {"acceleration": AccelStamped, "velocity": TwistStamped,
                     "displacement": PointStamped}
_BILLION = 1_000_000_000


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


class Measurement:
    """A reusable foot-measurement message of one kind and axis."""

    def __init__(self, kind: str, foot_id: str, axis: str = "z"):
        self.msg = MEASUREMENT_TYPES[kind]()
        self.msg.header.frame_id = f"foot_{foot_id}"
        self._vec = {"acceleration": lambda m: m.accel.linear, "velocity": lambda m: m.twist.linear,
                     "displacement": lambda m: m.point}[kind](self.msg)
        self.axis = axis

    def fill(self, time_ns: int, value: float):
        set_stamp(self.msg.header.stamp, time_ns)
        setattr(self._vec, self.axis, value)
        return self.msg


def measurement_value(kind: str, msg, axis: str = "z") -> float:
    vec = {"acceleration": lambda m: m.accel.linear, "velocity": lambda m: m.twist.linear,
           "displacement": lambda m: m.point}[kind](msg)
    return getattr(vec, axis)


class Force:
    """A reusable actuator-force message."""

    def __init__(self, foot_id: str, axis: str = "z"):
        self.msg = WrenchStamped()
        self.msg.header.frame_id = f"foot_{foot_id}"
        self.axis = axis

    def fill(self, time_ns: int, force_n: float) -> WrenchStamped:
        set_stamp(self.msg.header.stamp, time_ns)
        setattr(self.msg.wrench.force, self.axis, force_n)
        return self.msg


def force_value(msg: WrenchStamped, axis: str = "z") -> float:
    return getattr(msg.wrench.force, axis)


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
