"""RLS of the imbalance (Zhou & Shi 2001 eqs. 2-3, digest 3.2 and 6): the generic filter against batch
least squares, its covariance over long runs, forgetting, safe holds; the paper's estimator on
exact run-up signals (closed form of App. A) with and without the paper's noise level."""
import dataclasses
import math

import numpy as np
import pytest

from rotor_avc.balancing.regression import RigidSample
from rotor_avc.balancing.rls import RigidRotorRls, RlsFilter
from rotor_avc.balancing.runup_response import runup_response
from rotor_avc.balancing.scenario import rigid_setup
from rotor_avc.config import load_config
from rotor_avc.errors import ModelError

SETUP = rigid_setup(load_config("balancer_rigid_rotor"))
ROTOR, SC = SETUP.rotor, SETUP.runup


def runup_samples(sc, t_end, noise=True, seed=0):
    """Exact open-loop run-up signals (balancer at zero) from the closed form, with the stated
    uniform noise on R_X, R_Z (+-noise_displacement_m) and theta, psi (+-noise_tilt_rad)."""
    rot = sc.rotor
    t = np.arange(int(round(t_end / sc.sample_period_s)) + 1) * sc.sample_period_s
    p1, p2 = (runup_response(t, rot.omega_n[i], rot.zeta[i], sc.accel_rad_s2) for i in range(2))
    amp = sc.true_amplitudes()
    U1, U2 = np.conj(amp["static"]) / rot.mass_kg, -1j * np.conj(amp["moment"]) / rot.I_t
    R, dR = U1 * np.conj(p1.total), U1 * np.conj(p1.velocity)
    Th, dTh = U2 * np.conj(p2.total), U2 * np.conj(p2.velocity)
    rng = np.random.default_rng(seed)
    if noise:
        R = R + (rng.uniform(-1, 1, t.size) + 1j * rng.uniform(-1, 1, t.size)) * sc.noise_displacement_m
        Th = Th + (rng.uniform(-1, 1, t.size) + 1j * rng.uniform(-1, 1, t.size)) * sc.noise_tilt_rad
    a = sc.accel_rad_s2
    return [RigidSample(t[k], 0.5 * a * t[k]**2, a * t[k], a, R[k].real, dR[k].real, Th[k].real,
                        dTh[k].real, R[k].imag, dR[k].imag, Th[k].imag, dTh[k].imag)
            for k in range(t.size)]


def rel_errors(est, b_true):
    b = est.b
    return (np.linalg.norm(b[:2] - b_true[:2]) / np.linalg.norm(b_true[:2]),
            np.linalg.norm(b[2:] - b_true[2:]) / np.linalg.norm(b_true[2:]))


def run_estimator(samples, checkpoints, **kw):
    est = RigidRotorRls(ROTOR, SC.balancer_mass_kg, SC.balancer_axial_m,
                        **{**SETUP.estimator, **kw})
    out = {}
    for s in samples:
        est.update(s)
        for tc in checkpoints:
            if abs(s.t - tc) < 1e-9:
                out[tc] = (rel_errors(est, SC.true_b()), dict(est.std()))
    return est, out


def test_filter_equals_batch_least_squares_with_prior():
    rng = np.random.default_rng(1)
    X = rng.normal(size=(400, 3)) * np.array([1e3, 1e4, 1e5])
    theta = np.array([1e-3, -2e-4, 5e-5])
    y = X @ theta + rng.normal(size=400) * 0.1
    p0 = 1e-4
    f = RlsFilter(3, p0)
    for k in range(0, 400, 2):                         # two rows per sample
        assert f.update(X[k:k + 2], y[k:k + 2])
    batch = np.linalg.solve(X.T @ X + np.eye(3) / p0, X.T @ y)
    np.testing.assert_allclose(f.theta, batch, rtol=1e-8)
    np.testing.assert_allclose(f.P, np.linalg.inv(X.T @ X + np.eye(3) / p0), rtol=1e-7)
    assert f.noise_var == pytest.approx(0.01, rel=0.2)


def test_covariance_stays_positive_definite_over_long_runs(full):
    """Run-up-like regressors growing to 1e7 with a diffuse start: Joseph form keeps P symmetric
    positive definite and the estimate exact to the noise level."""
    n = 400_000 if full else 40_000
    t = np.arange(n) * 1e-4 * (400_000 / n)
    w = 300.0 * t
    phi = 150.0 * t**2
    X = np.column_stack([w**2 * np.cos(phi), -w**2 * np.sin(phi)]) * 11.6
    theta = np.array([-6.1e-5, -3.1e-5])
    y = X @ theta + np.random.default_rng(2).normal(size=n) * 10.0
    f = RlsFilter(2, 1e6)
    min_eig = np.inf
    for k in range(n):
        f.update(X[k], y[k])
        if k % 1000 == 0:
            min_eig = min(min_eig, np.linalg.eigvalsh(f.P).min())
            assert np.array_equal(f.P, f.P.T)
    assert min_eig > 0 and np.linalg.eigvalsh(f.P).min() > 0
    assert np.linalg.norm(f.theta - theta) / np.linalg.norm(theta) < 1e-3


