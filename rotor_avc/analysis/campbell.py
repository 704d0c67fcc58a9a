"""Campbell diagram: damped natural frequencies and damping of every mode over rotor speed.

At each speed ``Omega`` of the grid the poles are those of a damping rule (:data:`DAMPING_RULES`;
by default the config's own pole procedure, so the diagram agrees with ``rotor-avc poles`` at
every grid speed). Loss-factor damping makes the state matrix depend on the damping frequency
``w_F``; every pole is returned with the ``w_F`` it was computed at, and its right eigenvector is
that of ``A(Omega; w_F)``.

Modes are followed from one speed to the next by eigenvector similarity, the modal assurance
criterion ``MAC(u, v) = |u^H v|^2 / (|u|^2 |v|^2)`` (Allemang 2003), not by sorting frequencies:
where two modes of different shape cross, each keeps its identity. The assignment between
neighbouring speeds minimises ``sum (1 - MAC) + |lambda_a - lambda_b| / max(|lambda_a|,
|lambda_b|, 1)`` (the eigenvalue distance separates the two members of a conjugate pair, whose
shapes can be alike, and the modes of a degenerate pair).

Derived quantities (``f`` in Hz, ``s`` the rotor speed in Hz):

* damping ratio ``zeta = -Re lambda / |lambda|``; logarithmic decrement
  ``Lambda = -2 pi Re lambda / |Im lambda|`` (API 684 uses the log decrement);
* critical speeds of order ``k``: where a mode's damped natural frequency meets the excitation
  line ``f = k s`` (linear interpolation between grid speeds);
* onset of instability: where a mode's real part crosses zero from below (interpolated).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.optimize

from ..errors import ModelError
from ..closed_loop.loop import ClosedLoop
from .poles import POLE_METHODS, PoleResult, closed_loop_poles, machine_poles
from .sampled_loop import machine_sampled_loop
from .stability_threshold import SampledEigenvalues


def _forced_poles(machine, speed_rad_s: float) -> PoleResult:
    w_F = float(machine.plant.forced_damping_frequency(speed_rad_s))
    return PoleResult(speed_rad_s, w_F, closed_loop_poles(machine.loop, speed_rad_s, w_F), [w_F])


#: ``--damping`` rule -> ``f(machine, speed_rad_s) -> PoleResult``: ``config`` is the config's
#: ``analysis.pole_method`` (what ``rotor-avc poles`` prints); ``forced`` damps every mode at
#: ``w_F = max(Omega, floor)`` (the forced-response convention); the others name a pole method.
DAMPING_RULES: dict[str, Callable] = {"config": machine_poles, "forced": _forced_poles,
                                      **POLE_METHODS}


@dataclass
class CampbellDiagram:
    """Tracked modes over speed: column ``k`` of ``poles`` follows one mode (``Im >= 0`` at the
    first speed; ordered by frequency there and labelled with it, e.g. ``mode 3 (15.96 Hz)``)."""

    speed_rad_s: np.ndarray
    poles: np.ndarray                       # (speeds, modes), 1/s
    labels: list[str]

    @property
    def speed_hz(self) -> np.ndarray:
        return self.speed_rad_s / (2 * np.pi)

    @property
    def freq_hz(self) -> np.ndarray:
        return np.abs(self.poles.imag) / (2 * np.pi)

    @property
    def damping_ratio(self) -> np.ndarray:
        mag = np.abs(self.poles)
        return np.divide(-self.poles.real, mag, out=np.zeros(mag.shape), where=mag > 0)

    @property
    def log_decrement(self) -> np.ndarray:
        """``-2 pi Re / |Im|``; ``inf`` for non-oscillating poles."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(np.abs(self.poles.imag) > 0,
                            -2 * np.pi * self.poles.real / np.abs(self.poles.imag), np.inf)

    def critical_speeds(self, orders=(1, 2)) -> list[dict]:
        """Where mode frequency ``f_k(s)`` meets ``order * s`` -> rows ``{"mode", "order",
        "speed_hz"}`` sorted by speed (oscillating modes only)."""
        s, f = self.speed_hz, self.freq_hz
        rows = []
        for order in orders:
            for k, label in enumerate(self.labels):
                rows += [{"mode": label, "order": int(order), "speed_hz": x}
                         for x in _crossings(s, f[:, k] - order * s, f[:, k] > 0)]
        return sorted(rows, key=lambda r: (r["speed_hz"], r["order"]))

    def instability_onsets(self) -> list[dict]:
        """Where a mode's real part rises through zero -> rows ``{"mode", "speed_hz",
        "freq_hz"}`` sorted by speed."""
        s = self.speed_hz
        rows = []
        for k, label in enumerate(self.labels):
            re = self.poles[:, k].real
            for x in _crossings(s, re, np.ones(s.shape, bool), rising_only=True):
                rows.append({"mode": label, "speed_hz": x,
                             "freq_hz": float(np.interp(x, s, self.freq_hz[:, k]))})
        return sorted(rows, key=lambda r: r["speed_hz"])

    def to_json(self, orders=(1, 2)) -> dict:
        return {"speed_hz": self.speed_hz.tolist(),
                "modes": [{"label": label, "freq_hz": self.freq_hz[:, k].tolist(),
                           "damping_ratio": self.damping_ratio[:, k].tolist()}
                          for k, label in enumerate(self.labels)],
                "critical_speeds": self.critical_speeds(orders)}


