"""Fault cases of the ROS graph: a controller that stops answering (hung, killed), bad and stale
measurements, real-time mode with its timing diagnostics, clean shutdown on SIGINT/SIGTERM."""
import math
import signal
import time

import numpy as np
import pytest

from ros_helpers import (make_executor, node_process, params, rclpy, spin_until,  # noqa: F401
                         stop, wait_for_nodes)
from test_ros_graph import FEET, scenario_file

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import AccelStamped, WrenchStamped

from rotor_avc.control.block import build_digital_controllers
from rotor_avc.nodes import messages as m
from rotor_avc.nodes.foot_controller import FootController
from rotor_avc.nodes.namespace_guard import EXIT_NAMESPACE_TAKEN
from rotor_avc.nodes.plant_simulator import PlantSimulator
from rotor_avc.scenario import load_scenario

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module", autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


class Listener:
    """A node collecting /diagnostics and the actuator forces."""

    def __init__(self, name="listener"):
        self.node = rclpy.create_node(name)
        self.diag: list = []
        self.forces: dict = {}
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.diag.append, 100)
        for f in FEET:
            self.node.create_subscription(
                WrenchStamped, m.actuator_topic(f, "actuator_force"),
                lambda msg, f=f: self.forces.setdefault(f, []).append(
                    (m.stamp_ns(msg.header.stamp), msg.wrench.force.z)), m.LOCKSTEP_QOS)

    def statuses(self, level=None):
        out = []
        for arr in self.diag:
            for st in arr.status:
                if level is None or st.level == m.LEVELS[level]:
                    out.append(st)
        return out


@pytest.mark.parametrize("policy", ["hold", "zero"])
def test_hung_controller_gets_the_fault_policy_and_returns(tmp_path, policy):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.4)
    plant = PlantSimulator("plant_fault", parameter_overrides=params(
        scenario=sc, controller_timeout_s=0.3, fault_policy=policy))
    ctrls = {f: FootController(f"fc_{f}", parameter_overrides=params(scenario=sc, foot_id=f))
             for f in FEET}
    lis = Listener()
    ex = make_executor("events")
    for n in [plant, lis.node, *ctrls.values()]:
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: plant.k >= 300)
        ex.remove_node(ctrls["NL"])                          # NL hangs: no more answers
        k_hang = plant.k
        assert spin_until(ex, lambda: "NL" in plant.book.absent(), timeout_s=10)
        assert spin_until(ex, lambda: plant.k >= k_hang + 400, timeout_s=30)
        ex.add_node(ctrls["NL"])                             # ... and comes back
        k_back = plant.k
        assert spin_until(ex, lambda: plant.finished, timeout_s=60)
        spin_until(ex, lambda: False, timeout_s=0.3)          # deliver the last diagnostics
    finally:
        ex.shutdown()
        for n in [plant, lis.node, *ctrls.values()]:
            n.destroy_node()
    ts = plant.result()
    f_nl = ts["actuator_NL_fz"]
    held = f_nl[k_hang + 5:k_hang + 400]
    # hold: NL's last answer (given around the sample it hung at); zero: zero force
    expected = held[0] if policy == "hold" else 0.0
    assert np.all(held == expected), (held[:5], expected)
    if policy == "hold":
        assert expected in f_nl[k_hang - 3:k_hang + 2] and expected != 0.0
    assert np.std(f_nl[k_back + 50:]) > 0.1 * np.std(f_nl[:k_hang])      # answering again
    assert not plant.book.absent() and plant.book.responders["NL"].faults == 1
    errors = [st for st in lis.statuses("error") if "NL" in st.message]
    assert errors and "no answer within 0.3 s" in errors[0].message and policy in errors[0].message
    assert any("run complete" in st.message for st in lis.statuses())


