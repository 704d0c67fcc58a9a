"""CDR codec: round trips, batch layout against per-message coding, and two independent
implementations of the wire format -- the `rosbags` serializer and rclpy/rmw_fastrtps."""
import numpy as np
import pytest

from rotor_avc.bag import msgdefs
from rotor_avc.bag.cdr import DTYPES, CdrCodec, CdrError

SPECS = msgdefs.known_specs()
TYPES = sorted(msgdefs.DEFINITIONS)


def random_message(name, rng, seq_len=None):
    """A message dict with random values for every field of a vendored type."""
    out = {}
    for f in SPECS[name].fields:
        def one():
            if f.nested:
                return random_message(f.type, rng, seq_len)
            if f.type == "string":
                return "".join(rng.choice(list("abcxyz_/ 09"), size=rng.integers(0, 9)))
            if f.type.startswith("float"):
                return float(rng.standard_normal()) if f.type == "float64" else float(
                    np.float32(rng.standard_normal()))
            if f.type in ("byte", "char"):      # rosbags packs byte as signed: 0..127 is common
                return int(rng.integers(0, 128))
            info = np.iinfo(DTYPES[f.type])
            return int(rng.integers(max(info.min, -2**31), min(info.max, 2**31 - 1)))
        if f.kind == "scalar":
            out[f.name] = one()
        else:
            n = f.size if f.kind == "array" else (seq_len if seq_len is not None
                                                   else int(rng.integers(0, 4)))
            items = [one() for _ in range(n)]
            out[f.name] = np.array(items, dtype=DTYPES[f.type]) if not f.nested and \
                f.type != "string" else items
    return out


def assert_same(a, b, where="msg"):
    if isinstance(a, dict):
        assert set(a) == set(b), where
        for k in a:
            assert_same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)) and a and isinstance(a[0], dict):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, (np.ndarray, list, tuple)) and not (isinstance(a, list) and a and
                                                           isinstance(a[0], str)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=where)
    else:
        assert a == b, where


@pytest.mark.parametrize("name", TYPES)
def test_round_trip(name):
    rng = np.random.default_rng(abs(hash(name)) % 2**32)
    codec = CdrCodec(name, SPECS)
    for _ in range(5):
        msg = random_message(name, rng)
        assert_same(msg, codec.decode(codec.encode(msg)))


@pytest.mark.parametrize("name", TYPES)
def test_batch_layout_equals_per_message_coding(name):
    rng = np.random.default_rng(7)
    codec = CdrCodec(name, SPECS)
    msgs = [random_message(name, rng, seq_len=2) for _ in range(6)]
    # same structure: copy strings of the first message into the others
    template = codec.encode(msgs[0])
    layout = codec.layout(template)
    rows = np.stack([np.frombuffer(codec.encode(_with_strings(m, msgs[0])), np.uint8)
                     for m in msgs])
    assert layout.matches(rows)
    decoded = layout.decode(rows)
    for i in range(len(msgs)):
        single = codec.layout(rows[i].tobytes()).decode(rows[i:i + 1])
        for path, values in single.items():
            np.testing.assert_array_equal(decoded[path][i], values[0])
    again = layout.encode(template, decoded, len(msgs))
    for i in range(len(msgs)):
        assert_same(codec.decode(rows[i].tobytes()), codec.decode(again[i].tobytes()))


def _with_strings(msg, ref):
    """``msg`` with the strings (and string lists) of ``ref``: the same CDR structure."""
    out = {}
    for k, v in msg.items():
        r = ref[k]
        if isinstance(v, dict):
            out[k] = _with_strings(v, r)
        elif isinstance(v, str) or (isinstance(v, list) and v and isinstance(v[0], str)):
            out[k] = r
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            out[k] = [_with_strings(a, b) for a, b in zip(v, r)]
        else:
            out[k] = v
    return out


def test_layout_rejects_a_different_structure():
    codec = CdrCodec("sensor_msgs/msg/JointState", SPECS)
    a = codec.encode({"name": ["rotor"], "position": [1.0]})
    b = codec.encode({"name": ["rotor"], "position": [1.0, 2.0]})[:len(a)]
    rows = np.stack([np.frombuffer(a, np.uint8), np.frombuffer(b, np.uint8)])
    assert not codec.layout(a).matches(rows)


