"""The per-sample filter: equal to scipy.signal.lfilter, steady-state start, bumpless gain."""
import math

import numpy as np
import pytest
import scipy.signal

from rotor_avc.control.discretize import discretize_controller
from rotor_avc.control.filter import IirFilter
from rotor_avc.control.spec import (i_controller, lead_lag_controller, p_controller, pd_controller,
                                    pi_controller, pid_controller)
from rotor_avc.errors import ModelError

T = 1 / 5000.0
SPECS = {
    "P": p_controller(3.0e3, "acceleration"),
    "I": i_controller(1.4e5, "acceleration"),
    "PI_leak": pi_controller(3e3, 1.4e5, "acceleration", leak_hz=0.5),
    "PID": pid_controller(1e7, 5e8, 2e4, "displacement", derivative_filter_s=2e-4),
    "lead_lag": lead_lag_controller(1e5, 30.0, 300.0, "velocity"),
    "PD": pd_controller(1e7, 2e4, "displacement", derivative_filter_s=2e-4),
}


def _random_stable(order, rng):
    poles = 0.95 * rng.uniform(0.1, 1.0, order) * np.exp(1j * rng.uniform(0, np.pi, order))
    a = np.real(np.poly(np.concatenate([poles[: order // 2], np.conj(poles[: order // 2]),
                                        poles.real[order // 2 * 2:]])))
    return rng.standard_normal(order + 1), a


@pytest.mark.parametrize("kind", list(SPECS))
@pytest.mark.parametrize("method", ["tustin", "zoh"])
def test_equals_lfilter_on_long_random_input(kind, method):
    tf = discretize_controller(SPECS[kind], T, method)
    x = np.random.default_rng(7).standard_normal(50_000)
    filt = IirFilter(tf.b, tf.a)
    y = np.array([filt.step(v) for v in x.tolist()])
    ref = scipy.signal.lfilter(tf.b, tf.a, x)
    assert np.max(np.abs(y - ref)) <= 1e-12 * max(np.max(np.abs(ref)), 1.0)


@pytest.mark.parametrize("order", [3, 4, 6])
def test_equals_lfilter_higher_orders_and_unnormalised_a0(order):
    rng = np.random.default_rng(order)
    b, a = _random_stable(order, rng)
    x = rng.standard_normal(20_000)
    filt = IirFilter(3.0 * b, 3.0 * a)             # a0 != 1 is normalised
    y = np.array([filt.step(v) for v in x.tolist()])
    ref = scipy.signal.lfilter(b, a, x)
    assert np.max(np.abs(y - ref)) <= 1e-12 * np.max(np.abs(ref))


def test_output_and_advance_split_equals_step():
    tf = discretize_controller(SPECS["PID"], T, "tustin")
    f1, f2 = IirFilter(tf.b, tf.a), IirFilter(tf.b, tf.a)
    for v in np.random.default_rng(1).standard_normal(500).tolist():
        y = f2.output(v)
        f2.advance(v, y)
        assert f1.step(v) == y
    assert f1.state == f2.state


@pytest.mark.parametrize("kind", ["P", "PI_leak", "PD", "lead_lag"])
def test_steady_state_start_has_no_transient(kind):
    tf = discretize_controller(SPECS[kind], T, "tustin")
    filt = IirFilter(tf.b, tf.a)
    x0 = 0.37
    filt.init_steady_state(x0)
    y = [filt.step(x0) for _ in range(2000)]
    dc = complex(SPECS[kind](0.0)).real            # continuous G_c(0): Tustin keeps DC gain
    np.testing.assert_allclose(y, dc * x0, rtol=1e-12)
    if tf.order == 0:
        return
    # scipy's steady state (lfilter_zi scaled by the input) agrees
    zi = scipy.signal.lfilter_zi(tf.b, tf.a) * x0
    np.testing.assert_allclose(filt.state, zi, rtol=1e-9, atol=1e-12 * np.abs(zi).max())


def test_integrator_steady_state_holds_a_force_and_refuses_a_ramp():
    tf = discretize_controller(SPECS["I"], T, "tustin")
    filt = IirFilter(tf.b, tf.a)
    filt.init_steady_state(0.0, 250.0)
    assert [filt.step(0.0) for _ in range(100)] == [250.0] * 100
    with pytest.raises(ModelError, match="no steady state"):
        filt.init_steady_state(1.0)
    with pytest.raises(ModelError, match="not a steady state"):
        IirFilter([1.0, 0.5], [1.0, -0.5]).init_steady_state(1.0, 2.0)   # G(1) = 3


def test_bumpless_gain_change_keeps_the_stored_output():
    """I controller holding a force: changing the gain does not move the held force; the new
    gain acts on new input only (the gain sits before the integrator)."""
    tf = discretize_controller(SPECS["PI_leak"], T, "zoh")
    filt = IirFilter(tf.b, tf.a)
    for v in np.random.default_rng(3).standard_normal(300).tolist():
        filt.step(v)
    before = filt.output(0.0)                          # next output for zero input
    filt.set_gain(3.0)
    assert filt.output(0.0) == before                  # no bump in the stored part
    assert filt.gain == 3.0
    # after the change the filter is exactly 3x the design on the new input, from that state
    ref = IirFilter(3.0 * tf.b, tf.a)
    ref.set_state(filt.state)
    x = np.random.default_rng(4).standard_normal(50).tolist()
    assert [filt.step(v) for v in x] == [ref.step(v) for v in x]


def test_reset_and_state_errors():
    tf = discretize_controller(SPECS["PID"], T, "tustin")
    filt = IirFilter(tf.b, tf.a)
    filt.step(1.0)
    assert any(filt.state)
    filt.reset()
    assert filt.state == (0.0, 0.0)
    with pytest.raises(ModelError, match="2 finite numbers"):
        filt.set_state([1.0])
    with pytest.raises(ModelError, match="finite"):
        filt.set_gain(math.nan)
