"""Poles with frequency-dependent damping: the per-mode whirl-frequency iteration (Werner 2019
Sec. 3.3, eqs. 62-64).

Loss-factor damping ``d = c tan(delta) / w_F`` (eq. 1), the circulatory term ``d_i Omega`` and any
frequency-dependent coefficients of the plant (Werner 2019: the electromagnetic ``c_md(w_F)``,
``d_m(w_F)``) make the state matrix ``A(Omega; w_F)`` (eq. 62) depend on the whirl frequency of the
very mode one looks for. The paper iterates every mode on its own: start at ``w_F = Omega``, set
``w_F = |Im lambda_k|``, rebuild ``A``, take the eigenvalue nearest to ``lambda_k``, repeat. Its
result is the mode's fixed point ``|Im lambda_k(w_F)| = w_F``, which is found here robustly:

1. every eigenvalue of ``A(Omega; w_F)`` is followed as a branch ``lambda_k(w_F)`` over a geometric
   grid of ``w_F`` (one-to-one assignment of the eigenvalues of neighbouring grid points, so two
   modes never merge), from ``floor`` up to beyond every ``|lambda_k|``;
2. on each branch ``g_k(w_F) = max(|Im lambda_k|, floor) - w_F`` is bracketed on the grid and its
   root refined (Brent; the branch is followed by nearest eigenvalue inside the bracket). Plain
   substitution reaches the same point where it converges, but cycles where ``|Im lambda|`` falls
   steeply with ``w_F`` (near the slip resonance of Werner 2019's field damping) and can hop between
   near-degenerate modes. Where a branch has several fixed points -- a mode that a low ``w_F``
   overdamps (``c tan(delta) / w_F`` grows without bound) is also consistent at the floor or at a
   heavily damped low frequency -- the highest is taken: loss-factor damping describes a mode
   vibrating at that frequency, and the paper's start ``w_F = Omega`` can sit in the overdamped
   region of a mode far above the rotor speed;
3. stable <=> every converged ``Re lambda_k < 0``.

``floor`` is the plant's ``damping_floor_rad_s``: near-real eigenvalues are damped at it, because
loss-factor damping is undefined at ``w_F = 0`` (our choice; the paper leaves the iteration's
details to its ref. [20]). Works for any :class:`ClosedLoop` (controller states included in
``A``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize

from ..errors import ModelError
from ..closed_loop.loop import ClosedLoop

#: ratio of neighbouring points of the ``w_F`` grid over which the branches are followed
GRID_RATIO = 1.05
_MAX_GRID = 2000


@dataclass
class WhirlIteration:
    """Converged poles at one speed: ``poles[k]`` is a fixed point with damping at ``w_F[k]``
    (both conjugates of a pair carry the same ``w_F``)."""

    speed_rad_s: float
    poles: np.ndarray
    w_F: np.ndarray

    @property
    def critical(self) -> int:
        """Index of the least damped pole (largest real part)."""
        return int(np.argmax(self.poles.real))


def per_mode_poles(loop: ClosedLoop, speed_rad_s: float, rel_tol: float = 1e-6) -> WhirlIteration:
    """The per-mode whirl-frequency fixed points at one speed (see the module docstring)."""
    if not 0 < rel_tol < 0.1:
        raise ModelError(f"whirl iteration tolerance must be in (0, 0.1) (got {rel_tol})")
    floor = loop.plant.damping_floor_rad_s
    cache: dict[float, np.ndarray] = {}

    def eigenvalues(w_F: float) -> np.ndarray:
        if w_F not in cache:
            cache[w_F] = np.linalg.eigvals(loop.state_space(speed_rad_s, w_F)[0])
        return cache[w_F]

    # 1. branches over the grid, up to beyond every |lambda| (a bound of every whirl frequency)
    ws, branches = [floor], [eigenvalues(floor)]
    while np.abs(branches[-1]).max() * GRID_RATIO**2 >= ws[-1]:
        if len(ws) > _MAX_GRID:
            raise ModelError("whirl iteration: the eigenvalues' frequencies keep rising with the "
                             "damping frequency (no fixed point) -- check the model's damping")
        w = ws[-1] * GRID_RATIO
        ev = eigenvalues(w)
        rows, cols = scipy.optimize.linear_sum_assignment(
            np.abs(branches[-1][:, None] - ev[None, :]))
        branches.append(ev[cols[np.argsort(rows)]])
        ws.append(w)
    ws, lam = np.array(ws), np.array(branches)                # (G,), (G, N)
    g = np.maximum(np.abs(lam.imag), floor) - ws[:, None]
    scale = max(np.abs(lam[-1]).max(), 1.0)

    # 2. the root of each branch
    poles, w_out = [], []
    for k in range(lam.shape[1]):
        gk = g[:, k]
        brackets = np.flatnonzero((gk[:-1] > 0) & (gk[1:] <= 0) | (gk[:-1] == 0))
        if brackets.size == 0:
            raise ModelError(f"whirl iteration at {speed_rad_s:.6g} rad/s: the mode near "
                             f"{lam[-1, k]:.4g} 1/s has no consistent whirl frequency on the grid")
        i = int(brackets[-1])
        if gk[i] == 0:
            w_F, root = ws[i], lam[i, k]
        else:
            lo, hi, a, b = ws[i], ws[i + 1], lam[i, k], lam[i + 1, k]

            def follow(w):
                guess = a + (b - a) * (w - lo) / (hi - lo)
                ev = eigenvalues(float(w))
                return ev[np.argmin(np.abs(ev - guess))]

            w_F = scipy.optimize.brentq(lambda w: max(abs(follow(w).imag), floor) - w, lo, hi,
                                        xtol=rel_tol * lo * 1e-3, rtol=rel_tol)
            root = follow(w_F)
        if root.imag < -1e-9 * scale:
            continue                                          # the conjugate branch's twin
        pair = [root, np.conj(root)] if root.imag > 1e-9 * scale else [complex(root.real, 0.0)]
        poles += pair
        w_out += [float(w_F)] * len(pair)
    poles = np.array(poles)
    if poles.size != lam.shape[1]:
        raise ModelError(f"whirl iteration at {speed_rad_s:.6g} rad/s: the converged poles are not "
                         f"conjugate-symmetric ({poles.size} for {lam.shape[1]} states)")
    return WhirlIteration(float(speed_rad_s), poles, np.array(w_out))

