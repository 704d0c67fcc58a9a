"""The harmonic controller node's commission mode in the lockstep graph (plant, node and a
listener in one executor), on the machine of test_harmonic_commission.py: the Werner 2021 open
feet with actuators 1.5 x stiffer than the controller's model, at 50 Hz. The node identifies the
table that ``rotor-avc harmonic commission`` identifies in-process, bit for bit (the same
commission.json and table), then adapts with it: the whole run equals the in-process loop with
the same block bit for bit, and the 1x falls. With the margin asked above what the loop has, it
refuses: the same identification, no commissioned.yaml, zero force after the fade-out, mode 6 on
harmonic/status and ERROR with the reason on /diagnostics. A test level above a limit is refused
before any topic exists."""
import json

import numpy as np
import pytest
import yaml

from ros_helpers import make_executor, params, rclpy, spin_until  # noqa: F401
from test_ros_graph import ros  # noqa: F401  (the module's rclpy context)

from rotor_avc.analysis.order_tracking import phasor
from rotor_avc.cli import main
from rotor_avc.config import find_config
from rotor_avc.errors import ConfigError
from rotor_avc.machine import load_machine
from rotor_avc.nodes import messages as m
from rotor_avc.nodes.harmonic_controller import HarmonicControllerNode
from rotor_avc.nodes.plant_simulator import PlantSimulator
from rotor_avc.reports.commission_files import live_commissioning
from rotor_avc.scenario import load_scenario
from rotor_avc.sim.loop import run_loop

pytestmark = pytest.mark.ros
NOMINAL = "scenario_harmonic_case2_steady"
ACTUATORS = ("DL", "DR", "NL")
SPEED_HZ = 50.0
FS = 5000.0
#: a short test: 4 steps of 2 + 10 + 4 revolutions, then 2 revolutions of fade-out (1.32 s)
SHORT = "{ramp_revolutions: 2, settle_revolutions: 10, measure_revolutions: 4}"
COMMISSIONED_S = (4 * 16 + 2) / SPEED_HZ


def machine(folder, duration_s: float, harmonic: str = "") -> str:
    """The true machine (stiffer actuators) at 50 Hz, harmonic control on from the switch."""
    path = folder / "machine.yaml"
    path.write_text(f"include: [{find_config(NOMINAL)}]\n"
                    "elements: {actuator: {stiffness_n_per_m: {z: 1.575e+7}}}\n"
                    "harmonic: {start_s: 0.0, min_speed_hz: 40.0, commission: "
                    f"{{{SHORT[1:-1]}, max_added_vibration: 1.0{harmonic}}}}}\n"
                    f"simulation: {{speed: {{type: constant, speed_hz: {SPEED_HZ}}}, "
                    f"duration_s: {duration_s}}}\n")
    return str(path)


def commission_graph(scenario: str, out):
    """Plant and commissioning node in lockstep to the end; (plant, node, harmonic/status
    data arrays)."""
    plant = PlantSimulator("plant_commission", parameter_overrides=params(scenario=scenario,
                                                                          harmonic=True))
    node = HarmonicControllerNode("harmonic_controller", parameter_overrides=params(
        scenario=scenario, commission=True, commission_out=str(out), model=NOMINAL))
    listener = rclpy.create_node("commission_listener")
    status = []
    listener.create_subscription(m.Float64MultiArray, m.topic("harmonic/status", m.NAMESPACE),
                                 lambda msg: status.append(list(msg.data)), m.LOCKSTEP_QOS)
    ex = make_executor("events")
    for n in (plant, node, listener):
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: plant.finished and len(status) == node.block.n_updates,
                          timeout_s=300)
    finally:
        ex.shutdown()
        for n in (listener, plant):
            n.destroy_node()
    return plant, node, np.array(status)


def one_x(ts, channel: str) -> np.ndarray:
    """1x magnitude per revolution of one channel."""
    P = int(round(FS / SPEED_HZ))
    y = ts[channel]
    return np.array([abs(phasor(ts.angle_rad[i:i + P], y[i:i + P]))
                     for i in range(0, len(y) - P + 1, P)])


