"""Launch-free integration tests of the ROS graph: plant, foot controllers and balancer in rclpy
executors (one process) and as separate processes over DDS on loopback. The lockstep graph must
reproduce the in-process loop (rotor_avc.sim.loop) exactly."""
import math

import numpy as np
import pytest

from ros_helpers import make_executor, node_process, params, rclpy, spin_until, stop  # noqa: F401

from rotor_avc.analysis.order_tracking import phasor
from rotor_avc.analysis.sampled_loop import machine_sampled_loop
from rotor_avc.nodes.foot_controller import FootController
from rotor_avc.nodes.plant_simulator import PlantSimulator
from rotor_avc.sim.loop import run_loop
from rotor_avc.scenario import load_scenario

pytestmark = pytest.mark.ros
FEET = ("DL", "DR", "NL")


@pytest.fixture(scope="module", autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


def scenario_file(tmp_path, machine: str, speed_hz: float, duration_s: float = 0.2,
                  initial: str = "steady_state") -> str:
    path = tmp_path / f"{machine}_{speed_hz:g}.yaml"
    path.write_text(f"""include: {machine}.yaml
simulation:
  sample_rate_hz: 5000.0
  duration_s: {duration_s}
  speed: {{type: constant, speed_hz: {speed_hz}}}
  unbalance:
    static: {{magnitude: 1.0e-2, phase_deg: 0.0}}
    moment: {{magnitude: 2.0e-3, phase_deg: 90.0}}
  initial_state: {initial}
""")
    from rotor_avc.config import find_config
    # include relative to the shipped config folder
    path.write_text(path.read_text().replace(f"include: {machine}.yaml",
                                             f"include: {find_config(machine)}"))
    return str(path)


def run_graph(scenario: str, executor_kind: str = "events", controllers=FEET, **plant_params):
    """All nodes in one executor in this process; returns the plant node after the run."""
    plant = PlantSimulator(f"plant_{executor_kind}", parameter_overrides=params(
        scenario=scenario, executor=executor_kind, **plant_params))
    ctrls = [FootController(f"foot_controller_{f}", parameter_overrides=params(
        scenario=scenario, foot_id=f)) for f in controllers]
    return run_to_end(plant, ctrls, executor_kind)


def run_to_end(plant, others, executor_kind: str = "events", timeout_s: float = 180.0):
    """Spin the plant and the other nodes in one executor until the run is complete."""
    ex = make_executor(executor_kind)
    for n in [plant, *others]:
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: plant.finished, timeout_s=timeout_s)
    finally:
        ex.shutdown()
        for n in [*others, plant]:
            n.destroy_node()
    return plant


def in_process(scenario: str, n_steps: int):
    sc = load_scenario(scenario)
    return run_loop(sc.stepper(), sc.controllers(), n_steps, initial_state=sc.initial_state,
                    progress=False)


@pytest.mark.parametrize("executor_kind", ["events", "single_threaded"])
def test_one_process_graph_equals_in_process_loop(tmp_path, executor_kind):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.1)
    plant = run_graph(sc, executor_kind)
    ts = plant.result()
    ref = in_process(sc, plant.n_steps)
    assert len(ts) == len(ref) == 500
    for foot in FEET:
        for ch in (f"foot_{foot}_az", f"actuator_{foot}_fz"):
            scale = np.max(np.abs(ref[ch]))
            assert np.max(np.abs(ts[ch] - ref[ch])) <= 1e-9 * scale, ch
    np.testing.assert_allclose(ts["bearing_D_vz"], ref["bearing_D_vz"], rtol=0, atol=1e-15)
    assert not plant.fault_log and plant.book.resends == 0


def test_control_lowers_resonance_by_the_analytical_margin(tmp_path):
    """At the 9.4 Hz machine resonance the closed loop (ROS graph) lowers the bearing-housing
    vibration below case 2 by the margin the sampled-loop model predicts."""
    f = 9.39
    closed = run_graph(scenario_file(tmp_path, "foot_mount_case3", f, 0.6)).result()
    opened = run_graph(scenario_file(tmp_path, "foot_mount_case2", f, 0.6), controllers=()).result()
    measured = {}
    for name, ts in (("closed", closed), ("open", opened)):
        revs = np.floor(ts.angle_rad[-1] / (2 * math.pi))
        n = int(np.searchsorted(ts.angle_rad, 2 * math.pi * revs))     # whole revolutions
        measured[name] = abs(phasor(ts.angle_rad[:n], ts["bearing_D_vz"][:n]))
    ratio = measured["closed"] / measured["open"]
    w = 2 * math.pi * f
    model = {}
    for case in ("foot_mount_case3", "foot_mount_case2"):
        sc = load_scenario(scenario_file(tmp_path, case, f))
        frf = machine_sampled_loop(sc.machine, sc.sample_period_s).unbalance_frf([w])
        u = sc.amplitudes
        model[case] = abs(frf.responses["bearing_D_vz_static"][0] * u["static"]
                          + frf.responses["bearing_D_vz_moment"][0] * u["moment"])
    expected = model["foot_mount_case3"] / model["foot_mount_case2"]
    assert ratio < 0.5                                      # a real reduction (> 6 dB)
    assert 20 * math.log10(ratio) == pytest.approx(20 * math.log10(expected), abs=0.05)


