"""The byte-level encoders and decoders of the lockstep hot path (rotor_avc.nodes.messages)
against rclpy's own serialisation: what the nodes publish deserialises to the typed message,
what rclpy serialises decodes to the typed message's fields, for layouts of every alignment;
malformed bytes give a MessageError naming the type and the field, never wrong values."""
import math
import struct

import numpy as np
import pytest

pytest.importorskip("rclpy", reason="ROS 2 Jazzy (rclpy) is not installed")
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray, MultiArrayDimension  # noqa: E402

from rotor_avc.nodes import messages as m  # noqa: E402

pytestmark = pytest.mark.ros
RNG = np.random.default_rng(7)
SPECIAL = [0.0, -0.0, 1e-310, -2.5e300, math.pi, math.inf, -math.inf]


def joint(stamp_ns=0, frame="", names=(), position=(), velocity=(), effort=()) -> JointState:
    msg = JointState()
    m.set_stamp(msg.header.stamp, stamp_ns)
    msg.header.frame_id = frame
    msg.name, msg.position, msg.velocity, msg.effort = (list(names), list(position),
                                                       list(velocity), list(effort))
    return msg


def labelled(dims, data) -> Float64MultiArray:
    msg = Float64MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=label, size=len(data), stride=len(data))
                      for label in dims]
    msg.data = list(data)
    return msg


def rosbags_reads(data: bytes, msg_type: str):
    """The message as the `rosbags` library decodes it (strict about the message size)."""
    from rosbags.typesys import Stores, get_typestore
    return get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(data, msg_type)


def same_floats(a, b) -> bool:
    """Equal bit for bit (0.0 vs -0.0 and NaN payloads included)."""
    return len(a) == len(b) and struct.pack(f"<{len(a)}d", *a) == struct.pack(f"<{len(b)}d", *b)


# -- encoders: our bytes deserialise (rclpy) to the typed message -------------------------------
@pytest.mark.parametrize("t_ns", [0, 200_000, 12_345_678_901, 2**31 * 10**9 - 1])
def test_rotor_bytes_are_the_typed_joint_state_and_clock(t_ns):
    raw = m.RotorBytes()
    for angle, speed in [(1.25, -3.5), (1e-310, math.inf), (-0.0, 6e5)]:
        joint_b, clock_b = raw.fill(t_ns, angle, speed)
        typed_joint, typed_clock = m.Rotor().fill(t_ns, angle, speed)
        assert deserialize_message(joint_b, JointState) == typed_joint
        assert deserialize_message(clock_b, Clock) == typed_clock
        assert m.joint_state(joint_b) == (t_ns, (angle,), (speed,))
        other = rosbags_reads(joint_b, "sensor_msgs/msg/JointState")
        assert (other.header.frame_id, other.name, other.position.tolist(),
                other.velocity.tolist()) == ("rotor", ["rotor"], [angle], [speed])
        assert rosbags_reads(clock_b, "rosgraph_msgs/msg/Clock").clock.nanosec == t_ns % 10**9
        assert m.raw_time_reader("sensor_msgs/msg/JointState")(joint_b) == t_ns
        assert m.raw_time_reader("rosgraph_msgs/msg/Clock")(clock_b) == t_ns


@pytest.mark.parametrize("n_names", [0, 1, 2, 5, 30])
def test_labelled_bytes_are_the_typed_labelled_array(n_names):
    names = [f"s{'x' * (i % 9)}{i}" for i in range(n_names)]     # label lengths of every residue
    raw = m.LabelledBytes(names)
    assert raw.names == ("time_s", *names)
    for _ in range(3):
        values = RNG.normal(size=n_names) * 10.0 ** RNG.integers(-300, 300, n_names)
        values[: min(n_names, len(SPECIAL))] = SPECIAL[:n_names]
        time_s = float(RNG.uniform(0, 100))
        data = raw.fill(time_s, values)
        typed = deserialize_message(data, Float64MultiArray)
        expected = m.Labelled(["time_s", *names]).fill([time_s, *values.tolist()])
        assert typed.layout == expected.layout and typed.layout.dim[0].label == raw.label
        assert same_floats(typed.data, [time_s, *values])
        assert m.labelled_array(data)[0] == raw.label
        other = rosbags_reads(data, "std_msgs/msg/Float64MultiArray")
        assert other.layout.dim[0].label == raw.label and same_floats(other.data, typed.data)
        assert same_floats(m.labelled_array(data)[1], [time_s, *values])
    with pytest.raises(ValueError, match=f"{n_names + 1} values for the {n_names} names"):
        raw.fill(0.0, np.zeros(n_names + 1))


