"""The foot controller node under hostile input and overload, and with sensor_msgs/Imu input,
in a rclpy executor: a wrong frame_id and a message stamped 2^31-1 s each cost one sample (the
answers afterwards are the reference block's exactly), a flood of 20,000 measurements is
reported as dropped on /diagnostics, an Imu accelerometer drives the controller with its axis,
sign and scale, and an unstable design is refused at start-up. External inputs (an Imu, a stamped
vector on a driver's topic) are answered from publishers of every usual QoS -- rclpy's sensor-data
profile (best effort) as drivers publish, the default (reliable, volatile) and transient-local --
while a publisher the plant's lockstep subscription cannot match is an ERROR on /diagnostics
naming the fix."""
import math
import time

import numpy as np
import pytest

from ros_helpers import make_executor, params, rclpy, spin_until  # noqa: F401
from test_ros_faults import Listener
from test_ros_graph import scenario_file

from geometry_msgs.msg import AccelStamped
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import Imu

from rotor_avc.analysis.design_check import DesignError
from rotor_avc.control.block import build_digital_controllers
from rotor_avc.nodes import foot_controller as fc_module
from rotor_avc.nodes import messages as m
from rotor_avc.nodes.foot_controller import FootController
from rotor_avc.nodes.plant_simulator import PlantSimulator
from rotor_avc.nodes.runtime import ParameterError
from rotor_avc.scenario import load_scenario

pytestmark = pytest.mark.ros
G = 9.80665


@pytest.fixture(scope="module", autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


@pytest.fixture
def scenario(tmp_path):
    return scenario_file(tmp_path, "foot_mount_case3", 20.0, initial="rest")


def reference(sc):
    ref = build_digital_controllers(load_scenario(sc).machine, load_scenario(sc).sample_period_s)["DL"]
    ref.reset()
    return ref


def drive(ctrl, msg_type, topic, messages, fill):
    """Publish ``messages`` one at a time, each after the answer to the one before; the forces."""
    lis = Listener(f"listener_{ctrl.get_name()}")
    pub = lis.node.create_publisher(msg_type, topic, m.LOCKSTEP_QOS)
    ex = make_executor("events")
    for n in (ctrl, lis.node):
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0, timeout_s=10)
        msg = msg_type()
        for item in messages:
            fill(msg, *item)
            n_before = len(lis.forces.get("DL", []))
            pub.publish(msg)
            assert spin_until(ex, lambda: len(lis.forces.get("DL", [])) > n_before, timeout_s=10)
    finally:
        ex.shutdown()
        ctrl.destroy_node()
        lis.node.destroy_node()
    return [f for _, f in lis.forces["DL"]], lis


def test_wrong_frame_and_far_future_stamp_cost_one_sample(scenario):
    T = load_scenario(scenario).sample_period_s
    ctrl = FootController("fc_hostile", parameter_overrides=params(scenario=scenario, foot_id="DL"))
    x = np.sin(np.arange(40) * 0.3).tolist()
    sent = [(m.sample_ns(k, T), v, "foot_DL") for k, v in enumerate(x)]
    sent[10] = (sent[10][0], 50.0, "imu_link")                     # wrong frame
    sent[20] = ((2**31 - 1) * 10**9, 50.0, "foot_DL")              # stamped 2^31-1 s

    def fill(msg, stamp, value, frame):
        m.set_stamp(msg.header.stamp, stamp)
        msg.header.frame_id = frame
        msg.accel.linear.z = value

    got, lis = drive(ctrl, AccelStamped, m.actuator_topic("DL", "acceleration"), sent, fill)
    ref = reference(scenario)
    expected = [ref.step(v) for k, v in enumerate(x) if k not in (10, 20)]
    assert got[10] == got[9] and got[20] == got[19]                  # safe output: hold
    assert got[:10] + got[11:20] + got[21:] == expected              # recovered at once
    counts = ctrl.counts
    # the two rejected samples are missing from the accepted stream: counted as dropped too
    assert counts["wrong_frame"] == 1 and counts["future"] == 1 and counts["dropped"] == 2
    warnings = [st.message for st in lis.statuses("warn")]
    assert any("not from frame 'foot_DL'" in w for w in warnings)


