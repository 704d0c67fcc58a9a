"""Transfer functions from an actuator force (the model of a broadband FRF measurement), each
against a second method: the continuous one against the closed loop's state space, the sampled
one against the impulse response of the lockstep loop itself (plant stepper + controller blocks).
"""
import numpy as np
import pytest

from rotor_avc.closed_loop.loop import ClosedLoop
from rotor_avc.analysis.sampled_loop import machine_sampled_loop
from rotor_avc.analysis.transfer import sampled_transfer_frf, transfer_frf
from rotor_avc.config import find_config, load_yaml
from rotor_avc.control.block import build_digital_controllers
from rotor_avc.errors import ModelError
from rotor_avc.machine import load_machine, machine_from_config
from rotor_avc.sim.loop import control_plan, controller_forces, start
from rotor_avc.sim.propagator import DampingRule
from rotor_avc.sim.speed_profile import constant_speed
from rotor_avc.sim.stepper import PlantStepper

OUTPUTS = ["bearing_D_vz", "bearing_N_vy", "foundation_DL_vz", "foot_DL_az", "foot_NL_az",
           "foot_DR_dz", "actuator_DL_fz", "actuator_NL_fz", "actuator_NR_fz"]


def machine_with(controllers: dict):
    data = load_yaml(find_config("foot_mount_case3"))
    data["controllers"] = controllers
    return machine_from_config(data, "test")


@pytest.mark.parametrize("controllers", [
    None,                                                             # case 3 as configured
    {"DL": {"type": "I", "feedback": "displacement", "ki": 2.0e7},    # a controller with states
     "NL": {"type": "PD", "feedback": "velocity", "kp": 5.0e4, "kd": 20.0}},
])
def test_continuous_transfer_equals_the_state_space_closed_loop(controllers):
    machine = load_machine("foot_mount_case3") if controllers is None else machine_with(controllers)
    loop, plant = machine.loop, machine.plant
    speed, w_F = 2 * np.pi * 35.0, 2 * np.pi * 35.0
    f = np.array([3.0, 18.0, 61.0, 104.0, 230.0])
    got = transfer_frf(loop, speed, f, "DR", OUTPUTS[:6], w_F)
    A, B = loop.state_space(speed, w_F)
    n = plant.n
    p_in = plant.actuator("DR").force_vector
    for k, fk in enumerate(f):
        s = 2j * np.pi * fk
        x = np.linalg.solve(s * np.eye(A.shape[0]) - A, B @ p_in)
        q, v = x[:n], x[n:2 * n]
        expect = {"bearing_D_vz": plant.output("bearing_D_vz").row @ v,
                  "bearing_N_vy": plant.output("bearing_N_vy").row @ v,
                  "foundation_DL_vz": plant.output("foundation_DL_vz").row @ v,
                  "foot_DL_az": s * plant.actuator("DL").sensor_row @ v,
                  "foot_NL_az": s * plant.actuator("NL").sensor_row @ v,
                  "foot_DR_dz": plant.actuator("DR").sensor_row @ q}
        for name, value in expect.items():
            assert got.responses[name][k] == pytest.approx(value, rel=1e-9, abs=1e-18)
    assert got.units["foot_DL_az"] == "m/s^2/N" and got.model == "continuous"


def test_sampled_transfer_equals_the_lockstep_impulse_response():
    """Force impulse d_0 = 1 N at DL through the stepper and the digital controllers; the DTFT
    of every recorded sequence is the sampled transfer (a settled constant -- the integrators'
    held force -- summed in closed form)."""
    machine = load_machine("foot_mount_case3")
    T, speed = 1 / 5000, 2 * np.pi * 20.0
    damping = DampingRule("whirl", 15.0)       # a short impulse response (w_F frozen, low)
    w_F = 15.0
    stepper = PlantStepper(machine.plant, T, constant_speed(speed), {}, damping)
    ctrls = build_digital_controllers(machine, T)
    plan = control_plan(stepper, ctrls)
    y = start(stepper, ctrls)
    n = 30000
    lay = stepper.layout
    rows = {name: lay.index(name) for name in ("bearing_D_vz", "foot_DL_az", "foot_NL_az")}
    Y = np.empty((n, len(rows) + 2))
    u = np.zeros(stepper.n_inputs)
    i_dl = [a.id for a in machine.plant.actuators].index("DL")
    i_nl = [a.id for a in machine.plant.actuators].index("NL")
    for k in range(n):
        controller_forces(plan, y, u)
        Y[k] = [y[i] for i in rows.values()] + [u[i_dl], u[i_nl]]
        applied = u.copy()
        applied[i_dl] += 1.0 if k == 0 else 0.0
        y = stepper.step(applied)
    names = list(rows) + ["actuator_DL_fz", "actuator_NL_fz"]
    assert np.all(np.abs(Y[-200:] - Y[-1]) <= 1e-9 * np.abs(Y).max(axis=0))    # settled
    f = np.array([2.0, 9.5, 40.0, 104.0, 400.0, 1700.0])
    model = sampled_transfer_frf(machine_sampled_loop(machine, T), speed, f, "DL", names, w_F)
    z_inv = np.exp(-2j * np.pi * f * T)
    powers = z_inv[:, None] ** np.arange(n)
    for j, name in enumerate(names):
        c = Y[-1, j]
        dtft = powers @ (Y[:, j] - c) + c / (1 - z_inv)
        np.testing.assert_allclose(model.responses[name], dtft, rtol=1e-7,
                                   atol=1e-9 * np.abs(dtft).max(), err_msg=name)
    zero = sampled_transfer_frf(machine_sampled_loop(machine, T), speed, f, "DL",
                                ["actuator_NR_fz"], w_F)
    assert not np.any(zero.responses["actuator_NR_fz"])


def test_sampled_transfer_approaches_the_continuous_one():
    """T -> 0: the sampled transfer tends to the continuous one times the hold's half-sample lag,
    with an error shrinking about tenfold per tenfold rate."""
    machine = load_machine("foot_mount_case3")
    f = np.linspace(5.0, 300.0, 60)
    speed = 2 * np.pi * 30.0
    cont = transfer_frf(machine.loop, speed, f, "NL", ["bearing_N_vz", "actuator_NL_fz"])
    errors = []
    for fs in (5000.0, 50000.0):
        samp = sampled_transfer_frf(machine_sampled_loop(machine, 1 / fs), speed, f, "NL",
                                    ["bearing_N_vz", "actuator_NL_fz"])
        lag = np.exp(-1j * np.pi * f / fs)
        errors.append(max(np.max(np.abs(samp.responses[k] - cont.responses[k] * lag))
                          / np.max(np.abs(cont.responses[k])) for k in cont.responses))
    assert errors[0] < 0.05 and 5 < errors[0] / errors[1] < 20


def test_bad_requests_name_the_problem():
    machine = load_machine("foot_mount_case3")
    with pytest.raises(ModelError, match="no actuator 'XX'"):
        transfer_frf(machine.loop, 10.0, [5.0], "XX")
    with pytest.raises(ModelError, match="no quantity 'bearing_Q_vz'"):
        transfer_frf(machine.loop, 10.0, [5.0], "DL", ["bearing_Q_vz"])
    with pytest.raises(ModelError, match="below the Nyquist frequency 500"):
        sampled_transfer_frf(machine_sampled_loop(machine, 1e-3), 10.0, [600.0], "DL")
    with pytest.raises(ModelError, match="finite values >= 0"):
        transfer_frf(ClosedLoop(machine.plant), 10.0, [-1.0], "DL")