def test_graph_as_separate_processes(tmp_path):
    """Plant in one process, each controller in its own, over DDS on loopback: same result."""
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.1)
    out = tmp_path / "plant.npz"
    procs = [node_process("foot_controller", "-r", f"__node:=foot_controller_{f}",
                          "-p", f"scenario:={sc}", "-p", f"foot_id:={f}") for f in FEET]
    plant = node_process("plant_simulator", "-p", f"scenario:={sc}", "-p", f"result_path:={out}")
    try:
        plant_out, _ = plant.communicate(timeout=180)
    finally:
        logs = [stop(p) for p in procs]
    assert plant.returncode == 0, plant_out
    from rotor_avc.sim.timeseries import TimeSeries
    ts = TimeSeries.load(out)
    ref = in_process(sc, len(ts))
    for foot in FEET:
        for ch in (f"foot_{foot}_az", f"actuator_{foot}_fz"):
            assert np.max(np.abs(ts[ch] - ref[ch])) <= 1e-9 * np.max(np.abs(ref[ch])), ch
    assert all("Traceback" not in log for log in logs), logs


def test_parameters_are_declared_described_and_checked():
    from rotor_avc.nodes.runtime import ParameterError
    with pytest.raises(ParameterError, match="mode.*unknown value 'fast'"):
        PlantSimulator("p_bad", parameter_overrides=params(scenario="scenario_case3_steady",
                                                           mode="fast"))
    with pytest.raises(ParameterError, match="controller_timeout_s"):
        PlantSimulator("p_bad2", parameter_overrides=params(scenario="scenario_case3_steady",
                                                            controller_timeout_s=-1.0))
    with pytest.raises(Exception, match="foot_id 'NR' has no controller.*DL, DR, NL"):
        FootController("c_bad", parameter_overrides=params(scenario="scenario_case3_steady",
                                                           foot_id="NR"))
    node = PlantSimulator("p_desc", parameter_overrides=params(scenario="scenario_case3_steady"))
    try:
        for name in ("scenario", "mode", "fault_policy", "controller_timeout_s", "executor"):
            desc = node.describe_parameters([name])[0]
            assert len(desc.description) > 15, name
        assert node.describe_parameters(["controller_timeout_s"])[0].floating_point_range
    finally:
        node.destroy_node()


def test_bad_parameter_exits_with_clear_message():
    proc = node_process("plant_simulator", "-p", "scenario:=no_such_scenario")
    out = stop(proc, timeout_s=60) if proc.wait(timeout=60) is None else proc.stdout.read()
    assert proc.returncode == 2
    assert "no_such_scenario" in out and "Traceback" not in out


def test_balancer_node_in_lockstep_equals_in_process(tmp_path):
    """Plant (waiting for the balancer) + balancer node: the corrections and the vibration equal
    the in-process loop with the same balancer block."""
    from rotor_avc.config import find_config
    from rotor_avc.nodes.balancer import Balancer
    path = tmp_path / "balance.yaml"
    path.write_text(f"""include: {find_config('scenario_balance_runup')}
balancer:
  supervisor: {{estimate_until_s: 0.2}}
simulation:
  speed: {{type: ramp, start_hz: 6.0, stop_hz: 8.0, duration_s: 1.0}}
  duration_s: 0.6
""")
    plant = PlantSimulator("plant_bal", parameter_overrides=params(scenario=str(path), balancer=True))
    bal = Balancer("balancer", parameter_overrides=params(scenario=str(path)))
    run_to_end(plant, [bal])
    ts = plant.result()
    sc = load_scenario(str(path))
    ref = run_loop(sc.stepper(), {}, plant.n_steps, balancer=sc.balancer(), progress=False)
    for ch in ("balancer_static_re", "balancer_static_im", "balancer_moment_re", "bearing_D_vz"):
        scale = np.max(np.abs(ref[ch]))
        assert scale > 0, ch
        assert np.max(np.abs(ts[ch] - ref[ch])) <= 1e-9 * scale, ch
    assert bal.block.last_output.mode != "estimate"          # it moved during the run