def test_imu_accelerometer_drives_the_controller(scenario):
    """Imu on its y axis, mounted upside down (sign -1), publishing in g: the node's forces equal
    the reference block's on the foot acceleration in m/s^2."""
    T = load_scenario(scenario).sample_period_s
    ctrl = FootController("fc_imu", parameter_overrides=params(
        scenario=scenario, foot_id="DL", input="imu", imu_axis="y", imu_sign=-1, imu_scale=G,
        frame_id="imu_DL", measurement_topic="/sensors/imu_DL/data"))
    accel = (3.0 * np.sin(np.arange(60) * 0.2)).tolist()                # m/s^2, foot axis

    def fill(msg, k, a):
        m.set_stamp(msg.header.stamp, m.sample_ns(k, T))
        msg.header.frame_id = "imu_DL"
        msg.linear_acceleration.y = -a / G
        msg.linear_acceleration.z = 1.0                                 # gravity: not the axis
        msg.angular_velocity.y = 123.0

    got, _ = drive(ctrl, Imu, "/sensors/imu_DL/data", list(enumerate(accel)), fill)
    ref = reference(scenario)
    np.testing.assert_allclose(got, [ref.step(a) for a in accel], rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("overrides,field", [
    ({"input": "imu", "imu_sign": 0}, "imu_sign"),
    ({"input": "imu", "imu_scale": -1.0}, "imu_scale"),
    ({"input": "accelerometer"}, "input"),
    ({"imu_axis": "w"}, "imu_axis"),
    ({"max_stamp_jump_s": 0.0}, "max_stamp_jump_s"),
])
def test_bad_input_parameters_are_refused_by_name(scenario, overrides, field):
    with pytest.raises(ParameterError, match=f"'{field}'"):
        FootController("fc_bad_param", parameter_overrides=params(scenario=scenario, foot_id="DL",
                                                                  **overrides))


def test_flood_of_measurements_is_reported_as_dropped(scenario):
    """20,000 measurements published as fast as possible, faster than the controller takes
    them: the gaps in the stamps count the drops exactly, /diagnostics reports them (count and
    rate), and the state stays bounded (finite, the filter's few floats). The flood spans 4 s
    of stamps, so max_stamp_jump_s is raised above that (a longer gap would be a new time base)."""
    T = load_scenario(scenario).sample_period_s
    ctrl = FootController("fc_flood", parameter_overrides=params(scenario=scenario, foot_id="DL",
                                                                 max_stamp_jump_s=10.0))
    lis = Listener("listener_flood")
    pub = lis.node.create_publisher(AccelStamped, m.actuator_topic("DL", "acceleration"), m.LOCKSTEP_QOS)
    ex = make_executor("events")
    for n in (ctrl, lis.node):
        ex.add_node(n)
    n_sent = 20_000
    last_ns = m.sample_ns(n_sent - 1, T)
    try:
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0, timeout_s=10)
        msg = AccelStamped()
        msg.header.frame_id = "foot_DL"
        for k in range(n_sent):
            m.set_stamp(msg.header.stamp, m.sample_ns(k, T))
            msg.accel.linear.z = math.sin(0.01 * k)
            pub.publish(msg)
            if k == 0:             # the stream's first sample taken: the reference for its gaps
                assert spin_until(ex, lambda: ctrl.stamps.last_ns == 0, timeout_s=10)
        assert spin_until(ex, lambda: ctrl.stamps.last_ns == last_ns, timeout_s=60)
        ctrl._publish_diagnostics()

        def reported():
            return [st for st in lis.statuses("warn") if st.name.endswith(": DL")
                    and {kv.key: kv.value for kv in st.values}.get("dropped") not in (None, "0")]
        assert spin_until(ex, lambda: bool(reported()), timeout_s=10)
    finally:
        ex.shutdown()
        ctrl.destroy_node()
        lis.node.destroy_node()
    processed = ctrl.timing.iterations
    dropped = ctrl.counts["dropped"]
    assert dropped > 0 and processed + dropped == n_sent
    st = reported()[-1]
    values = {kv.key: kv.value for kv in st.values}
    assert int(values["dropped"]) == dropped and float(values["dropped_per_s"]) > 0
    assert "dropped" in st.message
    assert all(math.isfinite(z) for z in ctrl.ctrl.filter.state)


