"""The foot controller node under hostile input and overload, and with sensor_msgs/Imu input,
in a rclpy executor: a wrong frame_id and a message stamped 2^31-1 s each cost one sample (the
answers afterwards are the reference block's exactly), a flood of 20,000 measurements is
reported as dropped on /diagnostics, an Imu accelerometer drives the controller with its axis,
sign and scale, and an unstable design is refused at start-up."""
import math

import numpy as np
import pytest

from ros_helpers import make_executor, params, rclpy, spin_until  # noqa: F401
from test_ros_faults import Listener
from test_ros_graph import scenario_file

from geometry_msgs.msg import AccelStamped
from sensor_msgs.msg import Imu

from rotor_avc.analysis.design_check import DesignError
from rotor_avc.control.block import build_digital_controllers
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

    got, lis = drive(ctrl, AccelStamped, m.foot_topic("DL", "acceleration"), sent, fill)
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
    pub = lis.node.create_publisher(AccelStamped, m.foot_topic("DL", "acceleration"), m.LOCKSTEP_QOS)
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
