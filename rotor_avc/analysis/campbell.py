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
* onset of instability: where a mode's real part crosses zero from below (interpolated);
* whirl direction and mode shape of every mode at every speed from the generalised-coordinate
  part of its eigenvector (:mod:`rotor_avc.analysis.mode_shapes`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.optimize

from ..errors import ModelError
from ..closed_loop.loop import ClosedLoop
from .mode_shapes import RotorGeometry, shape_rows, whirl_name
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


def damping_rule_text(machine, rule: str, sampled: bool = False) -> str:
    """What damping frequency ``w_F`` the poles of ``rule`` are computed with (DESIGN.md 2)."""
    if rule == "config":
        return damping_rule_text(machine, machine.analysis.pole_method, sampled) \
            + " (the config's analysis.pole_method)"
    if rule == "forced":
        text = (f"w_F = max(Omega, {machine.analysis.damping_floor_hz:g} Hz) for every mode "
                "(forced-response convention, analysis.damping_floor_hz)")
    elif rule == "worst_case":
        n_modes = machine.analysis.worst_case.n_modes
        text = (f"w_F = the whirl frequency of mode {n_modes} for every mode (worst case, "
                "Werner 2021 Fig. 4)")
    else:
        text = ("w_F = each mode's own whirl frequency (per-mode iteration, Werner 2019 Sec. 3.3)"
                + ("; the sampled loop at the least damped pole's" if sampled else ""))
    return text


@dataclass
class CampbellDiagram:
    """Tracked modes over speed: column ``k`` of ``poles`` follows one mode (``Im >= 0`` at the
    first speed; ordered by frequency there and labelled with it, e.g. ``mode 3 (15.96 Hz)``);
    ``shapes[i, :, k]`` is its generalised-coordinate eigenvector at speed ``i``."""

    speed_rad_s: np.ndarray
    poles: np.ndarray                       # (speeds, modes), 1/s
    labels: list[str]
    shapes: np.ndarray                      # (speeds, coordinates, modes), complex
    geometry: RotorGeometry
    damping_rule: str = ""

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

    @property
    def ellipticity(self) -> np.ndarray:
        """Whirl ellipticity ``(|r_f| - |r_b|) / (|r_f| + |r_b|)`` of every mode at every speed
        (> 0 forward; ``nan``: no rotor motion): see :mod:`rotor_avc.analysis.mode_shapes`."""
        return np.array([self.geometry.ellipticity(v, p) for v, p in zip(self.shapes, self.poles)])

    def whirl(self, index: int) -> list[str]:
        """``forward`` / ``backward`` / ``none`` of every mode at speed ``index``."""
        ellipticity = self.geometry.ellipticity(self.shapes[index], self.poles[index])
        return [whirl_name(e) for e in ellipticity]

    def reference_index(self, speed_hz: float | None) -> int:
        """The grid speed nearest to ``speed_hz`` (None: the highest), where whirl and shape are
        reported."""
        return len(self.speed_hz) - 1 if speed_hz is None \
            else int(np.argmin(np.abs(self.speed_hz - speed_hz)))

    def caption(self, k: int, index: int) -> str:
        """``mode 3, 15.96 Hz, FW`` (frequency at the first speed, whirl at speed ``index``)."""
        whirl = {"forward": "FW", "backward": "BW", "none": "no whirl"}[self.whirl(index)[k]]
        return self.labels[k].replace(" (", ", ").rstrip(")") + f", {whirl}"

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

    def to_json(self, orders=(1, 2), reference_speed_hz: float | None = None) -> dict:
        """Speeds, modes (frequency and damping over speed; whirl and shape at the reference
        speed), critical speeds and the damping rule."""
        i = self.reference_index(reference_speed_hz)
        whirl = self.whirl(i)
        return {"speed_hz": self.speed_hz.tolist(),
                "modes": [{"label": label, "freq_hz": self.freq_hz[:, k].tolist(),
                           "damping_ratio": self.damping_ratio[:, k].tolist(),
                           "whirl": whirl[k],
                           "shape": shape_rows(self.shapes[i, :, k], self.geometry.coords)}
                          for k, label in enumerate(self.labels)],
                "critical_speeds": self.critical_speeds(orders),
                "reference_speed_hz": float(self.speed_hz[i]),
                "damping_rule": self.damping_rule}


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
        return SampledEigenvalues(loop, res.w_F).eig(speed)    # np.linalg.eig: unit-norm columns
    return poles


def campbell_diagram(machine, speeds_rad_s, rule: str = "config", sampled: bool = False,
                     rotor_pairs=None, progress=None) -> CampbellDiagram:
    """Poles of ``machine`` (its ``loop``, or with ``sampled`` its sampled loop: see
    :func:`sampled_poles`) over a speed grid with a damping rule, tracked by eigenvector
    similarity (see the module docstring). ``rotor_pairs``: the rotor's lateral coordinate
    names ``(a, b)``, spin from ``a`` towards ``b``, for the whirl direction (default: the
    model's, :data:`rotor_avc.analysis.mode_shapes.ROTOR_PAIRS`); ``progress``: called
    ``(speeds done, speeds)`` after each speed (None: quiet)."""
    if rule not in DAMPING_RULES:
        raise ModelError(f"unknown damping rule {rule!r}; known: {', '.join(DAMPING_RULES)}")
    speeds = np.asarray(speeds_rad_s, dtype=float)
    if speeds.ndim != 1 or speeds.size < 2 or np.any(np.diff(speeds) <= 0) or speeds[0] < 0:
        raise ModelError("Campbell speeds must be an increasing grid of >= 2 speeds >= 0")
    poles_at = DAMPING_RULES[rule]
    discrete = sampled_poles(machine) if sampled else None
    n = machine.plant.n
    tracked, vectors, prev = [], [], None
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
        vectors.append(vec[:n])
        prev = (lam, vec)
        if progress is not None:
            progress(len(tracked), speeds.size)
    poles = np.array(tracked)
    scale = max(np.abs(poles[0]).max(), 1.0)
    keep = np.flatnonzero(poles[0].imag >= -1e-9 * scale)
    keep = keep[np.lexsort((poles[0, keep].real, np.abs(poles[0, keep].imag)))]
    f0 = np.abs(poles[0, keep].imag) / (2 * np.pi)
    labels = [f"mode {k + 1} ({f:.4g} Hz)" if f > 0 else f"mode {k + 1} (non-oscillating)"
              for k, f in enumerate(f0)]
    geometry = RotorGeometry.of_machine(machine) if rotor_pairs is None else \
        RotorGeometry.named(machine.plant.coords, rotor_pairs, machine.config.raw("model", None))
    shapes = np.array([v[:, keep] for v in vectors])
    for i in range(len(speeds) - 1, -1, -1):          # repeated poles resolved from the top down
        shapes[i] = geometry.circular_basis(shapes[i], poles[i, keep],
                                            shapes[i + 1] if i + 1 < len(speeds) else None)
    return CampbellDiagram(speeds, poles[:, keep], labels, shapes, geometry,
                           damping_rule_text(machine, rule, sampled))
