"""Closed-form run-up response of one mode at constant angular acceleration (Zhou & Shi 2001 App. A).

Paper eq. (A1) per unit imbalance, zero initial state, spin from rest ``phi = alpha t^2 / 2 +
omega0 t`` (``omega0`` generalises the paper's start from rest)::

    x'' + 2 zeta w_n x' + w_n^2 x = (omega^2 - i alpha) e^{i phi},   omega = phi'

The paper gives (A5)-(A7) only in outline (constants C1-C10 unstated). An explicit equivalent,
derived here with the roots ``l in {a0, b0} = -zeta w_n +- i w_d`` and ``(omega^2 - i alpha)
e^{i phi} = -i d/dt(omega e^{i phi})`` (two integrations by parts)::

    x = i omega0 h(t) - e^{i phi} + h'(t) - [a0^2 E_a0(t) - b0^2 E_b0(t)] / (a0 - b0)
    h(t) = (e^{a0 t} - e^{b0 t}) / (a0 - b0)            (impulse response)
    E_l(t) = int_0^t e^{i phi(tau) + l (t - tau)} dtau
           = -(sqrt(pi) / 2 kappa) [e^{i phi} e^{s^2} erfc(s) - e^{l t} e^{s0^2} erfc(s0)]
    kappa = e^{-i pi/4} sqrt(alpha / 2),   s_l(t) = kappa (t + (omega0 + i l) / alpha)

``e^{s^2} erfc(s)`` is evaluated as the Faddeeva function ``w(i s)`` when ``Re s >= 0`` and as
``2 e^{s^2} - w(-i s)`` otherwise; the ``2 e^{s^2}`` branch term is the *suddenly occurring*
free vibration (A7), present once ``Re s_a0`` turns positive at ``t_K``
(= ``w_n (zeta + sqrt(1 - zeta^2)) / alpha`` from rest), the paper's K jump. The three parts:

* synchronous (A6): ``e^{i phi}`` times a slowly varying amplitude, ``M_s = |x_s|``;
* suddenly occurring (A7): a free vibration at ``w_d`` starting at ``t_K``, ``M_n = |x_n|``;
* transient (A5): the free vibration fixed by the initial state (tiny; the paper drops it).

``M_k = M_s + M_n`` is the amplification of paper eqs. (6) and (8).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import wofz

from ..errors import ModelError

SQRT_PI = np.sqrt(np.pi)


@dataclass
class RunupParts:
    """Unit-imbalance response ``x = synchronous + sudden + transient`` and ``x'`` at times ``t``."""

    t: np.ndarray
    synchronous: np.ndarray
    sudden: np.ndarray
    transient: np.ndarray
    velocity: np.ndarray

    @property
    def total(self) -> np.ndarray:
        return self.synchronous + self.sudden + self.transient

    @property
    def M_s(self) -> np.ndarray:
        return np.abs(self.synchronous)

    @property
    def M_n(self) -> np.ndarray:
        return np.abs(self.sudden)

    @property
    def M(self) -> np.ndarray:
        """``M_k = M_sk + M_nk`` (paper eq. 8)."""
        return self.M_s + self.M_n


def _check(omega_n, zeta, alpha, omega0):
    if not (np.isfinite(omega_n) and omega_n > 0):
        raise ModelError(f"natural frequency must be > 0 (got {omega_n})")
    if not (np.isfinite(zeta) and 0 <= zeta < 1):
        raise ModelError(f"damping ratio must be in [0, 1) (got {zeta}): the closed form of "
                         "Appendix A is for an underdamped mode")
    if not (np.isfinite(alpha) and alpha > 0):
        raise ModelError(f"angular acceleration must be > 0 (got {alpha}): the run-up response "
                         "of Appendix A needs a constant acceleration; use the steady-state "
                         "FRF (rotor_avc.closed_loop.frf) at constant speed")
    if not (np.isfinite(omega0) and omega0 >= 0):
        raise ModelError(f"initial speed must be >= 0 (got {omega0})")


