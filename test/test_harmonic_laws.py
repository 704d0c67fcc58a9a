"""Adaptive harmonic control, unit level: update laws against their closed-form convergence,
RLS identification against a known matrix, the block's demodulation against the analytic
phasor, limits, fallback and config errors."""
import math

import numpy as np
import pytest

from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.harmonic.block import HarmonicController
from rotor_avc.harmonic.block_settings import HarmonicSettings
from rotor_avc.harmonic.identification import InfluenceRls
from rotor_avc.harmonic.influence import InfluenceSchedule
from rotor_avc.harmonic.laws import convergence_radius, update_matrices
from rotor_avc.harmonic.lti import robustness_map
from rotor_avc.harmonic.supervisor import SupervisorSettings

RNG = np.random.default_rng(7)


def random_g(m, n):
    return RNG.standard_normal((m, n)) + 1j * RNG.standard_normal((m, n))


@pytest.mark.parametrize("law", ["steepest_descent", "newton"])
def test_scalar_phase_error_limit_is_90_degrees(law):
    # scalar: radius |1 - mu' e^{-j phi}| (mu' = mu / m for Newton): < 1 iff cos(phi) > mu'/2
    g = np.array([[0.3 - 0.8j]])
    for phi in (30.0, 80.0, 89.0, 91.0, 120.0):
        for mu in (0.01, 0.3, 1.0):
            A_U, B = update_matrices(g * np.exp(1j * np.deg2rad(phi)), law, mu)
            r = convergence_radius(A_U, B, g)
            assert r == pytest.approx(abs(1 - mu * np.exp(-1j * np.deg2rad(phi))), rel=1e-12)
            assert (r < 1) == (math.cos(math.radians(phi)) > mu / 2)


def test_newton_cancels_in_one_step_and_leakage_extends_the_phase_limit():
    G = random_g(2, 3)
    A_U, B = update_matrices(G, "newton", 1.0)
    P = RNG.standard_normal(2) + 1j * RNG.standard_normal(2)
    U = A_U @ np.zeros(3) - B @ P
    assert np.abs(P + G @ U).max() < 1e-12 * np.abs(P).max()
    # at 95 degrees of error pure Newton diverges for every gain; with leakage small gains converge
    est = G * np.exp(1j * np.deg2rad(95))
    assert convergence_radius(*update_matrices(est, "newton", 0.05), G) > 1
    assert convergence_radius(*update_matrices(est, "newton", 0.05, leakage=0.05), G) < 1


def test_wls_converges_to_the_penalised_optimum():
    G = random_g(3, 2)
    P = RNG.standard_normal(3) + 1j * RNG.standard_normal(3)
    beta = 0.1
    A_U, B = update_matrices(G, "wls", 0.7, effort_weight=beta)
    U = np.zeros(2, complex)
    for _ in range(200):
        U = A_U @ U - B @ (P + G @ U)
    R = beta * np.linalg.norm(G, 2) ** 2 * np.eye(2)
    optimum = -np.linalg.solve(G.conj().T @ G + R, G.conj().T @ P)
    assert np.allclose(U, optimum, rtol=1e-10, atol=1e-12)


def test_weighted_newton_and_leaky_weighted_wls_settle_on_their_closed_forms():
    """With sensor weights W the Newton step is ``pinv(W^1/2 G) W^1/2 E``: its fixed point solves
    ``G^H W (P + G U) = 0``, the weighted least squares ``U = -(G^H W G)^-1 G^H W P`` (more
    sensors than actuators: the error is not cancelled). wls with leakage ``l``: the fixed
    point of ``U = A U - B (P + G U)`` is ``(l + mu) U = -mu H^-1 G^H W P``, the penalised
    optimum scaled by ``mu / (mu + l)``."""
    G = random_g(3, 2)
    P = RNG.standard_normal(3) + 1j * RNG.standard_normal(3)
    w = np.array([1.0, 4.0, 0.25])
    GhW = G.conj().T * w
    wls_fit = -np.linalg.solve(GhW @ G, GhW @ P)
    assert np.abs(wls_fit + np.linalg.pinv(G) @ P).max() > 0.05 * np.abs(wls_fit).max()
    A_U, B = update_matrices(G, "newton", 0.6, sensor_weights=w)
    U = np.zeros(2, complex)
    for _ in range(200):
        U = A_U @ U - B @ (P + G @ U)
    np.testing.assert_allclose(U, wls_fit, rtol=1e-10, atol=1e-12)
    beta, mu, leak = 0.1, 0.7, 0.2
    s2 = np.linalg.norm(np.sqrt(w)[:, None] * G, 2) ** 2
    H = GhW @ G + beta * s2 * np.eye(2)
    A_U, B = update_matrices(G, "wls", mu, effort_weight=beta, leakage=leak, sensor_weights=w)
    U = np.zeros(2, complex)
    for _ in range(400):
        U = A_U @ U - B @ (P + G @ U)
    np.testing.assert_allclose(U, -mu / (mu + leak) * np.linalg.solve(H, GhW @ P), rtol=1e-10,
                               atol=1e-12)