def test_forgetting_tracks_a_change():
    rng = np.random.default_rng(3)
    f, g = RlsFilter(2, 1.0, forgetting=0.98), RlsFilter(2, 1.0)
    for k in range(600):
        x = rng.normal(size=2)
        for filt in (f, g):
            filt.update(x, x @ ([1.0, 2.0] if k < 300 else [-1.0, 0.5]))
    # old data weigh 0.98^300 = 0.2 %: the forgetting filter follows, ordinary RLS averages
    assert np.abs(f.theta - [-1.0, 0.5]).max() < 0.02
    assert np.abs(g.theta - [-1.0, 0.5]).max() > 0.5
    with pytest.raises(ModelError, match="forgetting"):
        RlsFilter(2, 1.0, forgetting=1.5)


def test_nan_samples_and_empty_rows_are_held():
    f = RlsFilter(2, 1.0)
    f.update([1.0, 0.0], 2.0)
    state = (f.theta.copy(), f.P.copy())
    assert not f.update([np.nan, 1.0], 1.0)
    assert not f.update([1.0, 1.0], np.inf)
    assert not f.update([0.0, 0.0], 5.0)            # zero speed and acceleration: no information
    assert f.n_held == 3
    np.testing.assert_array_equal(f.theta, state[0])
    np.testing.assert_array_equal(f.P, state[1])


def test_rigid_estimator_holds_on_nan_and_at_rest():
    samples = runup_samples(SC, 0.05, noise=False)
    est = RigidRotorRls(ROTOR, 0.5, 0.3, **SETUP.estimator)
    rest = dataclasses.replace(samples[0], accel=0.0)      # at rest, not accelerating
    assert not est.update(rest) and not est.update(dataclasses.replace(rest, t=1e-4))
    for k, s in enumerate(samples):
        if k % 7 == 3:
            s = dataclasses.replace(s, R_X=math.nan)
        est.update(s)
    assert np.all(np.isfinite(est.b)) and est.n_held >= len(samples) // 7
    clean, _ = run_estimator(samples, [])
    assert np.linalg.norm(est.b - clean.b) < 0.05 * np.linalg.norm(clean.b)


@pytest.mark.parametrize("noise", [False, True])
def test_converges_within_5pc_by_half_second_and_1pc_by_one_second(noise):
    """Paper scenario, T = 1e-4 s, noise +-1e-5 m on R and +-2e-5 rad on the tilt (seeded)."""
    samples = runup_samples(SC, 1.0, noise=noise, seed=SC.seed)
    _, out = run_estimator(samples, [0.5, 1.0])
    (e1, e2), std = out[0.5]
    assert max(e1, e2) < 0.05
    (e1, e2), std = out[1.0]
    assert max(e1, e2) < 0.01
    if noise:                 # the reported uncertainty covers the actual error
        m, bt = ROTOR.mass_kg, SC.true_b()
        assert e1 * np.linalg.norm(bt[:2]) * m < 3 * std["static"]
        assert e2 * np.linalg.norm(bt[2:]) * m < 3 * std["moment"]
    else:
        assert max(e1, e2) < 1e-3


def test_forward_difference_is_biased_near_resonance_midpoint_is_not():
    """Digest 6: the O(T) phase error of eq. (2) as printed biases the estimate after a
    critical (12 % at T = 1e-4 s on the paper's rotor); the midpoint variant does not. A faster
    run-up (alpha = 3000 rad/s^2) passes the first critical within 0.25 s."""
    sc = dataclasses.replace(SC, accel_rad_s2=3000.0)
    samples = runup_samples(sc, 0.25, noise=False)
    errs = {}
    for reg in ("forward", "midpoint", "measured"):
        est = RigidRotorRls(ROTOR, 0.5, 0.3, **{**SETUP.estimator, "regression": reg})
        for s in samples:
            est.update(s)
        errs[reg] = rel_errors(est, sc.true_b())[0]
    assert errs["forward"] > 0.03
    assert errs["midpoint"] < 0.005 and errs["forward"] > 20 * errs["midpoint"]