def _crossings(x: np.ndarray, g: np.ndarray, valid: np.ndarray, rising_only=False) -> list[float]:
    """Interpolated ``x`` where ``g`` changes sign between neighbouring valid points."""
    a, b = g[:-1], g[1:]
    up = (a < 0) & (b >= 0)
    hit = up if rising_only else up | ((a > 0) & (b <= 0))
    hit &= valid[:-1] & valid[1:]
    i = np.flatnonzero(hit)
    return [float(x[j] + (x[j + 1] - x[j]) * a[j] / (a[j] - b[j])) for j in i]


def mode_vectors(loop: ClosedLoop, speed_rad_s: float, poles: np.ndarray,
                 w_F: np.ndarray) -> np.ndarray:
    """Right eigenvectors (columns, unit norm) of ``A(Omega; w_F[k])`` for each pole ``k``: the
    eigenvector of the eigenvalue nearest to the pole (one-to-one within each ``w_F``)."""
    vectors = None
    for w in np.unique(w_F):
        idx = np.flatnonzero(w_F == w)
        lam, vec = np.linalg.eig(loop.state_space(speed_rad_s, float(w))[0])
        if vectors is None:
            vectors = np.empty((vec.shape[0], poles.size), complex)
        rows, cols = scipy.optimize.linear_sum_assignment(np.abs(poles[idx][:, None] - lam[None, :]))
        vectors[:, idx[rows]] = vec[:, cols]
    return vectors / np.linalg.norm(vectors, axis=0)


def tracking_cost(lam_a, vec_a, lam_b, vec_b) -> np.ndarray:
    """``(1 - MAC) + relative eigenvalue distance`` between every mode of ``a`` and of ``b``
    (unit-norm eigenvectors as columns)."""
    mac = np.abs(vec_a.conj().T @ vec_b) ** 2
    scale = np.maximum(np.maximum(np.abs(lam_a)[:, None], np.abs(lam_b)[None, :]), 1.0)
    return (1.0 - mac) + np.abs(lam_a[:, None] - lam_b[None, :]) / scale


def sampled_poles(machine):
    """``f(speed, PoleResult) -> (poles, eigenvectors)``: the equivalent continuous poles
    ``s = ln(z) / T`` of the machine's sampled loop (its digital controllers, DESIGN.md 3) at the
    rule's damping frequency ``w_F`` (the least damped pole's for per-mode rules); frequencies
    are unique below the Nyquist frequency only."""
    loop = machine_sampled_loop(machine)

    def poles(speed: float, res: PoleResult):
        lam, vec = SampledEigenvalues(loop, res.w_F).eig(speed)
        return lam, vec / np.linalg.norm(vec, axis=0)
    return poles


def campbell_diagram(machine, speeds_rad_s, rule: str = "config",
                     sampled: bool = False) -> CampbellDiagram:
    """Poles of ``machine`` (its ``loop``, or with ``sampled`` its sampled loop: see
    :func:`sampled_poles`) over a speed grid with a damping rule, tracked by eigenvector
    similarity (see the module docstring)."""
    if rule not in DAMPING_RULES:
        raise ModelError(f"unknown damping rule {rule!r}; known: {', '.join(DAMPING_RULES)}")
    speeds = np.asarray(speeds_rad_s, dtype=float)
    if speeds.ndim != 1 or speeds.size < 2 or np.any(np.diff(speeds) <= 0) or speeds[0] < 0:
        raise ModelError("Campbell speeds must be an increasing grid of >= 2 speeds >= 0")
    poles_at = DAMPING_RULES[rule]
    discrete = sampled_poles(machine) if sampled else None
    tracked, prev = [], None
    for speed in speeds:
        res = poles_at(machine, float(speed))
        if discrete is not None:
            lam, vec = discrete(float(speed), res)
        else:
            w_F = res.mode_w_F if res.mode_w_F is not None else np.full(res.poles.size, res.w_F)
            lam, vec = res.poles, mode_vectors(machine.loop, float(speed), res.poles, w_F)
        if prev is not None:
            if lam.size != prev[0].size:
                raise ModelError(f"the number of poles changes at {speed / (2 * np.pi):.6g} Hz "
                                 f"({prev[0].size} -> {lam.size}); cannot track the modes")
            _, cols = scipy.optimize.linear_sum_assignment(tracking_cost(*prev, lam, vec))
            lam, vec = lam[cols], vec[:, cols]
        tracked.append(lam)
        prev = (lam, vec)
    poles = np.array(tracked)
    scale = max(np.abs(poles[0]).max(), 1.0)
    keep = np.flatnonzero(poles[0].imag >= -1e-9 * scale)
    keep = keep[np.lexsort((poles[0, keep].real, np.abs(poles[0, keep].imag)))]
    f0 = np.abs(poles[0, keep].imag) / (2 * np.pi)
    labels = [f"mode {k + 1} ({f:.4g} Hz)" if f > 0 else f"mode {k + 1} (non-oscillating)"
              for k, f in enumerate(f0)]
    return CampbellDiagram(speeds, poles[:, keep], labels)