def test_unstable_design_is_refused_at_start_up(tmp_path):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, initial="rest")
    path = tmp_path / "neg.yaml"
    path.write_text(f"include: {sc}\ncontrollers:\n" + "".join(
        f"  {f}: {{ki: -1.4e+5}}\n" for f in ("DL", "DR", "NL")))
    with pytest.raises(DesignError, match="fc_unstable.*UNSTABLE.*damping ratio -"):
        FootController("fc_unstable", parameter_overrides=params(scenario=str(path), foot_id="DL"))
    with pytest.raises(DesignError, match="plant_unstable.*UNSTABLE.*allow_unstable"):
        PlantSimulator("plant_unstable", parameter_overrides=params(scenario=str(path)))
    allowed = tmp_path / "allowed.yaml"
    allowed.write_text(f"include: {path}\ncontrol: {{allow_unstable: true}}\n")
    FootController("fc_allowed", parameter_overrides=params(scenario=str(allowed),
                                                            foot_id="DL")).destroy_node()


def test_fuzzed_measurement_bytes_never_break_the_controller(scenario):
    """500 corrupted measurements (bytes flipped anywhere, truncated, extended) between good
    ones, straight into the node's callback: each is answered or refused as malformed (no
    exception), the filter state stays finite and every answer is finite."""
    T = load_scenario(scenario).sample_period_s
    ctrl = FootController("fc_fuzz", parameter_overrides=params(scenario=scenario, foot_id="DL"))
    answers = []
    ctrl.pub.publish = lambda data: answers.append(m.stamped_value(data, "z")[1])
    rng = np.random.default_rng(11)
    meas = m.Measurement("acceleration", "DL")
    try:
        for k in range(500):
            good = meas.fill(m.sample_ns(2 * k, T), float(np.sin(0.1 * k)))
            ctrl._on_measurement(good)
            bad = bytearray(meas.fill(m.sample_ns(2 * k + 1, T), float(np.cos(0.1 * k))))
            kind = k % 3
            if kind == 0:
                for i in rng.integers(0, len(bad), 3):
                    bad[i] = int(rng.integers(0, 256))
            elif kind == 1:
                bad = bad[:int(rng.integers(0, len(bad)))]
            else:
                bad += rng.bytes(int(rng.integers(1, 64)))
            ctrl._on_measurement(bytes(bad))
    finally:
        ctrl.destroy_node()
    counts = ctrl.counts
    assert len(answers) + counts["malformed"] == 1000
    assert all(math.isfinite(f) for f in answers)
    assert all(math.isfinite(z) for z in ctrl.ctrl.filter.state)
    assert counts["malformed"] > 0 and counts["implausible"] + counts["future"] + counts["stale"] > 0


#: publisher QoS profiles a sensor input meets: what drivers use, rclpy's default, transient-local
PUBLISHER_QOS = {"sensor_data": qos_profile_sensor_data, "default": QoSProfile(depth=10),
                 "transient_local": QoSProfile(depth=10,
                                               durability=DurabilityPolicy.TRANSIENT_LOCAL)}
#: input kind -> message type, the driver's topic and how a message carries ``a`` (m/s^2)
SENSOR_INPUTS = {
    "stamped": (AccelStamped, "/driver/accel_DL",
                lambda msg, a: setattr(msg.accel.linear, "z", a)),
    "imu": (Imu, "/driver/imu_DL", lambda msg, a: setattr(msg.linear_acceleration, "z", a)),
}


def answered(ctrl, lis, pub, msg_type, fill, values, T) -> list[float]:
    """Publish one measurement per value (stamp k T), each after the answer to the one before;
    a measurement without an answer is published again after a while (best effort may lose one;
    the controller answers a repeated stamp from its cache). The forces, one per stamp."""
    ex = make_executor("events")
    for n in (ctrl, lis.node):
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0, timeout_s=30)
        msg = msg_type()
        msg.header.frame_id = "foot_DL"
        for k, value in enumerate(values):
            m.set_stamp(msg.header.stamp, m.sample_ns(k, T))
            fill(msg, value)
            stamp = m.sample_ns(k, T)
            t_end = time.monotonic() + 60
            while not any(s == stamp for s, _ in lis.forces.get("DL", [])):
                assert time.monotonic() < t_end, f"no answer to measurement {k}"
                pub.publish(msg)
                spin_until(ex, lambda: any(s == stamp for s, _ in lis.forces.get("DL", [])),
                           timeout_s=2)
    finally:
        ex.shutdown()
    return list(dict(lis.forces["DL"]).values())