def test_killed_controller_process(tmp_path):
    """The plant (here) with its controllers in separate processes; SIGKILL one of them, restart
    it: the plant reports the fault, applies the policy, and resumes with the new process."""
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=2.0)
    plant = PlantSimulator("plant_kill", parameter_overrides=params(
        scenario=sc, controller_timeout_s=0.5, fault_policy="hold"))
    procs = {f: node_process("foot_controller", "-r", f"__node:=fc_{f}", "-p", f"scenario:={sc}",
                             "-p", f"foot_id:={f}") for f in FEET}
    ex = make_executor("events")
    ex.add_node(plant)
    try:
        assert spin_until(ex, lambda: plant.k >= 500, timeout_s=90)
        procs["DR"].send_signal(signal.SIGKILL)
        procs["DR"].wait(timeout=10)
        assert spin_until(ex, lambda: "DR" in plant.book.absent(), timeout_s=10)
        procs["DR"] = node_process("foot_controller", "-r", "__node:=fc_DR", "-p",
                                   f"scenario:={sc}", "-p", "foot_id:=DR")
        # the plant (not spun meanwhile) waits until the new process is in the graph: on a
        # busy machine it would otherwise step through the rest of the run before DR is back
        assert wait_for_nodes(["fc_DR"], procs=[procs["DR"]])
        assert spin_until(ex, lambda: not plant.book.absent() or plant.finished, timeout_s=90)
        assert spin_until(ex, lambda: plant.finished, timeout_s=120)
    finally:
        ex.shutdown()
        plant.destroy_node()
        for p in procs.values():
            stop(p)
    # the kill is a fault; a restarted process may miss a deadline again while it starts up on a
    # busy machine (each miss is a fault, said), but it ends present, answering
    dr = plant.book.responders["DR"]
    assert dr.faults >= 1 and dr.present and dr.fault_reason.startswith("returned after fault")
    assert any("DR" in text and "no answer" in text for text in plant.fault_log)


def test_bad_and_stale_measurements_hold_a_safe_output(tmp_path):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, initial="rest")
    ctrl = FootController("fc_bad", parameter_overrides=params(scenario=sc, foot_id="DL"))
    lis = Listener("listener_bad")
    pub = lis.node.create_publisher(AccelStamped, m.actuator_topic("DL", "acceleration"), m.LOCKSTEP_QOS)
    ex = make_executor("events")
    for n in (ctrl, lis.node):
        ex.add_node(n)
    T = load_scenario(sc).sample_period_s
    ref = build_digital_controllers(load_scenario(sc).machine, T)["DL"]
    ref.reset()
    sent = [(1, 0.5), (2, -0.25), (3, math.nan), (4, 0.3), (2, 0.7), (5, math.inf), (6, 0.1),
            (6, 0.1)]
    a, b, c, d = (ref.step(v) for v in (0.5, -0.25, 0.3, 0.1))    # only the good samples step
    expected = [a, b, b, c, c, c, d, d]          # nan, stale 2, inf: held; repeated 6: cached
    try:
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0, timeout_s=10)
        msg = AccelStamped()
        msg.header.frame_id = "foot_DL"
        for k, value in sent:
            m.set_stamp(msg.header.stamp, m.sample_ns(k, T))
            msg.accel.linear.z = value
            pub.publish(msg)
            n_before = len(lis.forces.get("DL", []))
            assert spin_until(ex, lambda: len(lis.forces.get("DL", [])) > n_before, timeout_s=10)
        spin_until(ex, lambda: False, timeout_s=0.3)
        n_answers = len(lis.forces["DL"])
        ctrl._on_measurement(b"\x00\x01\x00\x00not a measurement")   # malformed bytes
        spin_until(ex, lambda: False, timeout_s=0.3)
        assert len(lis.forces["DL"]) == n_answers                # nothing to answer
    finally:
        ex.shutdown()
        ctrl.destroy_node()
        lis.node.destroy_node()
    got = [f for _, f in lis.forces["DL"]]
    np.testing.assert_allclose(got, expected, rtol=0, atol=0)
    counts = ctrl.counts
    assert {k: counts[k] for k in ("implausible", "stale", "repeated", "malformed", "future",
                                   "wrong_frame", "dropped")} == {
        "implausible": 2, "stale": 1, "repeated": 1, "malformed": 1, "future": 0,
        "wrong_frame": 0, "dropped": 0}
    assert "malformed measurement ignored" in ctrl.last_fault
    warnings = [st.message for st in lis.statuses("warn")]
    assert any("implausible measurement nan" in w and "safe output" in w for w in warnings)
    assert any("stale measurement" in w for w in warnings)


class StrayAnswers:
    """Answers on the actuator-force topics from a node that is not a controller of this plant:
    what a plant that is not discovered yet makes its controllers send."""

    def __init__(self, name: str, T: float):
        self.node = rclpy.create_node(name)
        self.T, self.k = T, 0
        self.pubs = [self.node.create_publisher(WrenchStamped, m.actuator_topic(f, "actuator_force"),
                                                m.LOCKSTEP_QOS) for f in FEET]

    def send(self, n: int = 1) -> None:
        msg = WrenchStamped()
        for _ in range(n):
            self.k += 1
            m.set_stamp(msg.header.stamp, m.sample_ns(self.k, self.T))
            for pub in self.pubs:
                pub.publish(msg)