@pytest.mark.parametrize("G, gain, message", [
    (random_g(2, 3), -0.5, "adaptation gain must be > 0"),
    (random_g(2, 3) * np.array([1.0, np.nan, 1.0]), 0.5, "finite .sensors, actuators. matrix"),
    (random_g(1, 3)[0], 0.5, "finite .sensors, actuators. matrix")])
def test_a_negative_gain_or_an_estimate_that_is_no_finite_matrix_is_refused(G, gain, message):
    with pytest.raises(ModelError, match=message):
        update_matrices(G, "newton", gain)


def test_robustness_map_shows_where_each_law_diverges():
    # Newton and steepest descent: the error iteration's eigenvalues are 1 - (mu/m) e^{-j phi}
    # times (1 for Newton; sigma_i^2 / sigma_max^2 <= 1 for steepest descent), so both diverge
    # past phi = acos(mu / 2m) < 90 degrees; the effort penalty (wls) acts like leakage.
    G = random_g(2, 3)
    phases = np.arange(0, 181, 5.0)
    mags, gains = np.array([0.5, 1.0, 2.0]), np.array([0.1, 0.4])
    for law in ("steepest_descent", "newton"):
        limit = robustness_map(G, law, phases, mags, gains).phase_limit_deg()
        bound = np.degrees(np.arccos(gains[None, :] / (2 * mags[:, None])))
        expected = np.floor((bound - 1e-9) / 5.0) * 5.0
        assert np.array_equal(limit, expected)
        assert np.all(limit < 90)
    wls = robustness_map(G, "wls", phases, mags, gains, effort_weight=0.05).phase_limit_deg()
    assert np.all(wls >= limit) and np.all(wls[1:, 0] >= 90)


def test_rls_identifies_a_matrix_from_changes():
    rng = np.random.default_rng(3)
    G, prior = (rng.standard_normal((2, 3)) + 1j * rng.standard_normal((2, 3)) for _ in range(2))
    rls = InfluenceRls(2, 3, forgetting=1.0, min_change=1e-9)
    for _ in range(12):
        dA = rng.standard_normal(3) + 1j * rng.standard_normal(3)
        assert rls.update(dA, G @ dA, prior)
    assert np.allclose(prior + rls.correction, G, atol=1e-2 * np.abs(G).max())
    assert rls.residual < 1e-2
    assert not rls.update(np.zeros(3), np.zeros(2), prior)        # no excitation: no update


def schedule(G, speed):
    return InfluenceSchedule(np.array([0.5 * speed, 2 * speed]), (1,),
                             np.stack([G[None], G[None]]), ("a", "b"), ("x", "y", "z"))


def test_block_demodulates_the_phasor_and_cancels_a_static_plant():
    T, speed = 1e-3, 2 * np.pi * 12.3          # a revolution is not a whole number of samples
    G = random_g(2, 3)
    P = np.array([0.4 - 0.1j, -0.2 + 0.3j])
    block = HarmonicController(schedule(G, speed), T, HarmonicSettings(gain=1.0, min_speed_hz=1))
    u = np.zeros(3)
    for k in range(3000):
        angle = speed * k * T
        y = ((P + G @ np.asarray(block.U[0] + 0)) * np.exp(1j * angle)).real   # static plant
        u = block.step(list(y), angle, speed)
        if block.n_updates == 1 and k < 200:
            # the first window's phasor: the disturbance, up to the window's fractional sample
            assert np.abs(block.E[0] - P).max() < 0.02 * np.abs(P).max()
    assert np.abs(block.E[0]).max() < 1e-6 * np.abs(P).max()
    assert np.allclose(P + G @ block.U[0], 0, atol=1e-6)
    assert len(u) == 3