def test_wire_format_example():
    """Alignment is relative to the end of the 4-byte header: float64 at payload offset 8k."""
    codec = CdrCodec("sensor_msgs/msg/JointState", SPECS)
    data = codec.encode({"header": {"frame_id": "abc"}, "name": ["rotor"], "position": [1.0]})
    assert data[:4] == b"\x00\x01\x00\x00"
    assert data[4 + 12:4 + 16] == b"abc\x00"
    assert np.frombuffer(data, "<f8", 1, 4 + 40)[0] == 1.0      # after count at 32, pad to 40


@pytest.mark.parametrize("name", TYPES)
def test_interop_with_rosbags_serializer(name):
    typesys = pytest.importorskip("rosbags.typesys")
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    rng = np.random.default_rng(11)
    codec = CdrCodec(name, SPECS)
    for _ in range(4):
        msg = random_message(name, rng)
        theirs = bytes(store.serialize_cdr(_to_rosbags(store, name, msg), name))
        assert_same(msg, codec.decode(theirs))
        assert_same(msg, _from_rosbags(store.deserialize_cdr(codec.encode(msg), name), name))


def _to_rosbags(store, name, msg):
    cls = store.types[name]
    kwargs = {}
    for f in SPECS[name].fields:
        v = msg[f.name]
        if f.nested:
            v = ([_to_rosbags(store, f.type, x) for x in v] if f.kind != "scalar"
                 else _to_rosbags(store, f.type, v))
        kwargs[f.name] = v
    return cls(**kwargs)


def _from_rosbags(obj, name):
    out = {}
    for f in SPECS[name].fields:
        v = getattr(obj, f.name)
        if f.nested:
            v = ([_from_rosbags(x, f.type) for x in v] if f.kind != "scalar"
                 else _from_rosbags(v, f.type))
        out[f.name] = v
    return out


@pytest.mark.ros
def test_interop_with_rclpy_serialization():
    """rmw_fastrtps (via rclpy) and this codec read each other's bytes."""
    serialization = pytest.importorskip("rclpy.serialization")
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from geometry_msgs.msg import AccelStamped, WrenchStamped
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    js = JointState(name=["rotor"], position=[1.5], velocity=[], effort=[2.0])
    js.header.stamp.sec, js.header.stamp.nanosec, js.header.frame_id = 3, 7, "rotor"
    acc = AccelStamped()
    acc.header.frame_id, acc.accel.linear.z = "foot_DL", -0.25
    wr = WrenchStamped()
    wr.header.frame_id, wr.wrench.force.z = "foot_NL", 12.5
    arr = Float64MultiArray(data=[1.0, 2.0, 3.0])
    arr.layout.dim = [MultiArrayDimension(label="a,b,c", size=3, stride=3)]
    diag = DiagnosticArray(status=[DiagnosticStatus(level=b"\x01", name="plant", message="ok",
                                                    values=[KeyValue(key="k", value="v")])])
    cases = [(js, "sensor_msgs/msg/JointState"), (acc, "geometry_msgs/msg/AccelStamped"),
             (wr, "geometry_msgs/msg/WrenchStamped"), (arr, "std_msgs/msg/Float64MultiArray"),
             (diag, "diagnostic_msgs/msg/DiagnosticArray")]
    for ros_msg, name in cases:
        codec = CdrCodec(name, SPECS)
        ours = codec.decode(serialization.serialize_message(ros_msg))
        back = serialization.deserialize_message(codec.encode(ours), type(ros_msg))
        assert back == ros_msg, name
    assert ours["status"][0]["level"] == 1 and ours["status"][0]["values"][0]["value"] == "v"


@pytest.mark.parametrize("data, problem", [
    (b"\x00\x01", "shorter than the CDR header"),
    (b"\x00\x00\x00\x00" + bytes(8), "big-endian CDR is not supported"),
    (b"\x00\x01\x00\x00" + bytes(6), "payload ends at byte"),
])
def test_decode_errors(data, problem):
    with pytest.raises(CdrError, match=problem):
        CdrCodec("rosgraph_msgs/msg/Clock", SPECS).decode(data)


def test_encode_errors_name_the_field():
    codec = CdrCodec("sensor_msgs/msg/JointState", SPECS)
    with pytest.raises(CdrError, match=r"JointState.position: not a list of float64"):
        codec.encode({"position": ["x"]})
    with pytest.raises(CdrError, match=r"header.stamp.sec: .* not a valid int32"):
        codec.encode({"header": {"stamp": {"sec": 2**40}}})