# -- decoders: rclpy's bytes decode to the typed message's fields -------------------------------
JOINTS = [
    joint(),
    joint(5, "rotor", ["rotor"], [1.0], [2.0]),
    joint(2**40 + 7, "f" * 7, ["a", "bc", "def", "ghij"], [1.0, 2.0, 3.0, 4.0],
          [-1.0] * 4, [0.5] * 4),
    joint(1, "abcde", ["q"], [], [3.0], [1.0]),         # empty position ends 4 mod 8: velocity
    joint(1, "abcde", ["q"], [], [], [1.0]),            # count follows without padding
    joint(9, "", [], [1.0, -0.0], [], [7.0]),
    joint(3, "b\u00e4r", ["\u03b8" * 3], [math.pi], [math.e]),
]


@pytest.mark.parametrize("msg", JOINTS, ids=range(len(JOINTS)))
def test_joint_state_decodes_what_rclpy_serialises(msg):
    stamp, position, velocity = m.joint_state(serialize_message(msg))
    assert stamp == m.stamp_ns(msg.header.stamp)
    assert same_floats(position, msg.position) and same_floats(velocity, msg.velocity)


def random_arrays():
    out = [labelled([], []), labelled(["time_s"], [1.5]), labelled(["a", "b"], [1.0, 2.0]),
           labelled(["time_s,a"], [])]
    for n_label in range(9):                             # every alignment of the data block
        names = ["time_s", "y" * n_label] + ["z"] * int(RNG.integers(0, 4))
        out.append(labelled([",".join(names)], RNG.normal(size=len(names))))
    return out


@pytest.mark.parametrize("msg", random_arrays())
def test_labelled_array_decodes_what_rclpy_serialises(msg):
    label, values = m.labelled_array(serialize_message(msg))
    assert label == (msg.layout.dim[0].label if len(msg.layout.dim) == 1 else "")
    assert same_floats(values, msg.data)
    time_of = m.raw_time_reader("std_msgs/msg/Float64MultiArray")
    leading = label.split(",")[0] == "time_s" and len(msg.data) > 0
    assert time_of(serialize_message(msg)) == (m.time_to_ns(msg.data[0]) if leading else None)


# -- malformed bytes ----------------------------------------------------------------------------
def check_every_truncation(data: bytes, decode) -> int:
    """Each prefix raises MessageError or, when only trailing padding is cut, decodes to the full
    message's values -- never to other values. Returns the shortest prefix that decodes."""
    full = decode(data)
    decoded = [cut for cut in range(len(data) + 1) if not raises_message_error(decode, data[:cut])]
    assert decoded == list(range(decoded[0], len(data) + 1))
    assert all(decode(data[:cut]) == full for cut in decoded)
    return decoded[0]


def raises_message_error(decode, data) -> bool:
    try:
        decode(data)
    except m.MessageError:
        return True
    return False


def test_truncated_messages_raise_message_error():
    data = m.RotorBytes().fill(123, 1.0, 2.0)[0]
    # encapsulation 4, stamp 8, frame_id 4 + "rotor\0" + 2, name: 4 + 4 + "rotor\0" + 2,
    # position 4 + 8, velocity 4 + 4 padding + 8, effort 4
    assert check_every_truncation(data, m.joint_state) == 72
    velocity_at = data.index(struct.pack("<d", 2.0))
    with pytest.raises(m.MessageError, match=r"sensor_msgs/msg/JointState: truncated -- velocity"):
        m.joint_state(data[:velocity_at + 4])
    arr = m.LabelledBytes(["a", "bb"]).fill(0.5, [1.0, 2.0])
    # encapsulation 4, dim count 4, label 4 + "time_s,a,bb\0" (12), size, stride, data_offset,
    # data count 4 each, 4 padding (8-aligned after the encapsulation), data 3 x 8
    assert check_every_truncation(arr, m.labelled_array) == 4 + 4 + 16 + 16 + 4 + 24
    with pytest.raises(m.MessageError, match=r"Float64MultiArray: truncated -- data needs"):
        m.labelled_array(arr[:-1])
    for msg in JOINTS:
        check_every_truncation(serialize_message(msg), m.joint_state)