@pytest.mark.parametrize("profile", list(PUBLISHER_QOS))
@pytest.mark.parametrize("kind", list(SENSOR_INPUTS))
def test_sensor_input_is_answered_from_every_publisher_qos(scenario, kind, profile):
    """The default measurement_qos (auto: sensor_data for an external input) matches a
    best-effort, a default and a transient-local publisher: every measurement is answered with
    the reference block's force."""
    T = load_scenario(scenario).sample_period_s
    msg_type, topic, fill = SENSOR_INPUTS[kind]
    ctrl = FootController(f"fc_qos_{kind}_{profile}", parameter_overrides=params(
        scenario=scenario, foot_id="DL", input=kind, measurement_topic=topic))
    assert ctrl.qos_name == "sensor_data"
    lis = Listener(f"listener_qos_{kind}_{profile}")
    pub = lis.node.create_publisher(msg_type, topic, PUBLISHER_QOS[profile])
    accel = (2.0 * np.sin(np.arange(30) * 0.25)).tolist()
    try:
        got = answered(ctrl, lis, pub, msg_type, fill, accel, T)
    finally:
        ctrl.destroy_node()
        lis.node.destroy_node()
    ref = reference(scenario)
    np.testing.assert_allclose(got, [ref.step(a) for a in accel], rtol=1e-12, atol=1e-9)
    assert ctrl.counts["incompatible_qos"] == 0


def test_publisher_the_lockstep_subscription_cannot_match_is_an_error(scenario, monkeypatch):
    """On the plant's own topic the subscription stays the lockstep one (reliable,
    transient-local): a best-effort publisher there is never matched -- said as an ERROR on
    /diagnostics and counted, naming the policy and the fix, until it is gone; with the fix
    (measurement_qos sensor_data) the same publisher is answered."""
    T = load_scenario(scenario).sample_period_s
    topic = m.actuator_topic("DL", "acceleration")
    ctrl = FootController("fc_qos_lockstep", parameter_overrides=params(scenario=scenario,
                                                                        foot_id="DL"))
    assert ctrl.qos_name == "lockstep"
    lis = Listener("listener_qos_lockstep")
    pub = lis.node.create_publisher(AccelStamped, topic, qos_profile_sensor_data)
    ex = make_executor("events")
    for n in (ctrl, lis.node):
        ex.add_node(n)

    def errors():
        return [st for st in lis.statuses("error") if st.name.endswith(": DL")]
    try:
        assert spin_until(ex, lambda: bool(errors()), timeout_s=30)
        text = errors()[-1].message
        assert "RELIABILITY" in text and "fix: -p measurement_qos:=sensor_data" in text, text
        assert topic in text and ctrl.counts["incompatible_qos"] >= 1
        assert pub.get_subscription_count() == 0                # never matched: nothing arrives
        monkeypatch.setattr(fc_module, "QOS_RECHECK_S", 0.0)
        lis.node.destroy_publisher(pub)                            # the bad publisher leaves
        n_ok = len(lis.statuses("ok"))
        assert spin_until(ex, lambda: any(st.name.endswith(": DL")
                                          for st in lis.statuses("ok")[n_ok:]), timeout_s=30)
        assert not ctrl.qos_error
    finally:
        ex.shutdown()
        ctrl.destroy_node()
        lis.node.destroy_node()
    fixed = FootController("fc_qos_fixed", parameter_overrides=params(
        scenario=scenario, foot_id="DL", measurement_qos="sensor_data"))
    lis = Listener("listener_qos_fixed")
    pub = lis.node.create_publisher(AccelStamped, topic, qos_profile_sensor_data)
    accel = [0.5, -1.0, 2.0, 0.25]
    try:
        got = answered(fixed, lis, pub, AccelStamped, SENSOR_INPUTS["stamped"][2], accel, T)
    finally:
        fixed.destroy_node()
        lis.node.destroy_node()
    ref = reference(scenario)
    np.testing.assert_allclose(got, [ref.step(a) for a in accel], rtol=1e-12, atol=1e-9)
