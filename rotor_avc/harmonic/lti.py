"""Stability of adaptive harmonic control: its exact linear equivalent at a fixed speed.

At a constant speed ``Omega`` with an integer number ``P`` of samples per revolution, the loop
of plant, feedback controllers (the feet's ``G_c``) and the harmonic block
(:mod:`rotor_avc.harmonic.block`, without identification, which is nonlinear) is linear and
``P``-periodic. Its state ``Z = [X; acc; U]`` -- the sampled loop's state ``X`` (plant, held
forces, controller and delay states), the demodulation sums and the real and imaginary parts
of the phasors -- obeys ``Z_{k+1} = M_k Z_k`` with, per sample and in the block's order:

1. ``acc += Omega T [cos(h theta_k); -sin(h theta_k)] e_k``  (``e_k = C_e X_k``);
2. at a window's last sample: ``U <- A_U U - B E``, ``E = 2 acc / (n Omega T)``, ``acc <- 0``;
3. ``X_{k+1} = A X_k + B_h sum_h (cos(h theta_k) Ur_h - sin(h theta_k) Ui_h)``.

The product over one revolution is an exact linear time-invariant system at the revolution
rate (the lifted system); its eigenvalues are the loop's poles per revolution (Floquet
multipliers; ``s = ln(z) / T_rev``), stable iff all lie inside the unit circle. This is the
revolution-rate form of the LTI equivalent of Guo & Bodson (2010) and Zazas & Daley (2017): for
per-sample updates, ``V = U e^{j h theta}`` turns the block into the time-invariant filter with
poles at ``e^{+-j h Omega T}`` that they derive. Eigenvalues exactly at 1 are split off and
not counted: the feedback integrators' drift (as in :mod:`.sampled_loop`) and, for laws
without leakage or effort penalty, the phasor directions the update never moves (the null
space of ``G^`` when there are more actuators than sensors).

The quasi-steady counterpart (no plant dynamics) is :func:`rotor_avc.harmonic.laws.
convergence_radius`; the robustness map (:func:`robustness_map`) evaluates both over the
estimate's phase and magnitude error and the gain.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..analysis.sampled_loop import LoopWithInput, SampledLoop, SampledPoles
from ..errors import ModelError
from .laws import convergence_radius, update_matrices

HELD_TOL = 1e-9


def _real(M: np.ndarray) -> np.ndarray:
    """Real form ``[[Re, -Im], [Im, Re]]`` of a complex matrix."""
    return np.block([[M.real, -M.imag], [M.imag, M.real]])


def samples_per_revolution(speed_rad_s: float, sample_period_s: float) -> int:
    """``P`` if a revolution spans an integer number of samples (to 1e-9), else ModelError."""
    P = 2 * np.pi / (speed_rad_s * sample_period_s)
    if abs(P - round(P)) > 1e-9 * P:
        raise ModelError(f"{speed_rad_s / (2 * np.pi):g} Hz is not an integer number of samples "
                         f"per revolution ({P:.4f}) at {1 / sample_period_s:g} Hz -- pick a "
                         "speed f_s / P for an integer P")
    return int(round(P))


def harmonic_poles(loop: SampledLoop, speed_rad_s: float, w_F: float, actuators, sensors,
                   harmonics, estimate: np.ndarray, law: str, gain: float, *,
                   effort_weight: float = 0.0, leakage: float = 0.0, sensor_weights=None,
                   update_every_samples: int = 0, lwi: LoopWithInput | None = None
                   ) -> SampledPoles:
    """Poles of the one-revolution map of the adaptive loop (module docstring) as
    :class:`SampledPoles` with the revolution as sample period (``drift``: the split-off
    eigenvalues at 1); ``estimate`` (H, M, N) the influence estimate the block uses."""
    T = loop.sample_period_s
    P = samples_per_revolution(speed_rad_s, T)
    every = update_every_samples or P
    if P % every:
        raise ModelError(f"update_every_samples {every} does not divide the {P} samples of a "
                         "revolution (the loop would not be periodic per revolution)")
    lwi = lwi or loop.with_inputs(speed_rad_s, w_F, actuators, sensors)
    H, M, N = len(harmonics), len(sensors), len(actuators)
    Nt = lwi.A.shape[0]
    na, nu = 2 * H * M, 2 * H * N
    nZ = Nt + na + nu
    acc = slice(Nt, Nt + na)
    uu = slice(Nt + na, nZ)
    upd = np.zeros((nu, nu))
    upd_acc = np.zeros((nu, na))
    n_held = 0
    for hi in range(H):
        A_U, B = update_matrices(estimate[hi], law, gain, effort_weight=effort_weight,
                                 leakage=leakage, sensor_weights=sensor_weights)
        r = slice(2 * N * hi, 2 * N * (hi + 1))
        upd[r, r] = _real(A_U)
        upd_acc[r, 2 * M * hi:2 * M * (hi + 1)] = -_real(B) * 2.0 / (every * speed_rad_s * T)
        if np.allclose(A_U, np.eye(N)):
            n_held += 2 * (N - np.linalg.matrix_rank(estimate[hi]))
    w = speed_rad_s * T
    h = np.array(harmonics, dtype=float)
    Phi = np.eye(nZ)
    for k in range(P):                       # Phi <- S3 S2 S1 Phi, each step in place
        c, s = np.cos(h * speed_rad_s * T * k), np.sin(h * speed_rad_s * T * k)
        Ce = lwi.C @ Phi[:Nt]                                     # e_k (M, nZ)
        for hi in range(H):
            Phi[Nt + 2 * M * hi:Nt + 2 * M * hi + M] += w * c[hi] * Ce
            Phi[Nt + 2 * M * hi + M:Nt + 2 * M * (hi + 1)] -= w * s[hi] * Ce
        if (k + 1) % every == 0:
            Phi[uu] = upd @ Phi[uu] + upd_acc @ Phi[acc]
            Phi[acc] = 0.0
        Jout = np.concatenate([np.concatenate([ci * np.eye(N), -si * np.eye(N)], axis=1)
                               for ci, si in zip(c, s)], axis=1)           # (N, nu)
        Phi[:Nt] = lwi.A @ Phi[:Nt] + (lwi.B @ Jout) @ Phi[uu]
    z = scipy.linalg.eigvals(Phi)
    n_split = n_held + lwi.n_drift
    idx = np.argsort(np.abs(z - 1.0))[:n_split]
    idx = idx[np.abs(z[idx] - 1.0) <= HELD_TOL ** 0.5]
    keep = np.ones(z.size, bool)
    keep[idx] = False
    return SampledPoles(float(speed_rad_s), float(w_F), P * T, z[keep], z[idx])


def excitation_loop_poles(loop: SampledLoop, speed_rad_s: float, w_F: float, sensors,
                          disturbance: np.ndarray, law: str, gain: float, *,
                          effort_weight: float = 0.0, leakage: float = 0.0, sensor_weights=None,
                          lwi: LoopWithInput | None = None) -> SampledPoles:
    """Poles of the one-revolution map of the excitation estimate's adaptation under the
    dynamic feed-forward (:mod:`.internal_model`): the residual is the loop's own response to
    the estimate's error, ``eps+ = A eps - Re{Be C e^{j theta_k}}``, ``e = Cy eps - Re{De C
    e^{j theta_k}}`` (the true excitation drops out of this homogeneous map), demodulated over
    the revolution, and ``C <- A_C C + B_C E`` by the law on ``disturbance`` (the model's
    ``H``). State ``[eps; acc_re; acc_im; C_re; C_im]``, in the block's order per sample; an
    exact model is assumed (the block's prediction removes the internal loop's own response)."""
    T = loop.sample_period_s
    P = samples_per_revolution(speed_rad_s, T)
    lwi = lwi or loop.with_inputs(speed_rad_s, w_F, [], sensors)
    Nt, M, ne = lwi.A.shape[0], len(sensors), lwi.Be.shape[1]
    xs, ar, ai, cs = (slice(0, Nt), slice(Nt, Nt + M), slice(Nt + M, Nt + 2 * M),
                      slice(Nt + 2 * M, Nt + 2 * M + 2 * ne))
    A_C, B_C = update_matrices(disturbance, law, gain, effort_weight=effort_weight,
                               leakage=leakage, sensor_weights=sensor_weights)
    upd_c, upd_acc = _real(A_C), _real(B_C) * 2.0 / (P * speed_rad_s * T)
    w = speed_rad_s * T
    Br, Bi, Dr, Di = lwi.Be.real, lwi.Be.imag, lwi.De.real, lwi.De.imag
    Phi = np.eye(Nt + 2 * M + 2 * ne)
    for k in range(P):
        c, s = np.cos(speed_rad_s * T * k), np.sin(speed_rad_s * T * k)
        # Re{Q C e^{j theta}} = [Qr c - Qi s, -Qr s - Qi c] [C_re; C_im]
        Jx = -np.hstack([Br * c - Bi * s, -Br * s - Bi * c])
        Je = -np.hstack([Dr * c - Di * s, -Dr * s - Di * c])
        e = lwi.C @ Phi[xs] + Je @ Phi[cs]
        Phi[ar] += w * c * e
        Phi[ai] -= w * s * e
        Phi[xs] = lwi.A @ Phi[xs] + Jx @ Phi[cs]
        if k == P - 1:
            Phi[cs] = upd_c @ Phi[cs] + upd_acc @ np.vstack([Phi[ar], Phi[ai]])
            Phi[ar] = 0.0
            Phi[ai] = 0.0
    z = scipy.linalg.eigvals(Phi)
    idx = np.argsort(np.abs(z - 1.0))[:lwi.n_drift]
    idx = idx[np.abs(z[idx] - 1.0) <= HELD_TOL ** 0.5]
    keep = np.ones(z.size, bool)
    keep[idx] = False
    return SampledPoles(float(speed_rad_s), float(w_F), P * T, z[keep], z[idx])


@dataclass(frozen=True)
class RobustnessMap:
    """Spectral radius per (phase error, magnitude factor, gain): quasi-steady (laws only) and,
    where computed, of the exact one-revolution map (NaN elsewhere)."""

    law: str
    phase_error_deg: np.ndarray
    magnitude_factor: np.ndarray
    gain: np.ndarray
    quasi_steady: np.ndarray          # (phase, magnitude, gain)
    exact: np.ndarray

    def converges(self, which: str = "quasi_steady") -> np.ndarray:
        return getattr(self, which) < 1.0

    def phase_limit_deg(self, which: str = "quasi_steady") -> np.ndarray:
        """Per (magnitude, gain): the largest |phase error| up to which every grid point
        converges (NaN if even zero error diverges)."""
        ok = self.converges(which)
        ph = np.abs(self.phase_error_deg)
        out = np.full(ok.shape[1:], np.nan)
        for i in np.ndindex(*ok.shape[1:]):
            bad = ph[~ok[(slice(None),) + i]]
            good = ph[ok[(slice(None),) + i]]
            if good.size and 0.0 in good:
                out[i] = good[good < bad.min()].max() if bad.size else good.max()
        return out


def robustness_map(G_true: np.ndarray, law: str, phase_error_deg, magnitude_factor, gain, *,
                   effort_weight: float = 0.0, leakage: float = 0.0, exact=None
                   ) -> RobustnessMap:
    """Convergence over estimate errors ``G^ = m e^{j phi} G`` and gains; ``exact``: optional
    ``(phase_index, magnitude_index, gain_index) -> max |z|`` of the one-revolution map
    (:func:`harmonic_poles`) evaluated at chosen points."""
    ph, mg, gn = (np.atleast_1d(np.asarray(v, dtype=float)) for v in
                  (phase_error_deg, magnitude_factor, gain))
    qs = np.zeros((ph.size, mg.size, gn.size))
    ex = np.full(qs.shape, np.nan)
    for i, phi in enumerate(ph):
        for j, m in enumerate(mg):
            est = G_true * m * np.exp(1j * np.deg2rad(phi))
            for k, g in enumerate(gn):
                A_U, B = update_matrices(est, law, g, effort_weight=effort_weight,
                                         leakage=leakage)
                qs[i, j, k] = convergence_radius(A_U, B, G_true)
    for (i, j, k), value in (exact or {}).items():
        ex[i, j, k] = value
    return RobustnessMap(law, ph, mg, gn, qs, ex)


def gain_schedule(loop: SampledLoop, schedule, settings, speeds_rad_s, candidates, w_F=None,
                  excitation_loop: bool = False) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Per speed (moved to the nearest whole number of samples per revolution) the largest
    candidate gain whose one-revolution map contracts within 0.1 % of the best candidate's
    (the plant's own slow modes bound every candidate alike) and by at least 0.1 % per
    revolution; else the smallest candidate; ``(speeds, gains)``. ``excitation_loop``: the map
    of the dynamic feed-forward's estimate (:func:`excitation_loop_poles`) instead of the
    phasors' (:func:`harmonic_poles`)."""
    T = loop.sample_period_s
    kw = dict(effort_weight=settings.effort_weight, leakage=settings.leakage,
              sensor_weights=settings.sensor_weights)
    out_s, out_g = [], []
    for speed in speeds_rad_s:
        P = max(int(round(2 * np.pi / (speed * T))), 3)
        w = 2 * np.pi / (P * T)
        wf = w if w_F is None else w_F
        if excitation_loop:
            lwi = loop.with_inputs(w, wf, [], schedule.sensors)
            radii = [excitation_loop_poles(loop, w, wf, schedule.sensors,
                                           schedule.disturbance_at(w), settings.law, g,
                                           lwi=lwi, **kw).max_abs_z for g in candidates]
        else:
            lwi = loop.with_inputs(w, wf, schedule.actuators, schedule.sensors)
            radii = [harmonic_poles(loop, w, wf, schedule.actuators, schedule.sensors,
                                    schedule.harmonics, schedule.at(w), settings.law, g,
                                    update_every_samples=0, lwi=lwi, **kw).max_abs_z
                     for g in candidates]
        best = min(radii)
        ok = [g for g, r in zip(candidates, radii) if r <= min(best + 1e-3, 1 - 1e-3)]
        out_s.append(w)
        out_g.append(max(ok) if ok else min(candidates))
    return tuple(out_s), tuple(out_g)


def stable_gain_limit(radius, nominal: float, max_factor: float = 100.0, rtol: float = 0.02
                      ) -> float:
    """Gain margin: the factor on the ``nominal`` gain up to which ``radius(gain) < 1`` holds
    continuously from the nominal (log-grid scan, then bisection); 0 if unstable at nominal,
    ``inf`` if stable up to ``max_factor``."""
    if radius(nominal) >= 1.0:
        return 0.0
    grid = nominal * np.geomspace(1.0, max_factor, 13)
    lo = grid[0]
    for g in grid[1:]:
        if radius(g) >= 1.0:
            hi = g
            break
        lo = g
    else:
        return float("inf")
    while hi / lo - 1.0 > rtol:
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if radius(mid) < 1.0 else (lo, mid)
    return float(np.sqrt(lo * hi) / nominal)