def test_force_limit_and_fallback():
    T, speed = 1e-3, 2 * np.pi * 10
    G = random_g(2, 3)
    P = np.array([1.0, 1.0j])
    wrong = schedule(G * np.exp(1j * np.deg2rad(150)), speed)
    block = HarmonicController(wrong, T, HarmonicSettings(
        gain=0.5, min_speed_hz=1, force_limit_n=5.0, divergence_factor=3.0, fallback="fade",
        supervisor=SupervisorSettings(enabled=False)))     # the fallback behind the supervisor
    peak = 0.0
    for k in range(20000):
        angle = speed * k * T
        y = ((P + G @ block.U[0]) * np.exp(1j * angle)).real
        peak = max(peak, max(abs(f) for f in block.step(list(y), angle, speed)))
    assert peak <= 5.0 + 1e-9
    assert block.mode == "fading" and "diverging" in block.reason
    assert np.abs(block.U).max() < 1e-3               # faded out
    state = block.state
    block.reset()
    assert block.mode == "off"
    block.set_state(state)
    assert block.mode == "fading"


def test_settings_and_config_errors():
    with pytest.raises(ModelError, match="wls"):
        HarmonicSettings(law="newton", effort_weight=0.1).check()
    with pytest.raises(ModelError, match="fallback"):
        HarmonicSettings(fallback="explode").check()
    from rotor_avc.config import load_config
    from rotor_avc.scenario import scenario_from_config
    base = load_config("scenario_harmonic_case2_steady").data
    for change, field in (({"sensors": ["bearing_X_vz"]}, "harmonic.sensors"),
                          ({"law": "wls"}, "harmonic.effort_weight"),
                          ({"gain": -1}, "harmonic.gain"),
                          ({"gain": "fast"}, "harmonic.gain"),
                          ({"harmonics": [0]}, "harmonic.harmonics"),
                          ({"fallback": {"mode": "stop"}}, "harmonic.fallback.mode"),
                          ({"identification": {"forgeting": 0.9}},
                           "harmonic.identification.forgeting"),
                          ({"runout": [{"sensor": "bearing_X_vz", "magnitude": 1e-4}]},
                           "harmonic.runout[0].sensor"),
                          ({"runout": [{"sensor": "bearing_D_vz", "order": 0, "magnitude": 1}]},
                           "harmonic.runout[0].order"),
                          ({"runout": [{"sensor": "bearing_D_vz", "magnitude": -1.0}]},
                           "harmonic.runout[0].magnitude"),
                          ({"runout": [{"sensor": "bearing_D_vz", "magnitud": 1.0}]},
                           "harmonic.runout[0].magnitud"),
                          ({"colour": 1}, "harmonic.colour")):
        data = {**base, "harmonic": {**base["harmonic"], **change}}
        with pytest.raises(ConfigError) as err:
            scenario_from_config(data, "test").harmonic()
        assert err.value.field == field


def test_block_cancels_1x_and_2x_together():
    T, speed = 1e-3, 2 * np.pi * 9.7
    G1, G2 = random_g(2, 3), random_g(2, 3)
    P1, P2 = np.array([0.3 + 0.2j, -0.1j]), np.array([0.05, 0.02 - 0.04j])
    sched = InfluenceSchedule(np.array([0.5 * speed, 2 * speed]), (1, 2),
                              np.stack([np.stack([G1, G2])] * 2), ("a", "b"), ("x", "y", "z"))
    block = HarmonicController(sched, T, HarmonicSettings(gain=0.8, min_speed_hz=1))
    for k in range(5000):
        angle = speed * k * T
        y = ((P1 + G1 @ block.U[0]) * np.exp(1j * angle)
             + (P2 + G2 @ block.U[1]) * np.exp(2j * angle)).real
        block.step(list(y), angle, speed)
    assert np.abs(P1 + G1 @ block.U[0]).max() < 1e-6 and np.abs(P2 + G2 @ block.U[1]).max() < 1e-6
