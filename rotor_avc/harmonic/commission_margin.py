"""The margin checked before commissioned harmonic control adapts (:mod:`.commission`).

Margin (:func:`phase_margin`): per speed and harmonic, the largest phase error of the written
table that the adaptation tolerates -- the smaller of the quasi-steady limit with the identified
matrix as the machine (:func:`rotor_avc.harmonic.lti.robustness_map`; ``acos(mu / 2)`` for the
Newton law on an exact table) and the limit of the exact one-revolution map
(:func:`rotor_avc.harmonic.lti.harmonic_poles`) on the controller's model loop. The model only
supplies the loop's dynamics there: with the table exact for the machine, a model whose
influence is ``G_m`` stands for it through the input transform ``K = pinv(G_m) G_id`` (for the
Newton law and ``G_id`` of full row rank, ``K pinv(G_id) = pinv(G_m)``: the map equals the
model loop's with its own influence as the estimate), rotated by the phase error.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .influence import model_schedule
from .lti import harmonic_poles, robustness_map, samples_per_revolution

TWO_PI = 2 * math.pi
#: phase errors of the quasi-steady limit (deg) and bisection steps of the exact one
PHASES_DEG = np.arange(-180.0, 180.5, 0.5)
BISECTIONS = 8


@dataclass(frozen=True)
class Margin:
    """Phase margins (deg) per harmonic: quasi-steady with the identified matrix, of the exact
    one-revolution map (and its spectral radius with the table exact), at ``speed_rad_s``."""

    speed_rad_s: float
    quasi_steady_deg: tuple[float, ...]
    exact_deg: float
    radius: float
    model: np.ndarray                   # (H, M, N): the model's influence at that speed

    @property
    def phase_margin_deg(self) -> float:
        return float(min(min(self.quasi_steady_deg), self.exact_deg))


def phase_margin(loop, speed_rad_s: float, w_F: float | None, actuators, sensors, harmonics,
                 identified: np.ndarray, law: str, gain: float, *, effort_weight: float = 0.0,
                 leakage: float = 0.0, sensor_weights=None) -> Margin:
    """:class:`Margin` at the speed moved to a whole number of samples per revolution (the map
    needs it; module docstring); ``loop`` the controller's model loop."""
    T = loop.sample_period_s
    w = TWO_PI / (max(int(round(TWO_PI / (speed_rad_s * T))), 3) * T)
    samples_per_revolution(w, T)
    wf = w if w_F is None else w_F
    qs = []
    for G in identified:
        if np.linalg.matrix_rank(G) < min(G.shape):
            qs.append(0.0)
            continue
        limit = robustness_map(G, law, PHASES_DEG, [1.0], [gain], effort_weight=effort_weight,
                               leakage=leakage).phase_limit_deg()[0, 0]
        qs.append(0.0 if np.isnan(limit) else float(limit))
    model = model_schedule(loop, sensors, actuators, harmonics, [w], wf).matrices[0]
    lwi = loop.with_inputs(w, wf, actuators, sensors)

    def radius(phase_deg: float) -> float:
        est = model * np.exp(1j * np.deg2rad(phase_deg))
        return harmonic_poles(loop, w, wf, actuators, sensors, harmonics, est, law, gain,
                              effort_weight=effort_weight, leakage=leakage,
                              sensor_weights=sensor_weights, lwi=lwi).max_abs_z

    r0 = radius(0.0)
    exact = 0.0 if r0 >= 1.0 else min(_stable_phase(radius, sign, max(qs))
                                      for sign in (1.0, -1.0))
    return Margin(w, tuple(qs), exact, r0, model)


def _stable_phase(radius, sign: float, top: float) -> float:
    """The largest phase error in ``[0, top]`` (one sign) up to which ``radius < 1`` (bisection
    from a stable zero)."""
    if top <= 0 or radius(sign * top) < 1.0:
        return top
    lo, hi = 0.0, top
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if radius(sign * mid) < 1.0 else (lo, mid)
    return lo