@pytest.mark.parametrize("scenario", ["scenario_sleeve_velocity", "scenario_stability_demo"])
def test_other_machines_run_in_the_graph(scenario):
    """Werner 2019 (oil films, velocity feedback at feet L, R) and Werner 2017 (soft foundation, damping
    frozen at the whirl frequency) through the same nodes: equal to the in-process loop."""
    sc = load_scenario(scenario)
    feet = tuple(sc.machine.controllers)
    assert feet == ("L", "R")
    plant = run_graph(scenario, controllers=feet, duration_s=0.2)
    ts = plant.result()
    ref = in_process(scenario, plant.n_steps)
    for ch, values in ref.channels.items():
        scale = np.max(np.abs(values))
        assert np.max(np.abs(ts[ch] - values)) <= 1e-9 * max(scale, 1e-300), ch
    assert np.max(np.abs(ref["actuator_L_fz"])) > 0


def test_feedforward_node_in_lockstep_equals_in_process():
    """Sci. Rep. 2023: the plant waits for the synchronous_controller's 1x forces (actuators y1, x1,
    y2, x2 in the bearing housings); equal to the in-process loop with the same generator."""
    from rotor_avc.nodes.synchronous_controller import SynchronousController
    scenario = "scenario_active_bearing"
    plant = PlantSimulator("plant_ff", parameter_overrides=params(scenario=scenario,
                                                                  duration_s=0.05))
    ff = SynchronousController("synchronous_controller", parameter_overrides=params(
        scenario=scenario))
    run_to_end(plant, [ff])
    ts = plant.result()
    sc = load_scenario(scenario)
    ref = run_loop(sc.stepper(), {}, plant.n_steps, feedforward=sc.feedforward(), progress=False)
    for ch, values in ref.channels.items():
        scale = np.max(np.abs(values))
        assert np.max(np.abs(ts[ch] - values)) <= 1e-9 * max(scale, 1e-300), ch
    assert np.max(np.abs(ref["actuator_x2_fx"])) > 0 and not plant.fault_log


TWO_X = ("harmonics: [1, 2], runout: [{sensor: bearing_D_vz, order: 2, magnitude: 2.0e-4, "
         "phase_deg: 30.0}, {sensor: bearing_N_vz, order: 2, magnitude: 1.0e-4}]")


DYNAMIC = "adapt_in: excitations, refresh_samples: 25, feedforward: dynamic"


@pytest.mark.parametrize("machine, extra", [("foot_mount_case2", ""), ("foot_mount_case3", ""),
                                            ("foot_mount_case2", TWO_X),
                                            ("foot_mount_case3", DYNAMIC)])
def test_harmonic_node_in_lockstep_equals_in_process(tmp_path, machine, extra):
    """The harmonic_controller node (bearing-housing 1x, 50 Hz, updates every revolution from
    the start) alone (case 2), beside the foot controllers (case 3), with the 2x as well
    against a 2x sensor runout (case 2), and with the dynamic feed-forward beside the foot
    controllers (case 3): bit for bit the in-process loop with the same block."""
    from rotor_avc.config import find_config
    from rotor_avc.nodes.harmonic_controller import HarmonicControllerNode
    path = tmp_path / f"harmonic_{machine}.yaml"
    path.write_text(f"""include: [{find_config(machine)}, {find_config('harmonic_bearings')}]
harmonic: {{min_speed_hz: 40.0{', ' + extra if extra else ''}}}
simulation:
  sample_rate_hz: 5000.0
  duration_s: 0.2
  speed: {{type: constant, speed_hz: 50.0}}
  unbalance: {{static: {{magnitude: 1.0e-2, phase_deg: 0.0}}}}
  initial_state: steady_state
  harmonic: true
""")
    scenario = str(path)
    sc = load_scenario(scenario)
    feet = tuple(sc.machine.controllers)
    plant = PlantSimulator("plant_h", parameter_overrides=params(scenario=scenario, harmonic=True))
    nodes = [HarmonicControllerNode("harmonic_controller", parameter_overrides=params(
        scenario=scenario))] + [FootController(f"foot_controller_{f}", parameter_overrides=params(
            scenario=scenario, foot_id=f)) for f in feet]
    run_to_end(plant, nodes)
    ts = plant.result()
    block = sc.harmonic()
    ref = run_loop(sc.stepper(), sc.controllers(), plant.n_steps, harmonic=block,
                   initial_state=sc.initial_state, progress=False)
    for ch, values in ref.channels.items():
        assert np.array_equal(ts[ch], values), ch
    assert block.n_updates >= 9 and np.max(np.abs(ref["actuator_DL_fz"])) > 0
    assert np.all(np.abs(block.U) > 0) and len(block.harmonics) == (2 if extra == TWO_X else 1)
    assert not plant.fault_log