def sudden_onset_time(omega_n: float, zeta: float, alpha: float, omega0: float = 0.0) -> float:
    """``t_K``: the instant the suddenly occurring vibration appears (``Re s_a0 = 0``)."""
    _check(omega_n, zeta, alpha, omega0)
    return (omega_n * (zeta + np.sqrt(1 - zeta**2)) - omega0) / alpha


def _branch(s):
    """``(sign, w(i sigma))`` with ``sigma = sign * s`` in the closed right half plane."""
    sign = np.where(s.real >= 0, 1.0, -1.0)
    return sign, wofz(1j * sign * s)


def runup_response(t, omega_n: float, zeta: float, alpha: float,
                   omega0: float = 0.0) -> RunupParts:
    """Closed-form response of eq. (A1) per unit imbalance at times ``t`` (>= 0), in three parts.

    ``omega0`` is the speed at ``t = 0`` (the paper starts from rest). Exact up to rounding
    (checked against numerical integration in the tests)."""
    _check(omega_n, zeta, alpha, omega0)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if np.any(~np.isfinite(t)) or np.any(t < 0):
        raise ModelError("run-up times must be finite and >= 0")
    w_d = omega_n * np.sqrt(1 - zeta**2)
    a0, b0 = -zeta * omega_n + 1j * w_d, -zeta * omega_n - 1j * w_d
    kappa = np.exp(-1j * np.pi / 4) * np.sqrt(alpha / 2)
    pre = SQRT_PI / (2 * kappa)
    omega = omega0 + alpha * t
    phase = np.exp(1j * (omega0 * t + alpha * t**2 / 2))
    h = (np.exp(a0 * t) - np.exp(b0 * t)) / (a0 - b0)           # impulse response
    dh = (a0 * np.exp(a0 * t) - b0 * np.exp(b0 * t)) / (a0 - b0)
    d2h = (a0**2 * np.exp(a0 * t) - b0**2 * np.exp(b0 * t)) / (a0 - b0)
    # x = i omega0 h - e^{i phi} + h' - sum_l c_l E_l   (two integrations by parts)
    sync, dsync = -phase, -1j * omega * phase
    sudden = np.zeros(t.shape, complex)
    dsudden = np.zeros(t.shape, complex)
    trans, dtrans = 1j * omega0 * h + dh, 1j * omega0 * dh + d2h
    for lam, c in ((a0, a0**2 / (a0 - b0)), (b0, -b0**2 / (a0 - b0))):
        shift = (omega0 + 1j * lam) / alpha
        s, s0 = kappa * (t + shift), kappa * shift
        sign, w_t = _branch(s)
        sign0, w_0 = _branch(np.asarray(s0))
        # e^{i phi} e^{s^2} = e^{l t + s0^2}: one exponent, so neither factor overflows
        branch = 2 * pre * np.exp(lam * t + s0**2)
        S = -sign * pre * phase * w_t                                   # E_l, synchronous
        N = branch * (float(sign0 < 0) - (sign < 0))                    # E_l, sudden (K jump)
        Tr = sign0 * pre * w_0 * np.exp(lam * t)                        # E_l, initial state
        sync -= c * S
        sudden -= c * N
        trans -= c * Tr
        dsync -= c * (phase + lam * S)                                  # E_l' = e^{i phi} + l E_l
        dsudden -= c * lam * N
        dtrans -= c * lam * Tr
    return RunupParts(t, sync, sudden, trans, dsync + dsudden + dtrans)


def modal_magnitudes(t, omega_n: float, zeta: float, alpha: float, omega0: float = 0.0):
    """``(M_s, M_n, M)`` of paper eq. (6)/(8) for one mode, per unit imbalance."""
    parts = runup_response(t, omega_n, zeta, alpha, omega0)
    return parts.M_s, parts.M_n, parts.M
