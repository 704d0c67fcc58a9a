"""The broadband test force in the ROS graph: the plant node steps the same PlantStepper, so a
lockstep run with `simulation.test_signal` reproduces the in-process loop sample by sample."""
import numpy as np
import pytest

from ros_helpers import make_executor, params, rclpy, spin_until  # noqa: F401
from test_ros_graph import FEET, ros  # noqa: F401  (the module's rclpy context)

from rotor_avc.config import find_config
from rotor_avc.nodes.foot_controller import FootController
from rotor_avc.nodes.plant_simulator import PlantSimulator
from rotor_avc.scenario import load_scenario

pytestmark = pytest.mark.ros


def test_lockstep_graph_applies_the_test_force_like_the_in_process_loop(tmp_path):
    path = tmp_path / "case3_test_force.yaml"
    path.write_text(f"""include: {find_config("foot_mount_case3")}
simulation:
  sample_rate_hz: 5000.0
  duration_s: 0.1
  speed: {{type: constant, speed_hz: 20.0}}
  unbalance: {{static: {{magnitude: 1.0e-2, phase_deg: 0.0}}}}
  initial_state: steady_state
  test_signal: {{actuator: DL, kind: white, rms_n: 200.0, band_hz: [2.0, 400.0], seed: 3}}
""")
    plant = PlantSimulator("plant_test_force", parameter_overrides=params(scenario=str(path)))
    ctrls = [FootController(f"foot_controller_{f}", parameter_overrides=params(
        scenario=str(path), foot_id=f)) for f in FEET]
    ex = make_executor("events")
    for node in [plant, *ctrls]:
        ex.add_node(node)
    try:
        assert spin_until(ex, lambda: plant.finished, timeout_s=120)
    finally:
        ex.shutdown()
        for node in [*ctrls, plant]:
            node.destroy_node()
    graph = plant.result()
    ref = load_scenario(path).run(progress=False)
    assert len(graph) == len(ref) == 500
    np.testing.assert_array_equal(graph["test_signal_DL_fz"], ref["test_signal_DL_fz"])
    assert np.std(ref["test_signal_DL_fz"]) > 100.0
    for ch in ("foot_DL_az", "foot_NL_az", "actuator_DL_fz", "bearing_D_vz"):
        scale = np.max(np.abs(ref[ch]))
        assert np.max(np.abs(graph[ch] - ref[ch])) <= 1e-9 * scale, ch
