"""The time simulator against the Werner 2017 eigen-analysis: on the very soft
demo foundation (threshold ~4426 rpm, whirl ~386.8 rad/s) a tiny disturbance decays below the
threshold and grows above it at the rate of the critical eigenvalue's real part, with the
loss-factor damping frozen at the converged whirl frequency (DESIGN.md 2) -- open loop, and with
the digital foot velocity feedback of the lockstep loop against the sampled-loop analysis."""
import numpy as np
import pytest

from rotor_avc.analysis.stability_study import (machine_threshold, stability_loop,
                                                threshold_settings, with_variants)
from rotor_avc.analysis.stability_threshold import eigen_source
from rotor_avc.config import load_config
from rotor_avc.control.block import build_digital_controllers
from rotor_avc.sim.loop import control_plan, controller_forces
from rotor_avc.sim.propagator import DampingRule
from rotor_avc.sim.speed_profile import constant_speed
from rotor_avc.sim.stepper import PlantStepper

#: digest 7.3, demo variant: alpha at 0.98 and 1.02 x Omega_stab (1/s)
DIGEST_ALPHA = {0.98: -0.088, 1.02: +0.088}


def envelope_rate(signal, T, window_s=0.5, skip_s=8.0):
    """Slope of log(max |signal| per window) after ``skip_s`` (the other modes have decayed)."""
    w = int(round(window_s / T))
    m = signal.size // w
    env = np.abs(signal[:m * w]).reshape(m, w).max(axis=1)
    t = (np.arange(m) + 0.5) * window_s
    sel = t > skip_s
    return np.polyfit(t[sel], np.log(env[sel]), 1)[0]


def simulate(machine, speed, w_F, T, duration_s, controllers=None):
    """Rotor-mass displacement after a 1 um kick of the rotor, from rest, at constant speed."""
    plant = machine.plant
    stepper = PlantStepper(plant, T, constant_speed(speed), damping=DampingRule("whirl", w_F))
    controllers = controllers or {}
    plan = control_plan(stepper, controllers)
    for ctrl in controllers.values():
        ctrl.reset()
    x0 = np.zeros(2 * plant.n)
    x0[plant.coords.index("z_w")] = 1e-6
    y = stepper.reset(x0)
    i = stepper.layout.index("rotor_z")
    u = np.zeros(stepper.n_inputs)
    out = np.empty(int(round(duration_s / T)))
    for k in range(out.size):
        controller_forces(plan, y, u)
        y = stepper.step(u)
        out[k] = y[i]
    return out


@pytest.fixture(scope="module")
def base():
    return load_config("roller_bearing_stability")


@pytest.mark.parametrize("factor", [0.98, 1.02])
def test_open_loop_growth_rate_equals_the_critical_real_part(base, full, factor):
    machine, result = machine_threshold(with_variants(base, ["demo"]))
    assert result.threshold_rpm == pytest.approx(4426, rel=1e-3)
    speed = factor * result.speed_rad_s
    alpha = eigen_source(machine.loop, result.w_F).max_real_part(speed)[0]
    assert alpha == pytest.approx(DIGEST_ALPHA[factor], rel=0.03)
    T = 2e-3
    rate = envelope_rate(simulate(machine, speed, result.w_F, T, 60.0 if full else 30.0), T)
    assert np.sign(rate) == np.sign(alpha)
    assert rate == pytest.approx(alpha, rel=0.03)


@pytest.mark.parametrize("factor", [0.98, 1.02])
def test_digital_foot_control_growth_rate_equals_the_sampled_loop(base, factor):
    """Lockstep loop with the digital velocity feedback (K_v = 1e5 N s/m at 2 kHz) against the
    sampled-loop eigen-analysis at the sampled threshold (~6700 rpm vs. 6680 continuous)."""
    cfg = with_variants(base, ["demo", "velocity_feedback", "sampled"])
    machine, result = machine_threshold(cfg)
    assert result.threshold_rpm == pytest.approx(6680, rel=0.01)
    loop = stability_loop(machine, threshold_settings(cfg))
    speed = factor * result.speed_rad_s
    alpha = eigen_source(loop, result.w_F).max_real_part(speed)[0]
    assert abs(alpha) > 0.02
    T = loop.sample_period_s
    blocks = build_digital_controllers(machine)
    rate = envelope_rate(simulate(machine, speed, result.w_F, T, 25.0, blocks), T)
    assert np.sign(rate) == np.sign(alpha)
    assert rate == pytest.approx(alpha, rel=0.05)


def test_sampled_threshold_tends_to_the_continuous_one(base):
    """The discrete controller's threshold approaches the continuous one as the rate rises and
    drops at a low rate (the hold's lag)."""
    cont = machine_threshold(with_variants(base, ["demo", "velocity_feedback"]))[1].threshold_rpm
    sampled = {}
    for rate_hz in (250.0, 20000.0):
        cfg = with_variants(base, ["demo", "velocity_feedback", "sampled"])
        cfg.data["control"]["sample_rate_hz"] = rate_hz
        sampled[rate_hz] = machine_threshold(cfg)[1].threshold_rpm
    assert sampled[20000.0] == pytest.approx(cont, rel=2e-3)
    assert sampled[250.0] < 0.98 * cont