def test_malformed_messages_raise_message_error():
    data = bytearray(m.RotorBytes().fill(123, 1.0, 2.0)[0])
    big_endian = bytes([0, 0]) + bytes(data[2:])
    with pytest.raises(m.MessageError, match="JointState: not little-endian CDR"):
        m.joint_state(big_endian)
    with pytest.raises(m.MessageError, match="not little-endian CDR"):
        m.labelled_array(b"\x00\x01")
    huge = bytearray(data)
    huge[24:28] = struct.pack("<I", 0xFFFFFFFF)          # name count
    with pytest.raises(m.MessageError, match=r"truncated -- name\[i\]"):
        m.joint_state(bytes(huge))
    unterminated = bytearray(data)
    unterminated[16 + 5] = ord("!")                      # frame_id "rotor\0" -> "rotor!"
    with pytest.raises(m.MessageError, match="header.frame_id is not a NUL-terminated string"):
        m.joint_state(bytes(unterminated))
    arr = bytearray(m.LabelledBytes(["a"]).fill(0.5, [1.0]))
    bad_utf8 = bytearray(arr)
    bad_utf8[12] = 0xFF                                  # first byte of the label
    with pytest.raises(m.MessageError, match=r"layout.dim\[i\].label is not UTF-8"):
        m.labelled_array(bytes(bad_utf8))
    # dim count @4, label "time_s,a\0" @8..21, size @24, stride @28, data_offset @32, count @36
    assert struct.unpack_from("<III", arr, 28) == (2, 0, 2)
    arr[36:40] = struct.pack("<I", 2**31)
    with pytest.raises(m.MessageError, match="truncated -- data needs"):
        m.labelled_array(bytes(arr))
    assert issubclass(m.MessageError, ValueError)
    assert m.received_time_ns(0.0006) == 600_000 and m.received_time_ns(2.0**31 - 1) == \
        (2**31 - 1) * 10**9
    for bad in (math.nan, -1e-9, 2.0**31, math.inf, 1e300):
        with pytest.raises(m.MessageError, match="is not a sim time"):
            m.received_time_ns(bad)


# -- the nodes report a malformed message instead of failing ------------------------------------
@pytest.fixture(scope="module")
def ros():
    import rclpy
    rclpy.init()
    yield
    rclpy.shutdown()


def test_nodes_ignore_and_report_malformed_messages(ros):
    from rclpy.parameter import Parameter

    from rotor_avc.nodes.balancer import Balancer
    from rotor_avc.nodes.plant_simulator import PlantSimulator
    from rotor_avc.nodes.synchronous_controller import SynchronousController
    garbage = b"\x00\x01\x00\x00\x05"

    def p(**values):
        return [Parameter(k, value=v) for k, v in values.items()]
    bal = Balancer("bal_malformed", parameter_overrides=p(scenario="scenario_balance_runup"))
    plant = PlantSimulator("plant_malformed", parameter_overrides=p(
        scenario="scenario_balance_runup", balancer=True))
    ff = SynchronousController("ff_malformed", parameter_overrides=p(
        scenario="scenario_active_bearing"))
    try:
        bal._on_joint(garbage)
        assert bal.faults == 1 and "rotor/joint_state ignored: sensor_msgs/msg/JointState: " \
            "truncated" in bal.last_fault
        bal._on_observables(m.LabelledBytes(["a"]).fill(0.5, [1.0])[:-3])
        assert bal.faults == 2 and "plant/observables ignored" in bal.last_fault
        bal._on_observables(serialize_message(labelled(["a,time_s"], [1.0, 2.0])))
        assert bal.faults == 3 and "no leading time_s" in bal.last_fault
        bal._on_observables(m.LabelledBytes(["a"]).fill(-1.0, [1.0]))
        assert bal.faults == 4 and "time_s = -1.0 is not a sim time" in bal.last_fault
        assert not bal.joints and not bal.values
        plant._on_balancer(garbage)
        plant._on_balancer(m.LabelledBytes(["static_re"]).fill(0.0, [1.0]))
        plant._on_balancer(m.LabelledBytes([n for n in plant.command_label.split(",")[1:]])
                           .fill(0.0, [math.nan] + [0.0] * (plant.command_size - 2)))
        assert len(plant.fault_log) == 3, plant.fault_log
        assert "Float64MultiArray: truncated" in plant.fault_log[0]
        assert "'time_s,static_re' with 2 values, not" in plant.fault_log[1]
        assert "not finite" in plant.fault_log[2]
        ff._on_joint(garbage)
        assert ff.faults == 1 and "JointState: truncated" in ff.last_fault
    finally:
        for node in (bal, plant, ff):
            node.destroy_node()