def test_answers_to_samples_never_sent_keep_the_plant_from_starting(tmp_path):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.2)
    plant = PlantSimulator("plant_stray", parameter_overrides=params(
        scenario=sc, discovery_timeout_s=3.0))
    ctrls = [FootController(f"fc_stray_{f}", parameter_overrides=params(scenario=sc, foot_id=f))
             for f in FEET]
    stray = StrayAnswers("other_run", load_scenario(sc).sample_period_s)
    stray.node.create_timer(0.005, stray.send)          # another run keeps being answered
    ex = make_executor("events")
    for n in [plant, stray.node, *ctrls]:
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: plant.finished, timeout_s=120)
    finally:
        ex.shutdown()
        for n in [plant, stray.node, *ctrls]:
            n.destroy_node()
    assert not plant.started and plant.exit_status == EXIT_NAMESPACE_TAKEN
    refusal = plant.fault_log[-1]
    assert refusal.startswith("not starting: a plant not discovered yet") and "/other_run" in refusal


def test_a_finished_runs_answers_do_not_keep_the_plant_from_starting(tmp_path):
    """The controllers' transient-local history of an earlier run arrives once, then stops."""
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.2)
    stray = StrayAnswers("earlier_run", load_scenario(sc).sample_period_s)
    stray.send(200)
    plant = PlantSimulator("plant_after", parameter_overrides=params(scenario=sc))
    ctrls = [FootController(f"fc_after_{f}", parameter_overrides=params(scenario=sc, foot_id=f))
             for f in FEET]
    ex = make_executor("events")
    for n in [plant, stray.node, *ctrls]:
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: sum(plant.received.values()) >= 3 * 200, timeout_s=60)
        assert spin_until(ex, lambda: plant.finished, timeout_s=120)
    finally:
        ex.shutdown()
        for n in [plant, stray.node, *ctrls]:
            n.destroy_node()
    assert plant.exit_status == 0 and plant.k == plant.n_steps, plant.fault_log


@pytest.mark.parametrize("policy", ["hold", "zero"])
def test_realtime_mode_reports_loop_timing(tmp_path, policy):
    path = tmp_path / "rt.yaml"
    path.write_text(open(scenario_file(tmp_path, "foot_mount_case3", 20.0, 0.5)).read()
                    .replace("sample_rate_hz: 5000.0", "sample_rate_hz: 1000.0"))
    plant = PlantSimulator("plant_rt", parameter_overrides=params(scenario=str(path), mode="realtime",
                                                                 fault_policy=policy))
    ctrls = [FootController(f"fc_rt_{f}", parameter_overrides=params(scenario=str(path), foot_id=f))
             for f in FEET]
    lis = Listener("listener_rt")
    ex = make_executor("events")
    for n in [plant, lis.node, *ctrls]:
        ex.add_node(n)
    try:
        t0 = time.monotonic()
        assert spin_until(ex, lambda: plant.finished, timeout_s=60)
        wall = time.monotonic() - t0
        spin_until(ex, lambda: False, timeout_s=1.2)          # one more diagnostics period
    finally:
        ex.shutdown()
        for n in [plant, lis.node, *ctrls]:
            n.destroy_node()
    assert wall >= 0.45                                         # paced by the wall clock
    loop = [st for st in lis.statuses() if st.name == "plant_rt: loop"]
    values = {kv.key: kv.value for kv in loop[-1].values}
    for key in ("period_mean_s", "period_std_s", "exec_mean_s", "exec_p99_s", "exec_max_s",
                "overruns"):
        assert key in values
    assert float(values["period_mean_s"]) == pytest.approx(1e-3, rel=0.5)
    ts = plant.result()
    assert np.all(np.isfinite(ts["actuator_DL_fz"])) and np.std(ts["actuator_DL_fz"][100:]) > 0
    ctrl_diag = [st for st in lis.statuses() if st.name == "fc_rt_DL: DL"]
    assert ctrl_diag and "exec_p99_s" in {kv.key for kv in ctrl_diag[-1].values}


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("module,args", [
    ("foot_controller", ("-p", "scenario:=scenario_case3_steady", "-p", "foot_id:=DL")),
    ("plant_simulator", ("-p", "scenario:=scenario_case3_steady", "-p", "duration_s:=60.0")),
])
def test_nodes_exit_cleanly_on_signals(module, args, sig):
    name = f"{module}_{sig.name.lower()}"
    proc = node_process(module, *args, "-r", f"__node:={name}")
    assert wait_for_nodes([name], procs=[proc])                 # running (waiting for peers)
    assert proc.poll() is None
    proc.send_signal(sig)
    out, _ = proc.communicate(timeout=20)
    assert proc.returncode == 0, out
    assert "Traceback" not in out
