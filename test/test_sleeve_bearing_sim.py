"""Werner 2019 in time: the in-process lockstep loop with velocity feedback against the analytical
models, and the sample-rate limits of the gains in a digital loop (Werner 2019 Sec. 8)."""
import copy
import math

import numpy as np
import pytest

from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.analysis.sampled_loop import SampledLoop, machine_sampled_loop
from rotor_avc.config import Section, load_config
from rotor_avc.control.block import build_digital_controllers
from rotor_avc.machine import Machine, build_controllers, build_plant, load_machine
from rotor_avc.sim.loop import run_loop
from rotor_avc.sim.speed_profile import constant_speed
from rotor_avc.sim.stepper import PlantStepper

AMP = {"bent_rotor": 10e-6 * np.exp(0.3j),           # 10 um bend
       "magnetic_eccentricity": 20e-6 * np.exp(-1.1j),  # speed-dependent pull (speed_factor)
       "mass_eccentricity": 5e-6}
QUANTITIES = ("bearing_vz", "bearing_vy", "foundation_L_vz", "foundation_R_vy", "actuator_L_fz")


def response(frf, quantity):
    return sum(frf.responses[f"{quantity}_{e}"][0] * a for e, a in AMP.items())


def fit(ts, name, t0=0.0):
    """Least-squares 1x phasor of a channel from ``t0`` on."""
    mask = ts.time_s >= t0
    th, y = ts.angle_rad[mask], ts[name][mask]
    basis = np.column_stack([np.ones_like(th), np.cos(th), np.sin(th)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    return coef[1] - 1j * coef[2]


@pytest.fixture(scope="module")
def machine():
    return load_machine("sleeve_bearing_motor_velocity")


def run(machine, rpm, fs, seconds, initial_state):
    speed = rpm * math.pi / 30
    stepper = PlantStepper(machine.plant, 1 / fs, constant_speed(speed), AMP)
    ctrls = build_digital_controllers(machine, 1 / fs)
    return run_loop(stepper, ctrls, int(fs * seconds), initial_state=initial_state), ctrls


@pytest.mark.parametrize("rpm", [1140.0, 2390.0])
def test_loop_1x_response_converges_to_the_continuous_model(machine, rpm):
    """Velocity feedback 1e6 N s/m at the housing resonances, all three excitations: the
    simulated 1x response equals the sampled-loop model (same sampling contract, independent
    assembly) to rounding and the continuous closed-loop FRF to O(T): within 0.5 % at 50 kHz,
    5x closer than at 10 kHz."""
    speed = rpm * math.pi / 30
    cont = unbalance_frf(machine.loop, [speed])
    worst = {}
    for fs in (10000.0, 50000.0):
        ts, ctrls = run(machine, rpm, fs, 0.1, "steady_state")
        model = SampledLoop.from_blocks(machine.plant, ctrls).unbalance_frf([speed])
        dev = []
        for q in QUANTITIES:
            got = fit(ts, q)
            assert got == pytest.approx(response(model, q), rel=1e-8)
            dev.append(abs(got / response(cont, q) - 1))
        worst[fs] = max(dev)
    assert worst[50000.0] < 5e-3
    assert worst[50000.0] < 0.3 * worst[10000.0]


def test_start_from_rest_settles_on_the_analytical_response(machine):
    rpm, fs = 1140.0, 5000.0
    ts, ctrls = run(machine, rpm, fs, 1.5, "rest")
    speed = rpm * math.pi / 30
    model = SampledLoop.from_blocks(machine.plant, ctrls).unbalance_frf([speed])
    for q in QUANTITIES:
        assert abs(fit(ts, q, t0=1.0) / response(model, q) - 1) < 1e-6, q
    assert abs(fit(ts, "bearing_vz", t0=0.0) / response(model, "bearing_vz") - 1) > 1e-3


def test_acceleration_feedthrough(machine):
    """Digest 8: foot-acceleration feed-through T M^-1 P_az = 3.23e-4 1/kg (own foot) and
    -3.9e-5 1/kg (other foot)."""
    p = machine.plant
    M_inv = np.linalg.inv(p.mass)
    s_L, s_R = p.actuator("L").sensor_row, p.actuator("R").sensor_row
    assert s_L @ M_inv @ p.actuator("L").force_vector == pytest.approx(3.23e-4, rel=0.005)
    assert s_L @ M_inv @ p.actuator("R").force_vector == pytest.approx(-3.9e-5, rel=0.01)
    assert s_R @ M_inv @ p.actuator("R").force_vector == pytest.approx(3.23e-4, rel=0.005)


def digital_machine(law: dict, fs: float, delay: int = 0) -> Machine:
    cfg = load_config("sleeve_bearing_motor")
    data = copy.deepcopy(cfg.data)
    data["controllers"] = {side: dict(law, delay_samples=delay) for side in ("L", "R")}
    data["control"] = {"sample_rate_hz": fs, "method": "tustin"}
    cfg = Section(data, "", cfg.source)
    plant = build_plant(cfg)
    return Machine(cfg, plant, build_controllers(cfg, plant))


def upper_gain(law, nominal, fs, delay=0):
    speed = 3600 * math.pi / 30                     # digest 8: n = 3600 rpm, w_F = Omega
    return nominal * machine_sampled_loop(digital_machine(law, fs, delay)).stable_gain_range(
        speed, speed).upper


@pytest.mark.parametrize("delay", [0, 1])
def test_acceleration_gain_limit_of_a_digital_loop(machine, delay):
    """Digest 8: with the feed-through, a sampled loop on the measured acceleration diverges once
    K rho(T M^-1 P) > 1 (about 2.77 t) however fast it samples -- far below the paper's 1e4 kg."""
    p = machine.plant
    F = np.array([[a.sensor_row @ np.linalg.solve(p.mass, b.force_vector) for b in p.actuators]
                  for a in p.actuators])
    bound = 1 / np.abs(np.linalg.eigvals(F)).max()
    law = {"type": "P", "feedback": "acceleration", "kp": 1e4}
    assert upper_gain(law, 1e4, 20000.0, delay) == pytest.approx(bound, rel=0.02)
    assert bound == pytest.approx(2.77e3, rel=0.01)


def test_velocity_and_displacement_gain_limits():
    """Digest 8 (Tustin filters on the measured acceleration): velocity feedback is stable over
    the paper's whole range (1e6 N s/m) at 1, 5 and 20 kHz; displacement feedback (leaky double
    integrator) is limited far below the paper's 1e9 N/m at 1 kHz, and the limit rises with the
    sample rate."""
    vel = {"type": "tf", "feedback": "acceleration", "num": [1e6], "den": [1.0, 0.0]}
    for fs in (1000.0, 5000.0, 20000.0):
        assert upper_gain(vel, 1e6, fs) > 1e6
    a = 2 * math.pi * 0.5
    disp = {"type": "tf", "feedback": "acceleration", "num": [1e9], "den": [1.0, 2 * a, a * a]}
    limits = [upper_gain(disp, 1e9, fs, delay=1) for fs in (1000.0, 5000.0, 20000.0)]
    assert limits[0] < 1e8 and np.all(np.diff(limits) > 0)
