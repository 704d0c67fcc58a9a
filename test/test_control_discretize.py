"""Discretisation of G_c(s): every controller kind x every method against python-control's
``sample_system``, the Tustin prewarp property, and clear errors for bad specs."""
import math

import control
import numpy as np
import pytest

from rotor_avc.control.discretize import DiscreteTf, discretize_controller
from rotor_avc.control.filter import IirFilter
from rotor_avc.control.spec import (ContinuousController, i_controller, lead_lag_controller,
                                    p_controller, pd_controller, pi_controller, pid_controller)
from rotor_avc.errors import ModelError

KINDS = {
    "P": p_controller(2.5e6, "displacement"),
    "I": i_controller(1.4e5, "acceleration"),
    "I_leak": i_controller(1.4e5, "acceleration", leak_hz=0.5),
    "PI": pi_controller(3e3, 1.4e5, "acceleration"),
    "PI_leak": pi_controller(3e3, 1.4e5, "acceleration", leak_hz=0.3),
    "PD": pd_controller(1e7, 2e4, "displacement", derivative_filter_s=1e-4),
    "PID": pid_controller(1e7, 5e8, 2e4, "displacement", derivative_filter_s=2e-4),
    "PID_leak": pid_controller(2e5, 1e6, 50.0, "velocity", derivative_filter_s=1e-4, leak_hz=0.2),
    "lead_lag": lead_lag_controller(1e5, 30.0, 300.0, "velocity"),
    "tf": ContinuousController(np.array([2.0, 3e2, 4e4]), np.array([1.0, 80.0, 9e4, 1e5]),
                               "velocity"),
}
METHODS = {"tustin": "bilinear", "zoh": "zoh", "foh": "foh"}


def _pc_coeffs(ctrl, T, method, prewarp_rad_s=None):
    sysd = control.sample_system(control.tf(ctrl.num, ctrl.den), T, method=method,
                                 prewarp_frequency=prewarp_rad_s)
    num, den = np.asarray(sysd.num[0][0], float), np.asarray(sysd.den[0][0], float)
    n = max(num.size, den.size)
    num = np.concatenate([np.zeros(n - num.size), num])
    den = np.concatenate([np.zeros(n - den.size), den])
    return num / den[0], den / den[0]


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("method", list(METHODS))
@pytest.mark.parametrize("rate_hz", [1000.0, 5000.0, 20000.0])
def test_matches_python_control(kind, method, rate_hz):
    ctrl, T = KINDS[kind], 1.0 / rate_hz
    tf = discretize_controller(ctrl, T, method)
    b_ref, a_ref = _pc_coeffs(ctrl, T, METHODS[method])
    if kind == "P":     # python-control returns k (1 - z^-1)/(1 - z^-1): same G_d, order 1 not 0
        z = np.exp(1j * np.linspace(0.1, 3.0, 7))
        ref = np.polyval(b_ref[::-1], 1 / z) / np.polyval(a_ref[::-1], 1 / z)
        np.testing.assert_allclose(tf(z), ref, rtol=1e-12)
        assert tf.order == 0
        return
    assert tf.b.size == b_ref.size and tf.a.size == a_ref.size
    scale_b = max(np.abs(b_ref).max(), 1e-300)
    np.testing.assert_allclose(tf.b, b_ref, rtol=0, atol=1e-10 * scale_b)
    np.testing.assert_allclose(tf.a, a_ref, rtol=0, atol=1e-10)
    assert tf.a[0] == 1.0 and tf.feedback == ctrl.feedback


@pytest.mark.parametrize("kind", ["I", "PID", "lead_lag", "tf"])
def test_tustin_prewarp_matches_python_control_and_is_exact_at_the_warp(kind):
    ctrl, T, f_w = KINDS[kind], 1.0 / 2000.0, 300.0
    tf = discretize_controller(ctrl, T, "tustin", prewarp_hz=f_w)
    b_ref, a_ref = _pc_coeffs(ctrl, T, "bilinear", 2 * math.pi * f_w)
    np.testing.assert_allclose(tf.b, b_ref, rtol=0, atol=1e-10 * np.abs(b_ref).max())
    np.testing.assert_allclose(tf.a, a_ref, rtol=0, atol=1e-10)
    w = 2 * math.pi * f_w                            # G_d(e^{j w T}) = G_c(j w) at the warp
    assert abs(tf.frequency_response(w) / ctrl(1j * w) - 1) < 1e-9
    plain = discretize_controller(ctrl, T, "tustin")
    assert abs(plain.frequency_response(w) / ctrl(1j * w) - 1) > 1e-4   # without it: not exact


def test_seed000_tustin_integrator_is_the_digest_recursion():
    """Digest 000 section 10: F[k] = F[k-1] - b0 T/2 (a[k] + a[k-1]) (the minus in the block)."""
    b0, T = 1.4e5, 2e-4
    tf = discretize_controller(i_controller(b0, "acceleration"), T, "tustin")
    np.testing.assert_allclose(tf.b, [b0 * T / 2, b0 * T / 2], rtol=1e-15)
    np.testing.assert_allclose(tf.a, [1.0, -1.0], rtol=0, atol=0)


def test_discrete_response_converges_to_continuous():
    ctrl = KINDS["PID"]
    w = 2 * math.pi * np.array([5.0, 50.0])
    errs = [np.max(np.abs(discretize_controller(ctrl, T, "tustin").frequency_response(w)
                          / ctrl(1j * w) - 1)) for T in (1e-3, 1e-4)]
    assert errs[1] < errs[0] / 50                      # Tustin: error ~ T^2


def test_coefficients_are_printable():
    text = discretize_controller(KINDS["I"], 2e-4, "tustin").describe()
    assert "b = [14, 14]" in text and "a = [1, -1]" in text and "5000 Hz" in text


def test_improper_spec_is_refused_with_the_fix():
    with pytest.raises(ModelError, match="improper.*derivative filter"):
        discretize_controller(pd_controller(1e7, 2e4, "displacement"), 1e-4)


@pytest.mark.parametrize("period", [-1e-3, 0.0, float("nan"), float("inf"), "fast"])
def test_bad_sample_period(period):
    with pytest.raises(ModelError, match="sample period"):
        discretize_controller(KINDS["I"], period)


@pytest.mark.parametrize("f_w", [2500.0, 4000.0, -5.0, 0.0, float("nan")])
def test_prewarp_at_or_above_nyquist_or_not_positive(f_w):
    with pytest.raises(ModelError, match="Nyquist"):
        discretize_controller(KINDS["I"], 1 / 5000.0, "tustin", prewarp_hz=f_w)


def test_prewarp_only_for_tustin_and_unknown_method():
    with pytest.raises(ModelError, match="tustin"):
        discretize_controller(KINDS["I"], 1e-4, "zoh", prewarp_hz=100.0)
    with pytest.raises(ModelError, match="unknown discretisation method"):
        discretize_controller(KINDS["I"], 1e-4, "matched")


def test_nan_coefficients_are_refused_everywhere():
    with pytest.raises(ModelError, match="non-finite"):
        ContinuousController(np.array([1.0, float("nan")]), np.array([1.0, 0.0]), "velocity")
    with pytest.raises(ModelError, match="finite"):
        DiscreteTf([1.0, float("nan")], [1.0, -1.0], 1e-3)
    with pytest.raises(ModelError, match="finite"):
        IirFilter([1.0], [1.0, float("inf")])
    with pytest.raises(ModelError, match="a\\[0\\] is zero"):
        DiscreteTf([1.0], [0.0, 1.0], 1e-3)