def test_node_commissions_like_the_command_then_adapts(tmp_path):
    scenario = machine(tmp_path, 1.8)
    assert main(["harmonic", "commission", scenario, "--model", NOMINAL, "--out",
                 str(tmp_path / "command")]) == 0
    plant, node, status = commission_graph(scenario, tmp_path / "node")
    try:
        # the same identification, margin and levels as the in-process command, bit for bit
        command = json.loads((tmp_path / "command" / "commission.json").read_text())
        graph = json.loads((tmp_path / "node" / "commission.json").read_text())
        assert graph == command and graph["accepted"]
        tables = [yaml.safe_load((tmp_path / d / "commissioned.yaml").read_text())
                  ["harmonic"]["influence"]["table"] for d in ("command", "node")]
        assert tables[0] == tables[1] and len(tables[0]) == 2 * 3
        # the run: bit for bit the in-process loop with the same block, which adapts at the end
        sc = load_scenario(scenario)
        block = live_commissioning(sc, tmp_path / "in_process", load_machine(NOMINAL))
        ref = run_loop(sc.stepper(), sc.controllers(), plant.n_steps, harmonic=block,
                       initial_state=sc.initial_state, progress=False)
        ts = plant.result()
        for ch, values in ref.channels.items():
            assert np.array_equal(ts[ch], values), ch
        assert node.block.mode == block.mode == "adapting" and not plant.fault_log
        level, text, values = node.status()
        assert level == "ok" and values["commission_phase_margin_deg"] == pytest.approx(
            graph["speeds"][0]["phase_margin_deg"])
    finally:
        node.destroy_node()
    # harmonic/status: mode 5 per test revolution, each actuator's test phasor alone at 100 N
    # (U1_DL, U1_DR, U1_NL after E1 of both sensors), then the controller's mode 1 (adapting)
    modes = status[:, 1]
    testing = status[modes == 5]
    assert len(testing) == 4 * 16 and set(modes[len(testing):]) == {1.0}
    U = testing[:, 5:8]
    for j in range(3):
        alone = np.zeros(3)
        alone[j] = 100.0
        assert np.any(np.all(U == alone, axis=1)), ACTUATORS[j]
    # the 1x of both housings after 0.48 s of adapting (the last five revolutions) more than
    # 12 dB below the first revolution's (measured: -29 and -19 dB)
    for ch in ("bearing_D_vz", "bearing_N_vz"):
        amp = one_x(ts, ch)
        assert amp[-5:].mean() < 0.25 * amp[0], (ch, amp.round(7))


def test_node_refuses_a_margin_below_the_minimum(tmp_path):
    scenario = machine(tmp_path, 1.4, ", min_phase_margin_deg: 80.0")
    plant, node, status = commission_graph(scenario, tmp_path / "node")
    try:
        doc = json.loads((tmp_path / "node" / "commission.json").read_text())
        level, text, _ = node.status()
    finally:
        node.destroy_node()
    margin = doc["speeds"][0]["phase_margin_deg"]
    assert not doc["accepted"] and margin < 80.0
    assert f"phase margin {margin:.1f} deg" in doc["refusal"]
    assert "harmonic.commission.min_phase_margin_deg 80 deg" in doc["refusal"]
    assert not (tmp_path / "node" / "commissioned.yaml").exists()
    assert level == "error" and doc["refusal"] in text
    assert status[-1, 1] == 6 and set(status[:-1, 1]) == {5.0}
    ts = plant.result()
    end = int(round(COMMISSIONED_S * FS)) + 2           # after the last test's fade-out
    for a in ACTUATORS:
        forces = ts[f"actuator_{a}_fz"]
        assert np.all(forces[end:] == 0.0) and np.abs(forces[:end]).max() > 50.0


def test_node_refuses_a_test_level_above_the_limit_before_any_topic(tmp_path):
    scenario = machine(tmp_path, 1.0)
    path = tmp_path / "limited.yaml"
    path.write_text(f"include: [{scenario}]\nharmonic: {{force_limit_n: 50.0}}\n")
    with pytest.raises(ConfigError, match=r"harmonic\.commission\.test_force_n.*force_limit_n "
                                          r"50 N"):
        HarmonicControllerNode("harmonic_controller_limited", parameter_overrides=params(
            scenario=str(path), commission=True, commission_out=str(tmp_path / "out")))
    assert not (tmp_path / "out").exists()
