"""Saturation, rate limit and anti-windup against textbook reference trajectories.

The references are the control_toolbox formulas for a PI controller written out directly
(``u = kp e + i``, ``i += dt (ki e + (u_sat - u)/trk_tc)`` for back-calculation; integrate only
if ``u == u_sat or e u <= 0`` for conditional integration), run beside the generic filter +
limits of the DigitalController block on a ZOH-discretised PI."""
import numpy as np
import pytest

from rotor_avc.control.block import DigitalController
from rotor_avc.control.discretize import discretize_controller
from rotor_avc.control.limits import OutputLimits, check_anti_windup
from rotor_avc.control.spec import i_controller, p_controller, pi_controller
from rotor_avc.errors import ModelError

T = 1e-3
KP, KI, LIMIT = 10.0, 2000.0, 100.0


def reference_pi(e, strategy, kb=None):
    """Textbook discrete PI (forward-Euler integral = ZOH of ki/s) with output saturation."""
    i, out = 0.0, []
    for ek in e:
        u = KP * ek + i
        u_sat = min(max(u, -LIMIT), LIMIT)
        if strategy == "back_calculation":
            i += T * (KI * ek + kb * (u_sat - u))
        elif strategy == "conditional_integration":
            if u == u_sat or ek * u <= 0:
                i += T * KI * ek
        else:
            i += T * KI * ek
        out.append(u_sat)
    return np.array(out)


def run_block(e, strategy, kb=None, kp=KP):
    tf = discretize_controller(pi_controller(kp, KI, "velocity") if kp else
                               i_controller(KI, "velocity"), T, "zoh")
    block = DigitalController(tf, force_limit_n=LIMIT, anti_windup=strategy,
                              back_calculation_gain=kb)
    return -np.array([block.step(v) for v in e])      # filter output = -force


def reversal(duration_s, after_s=6.0, level=1.0):
    n1, n2 = int(round(duration_s / T)), int(round(after_s / T))
    return np.concatenate([np.full(n1, level), np.full(n2, -level)]), n1


def recovery_s(y, k_rev):
    """Time from the error reversal to the first sample off the limit."""
    after = np.abs(y[k_rev:]) < LIMIT * (1 - 1e-12)
    return np.argmax(after) * T if after.any() else np.inf


@pytest.mark.parametrize("strategy,kb", [("none", None), ("back_calculation", 20.0),
                                         ("back_calculation", 1 / T),
                                         ("conditional_integration", None)])
def test_matches_the_reference_trajectory(strategy, kb):
    rng = np.random.default_rng(5)
    e = np.concatenate([np.full(400, 1.0), rng.standard_normal(600) * 0.8, np.full(300, -0.7),
                        rng.standard_normal(700) * 0.3])
    if strategy == "none":
        tf = discretize_controller(pi_controller(KP, KI, "velocity"), T, "zoh")
        block = DigitalController(tf, force_limit_n=LIMIT)
        y = -np.array([block.step(v) for v in e])
    else:
        y = run_block(e, strategy, kb)
    ref = reference_pi(e, strategy, kb)
    assert np.mean(np.abs(ref) >= LIMIT) > 0.1           # the limit really is active
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-9 * LIMIT)


@pytest.mark.parametrize("kp", [KP, 0.0])
def test_recovery_after_long_saturation(kp):
    """No anti-windup: recovery grows with the saturation time. Back-calculation: within the
    tracking time constant 1/K_b. Conditional integration: within two samples. Both
    independent of how long the output was saturated."""
    kb = 50.0
    rec = {}
    for duration in (0.5, 5.0):
        e, k_rev = reversal(duration)
        rec["none", duration] = recovery_s(reference_pi(e, "none") if kp else
                                           run_block(e, "none", kp=0.0), k_rev)
        rec["bc", duration] = recovery_s(run_block(e, "back_calculation", kb, kp=kp), k_rev)
        rec["ci", duration] = recovery_s(run_block(e, "conditional_integration", kp=kp), k_rev)
    # without anti-windup the integral must unwind: ~ duration - LIMIT/KI
    for d in (0.5, 5.0):
        # analytic: the integral KI d must come back to LIMIT + kp (kp e jumps by 2 kp)
        assert abs(rec["none", d] - (d - (LIMIT + kp) / KI)) <= 2 * T
        assert rec["bc", d] <= 1 / kb + 2 * T
        assert rec["ci", d] <= 2 * T
    assert rec["bc", 0.5] == rec["bc", 5.0] and rec["ci", 0.5] == rec["ci", 5.0]


def test_saturation_and_rate_limit():
    tf = discretize_controller(p_controller(1.0, "acceleration"), T, "tustin")
    rate = 2e4                                            # N/s -> 20 N per sample
    block = DigitalController(tf, force_limit_n=LIMIT, rate_limit_n_per_s=rate)
    forces = [block.step(500.0) for _ in range(10)]      # wants -500 N at once
    np.testing.assert_allclose(forces[:5], -20.0 * np.arange(1, 6))
    assert forces[5:] == [-LIMIT] * 5                    # then the force limit holds
    forces = [block.step(-500.0) for _ in range(12)]
    assert np.all(np.abs(np.diff([-LIMIT] + forces)) <= rate * T * (1 + 1e-12))
    assert forces[-1] == LIMIT


def test_limit_validation():
    lim = OutputLimits(T, None, None)
    with pytest.raises(ModelError, match="needs a limit"):
        check_anti_windup("back_calculation", lim, T, None)
    with pytest.raises(ModelError, match="unknown anti_windup"):
        check_anti_windup("clamping", lim, T, None)
    lim = OutputLimits(T, LIMIT, None)
    with pytest.raises(ModelError, match="back_calculation_gain must lie"):
        check_anti_windup("back_calculation", lim, T, 2 / T)
    with pytest.raises(ModelError, match="only used with anti_windup: back_calculation"):
        check_anti_windup("conditional_integration", lim, T, 10.0)
    with pytest.raises(ModelError, match="force_limit_n must be finite and > 0"):
        OutputLimits(T, -5.0, None)
    assert check_anti_windup("back_calculation", lim, T, None) == 1.0
