"""Closed-loop poles, damping ratios and the worst-case pole procedure (Werner 2021 Figure 4).

Loss-factor damping ``d = c tan(delta) / w_F`` makes the pole equation (43) depend on the unknown
whirl frequency. The paper's worst case damps every mode with ``w_F`` = the frequency of the
``n_modes``-th (highest relevant) mode, found by a fixed-point iteration:

1. undamped open loop (D = 0, T = 0, G(Omega) included): ``w_F = Im`` of the n-th pole pair
   (pairs with Im > 0, ascending);
2. closed loop with ``D = D_eta / w_F``: new ``w_F`` = Im of its n-th pair; repeat until the
   relative change is <= ``tol`` (5 %), then recompute once with the last ``w_F``;
3. stable <=> max Re(s) < 0.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from ..errors import ModelError
from ..closed_loop.loop import ClosedLoop
from .whirl_iteration import per_mode_poles


@dataclass
class PoleResult:
    """Poles of a closed loop at one speed, with the damping frequency used."""

    speed_rad_s: float
    w_F: float
    poles: np.ndarray
    history: list[float] = field(default_factory=list)
    #: per-pole damping frequency where the procedure damps every mode on its own (else None:
    #: every pole at ``w_F``)
    mode_w_F: np.ndarray | None = None

    @property
    def stable(self) -> bool:
        return bool(np.max(self.poles.real) < 0.0)

    @property
    def max_real(self) -> float:
        return float(np.max(self.poles.real))

    def table(self) -> list[dict]:
        """One row per pole with Im >= 0 (one of each conjugate pair), ascending frequency."""
        return pole_table(self.poles)


def pole_table(poles: np.ndarray) -> list[dict]:
    scale = max(np.abs(poles).max(), 1.0)
    upper = poles[poles.imag >= -1e-9 * scale]
    upper = upper[np.lexsort((upper.real, np.abs(upper.imag)))]
    rows = []
    for p in upper:
        mag = abs(p)
        rows.append({"re": float(p.real), "im": float(abs(p.imag)),
                     "freq_hz": float(abs(p.imag) / (2 * np.pi)),
                     "damping_ratio": float(-p.real / mag) if mag > 0 else 0.0})
    return rows


def closed_loop_poles(loop: ClosedLoop, speed_rad_s: float, w_F: float) -> np.ndarray:
    """Eigenvalues of the closed-loop state matrix at one speed and damping frequency."""
    A, _ = loop.state_space(speed_rad_s, w_F)
    return scipy.linalg.eigvals(A)


def _nth_pair(poles: np.ndarray, n_modes: int) -> float:
    scale = max(np.abs(poles).max(), 1.0)
    freqs = np.sort(poles.imag[poles.imag > 1e-9 * scale])
    if freqs.size < n_modes:
        raise ModelError(f"the worst-case procedure needs {n_modes} oscillating modes, the model "
                         f"has {freqs.size} -- lower analysis.worst_case.n_modes")
    return float(freqs[n_modes - 1])


def undamped_poles(loop: ClosedLoop, speed_rad_s: float) -> np.ndarray:
    """Open-loop poles without damping (gyroscopic terms kept): step 1 of Figure 4."""
    p = loop.plant
    n = p.n
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -np.linalg.solve(p.mass, p.stiffness)
    A[n:, n:] = -np.linalg.solve(p.mass, speed_rad_s * p.gyroscopic)
    return scipy.linalg.eigvals(A)


def worst_case_poles(loop: ClosedLoop, speed_rad_s: float, n_modes: int = 6, tol: float = 0.05,
                     max_iter: int = 20) -> PoleResult:
    """The paper's worst-case pole procedure (Figure 4); see the module docstring."""
    w_F = _nth_pair(undamped_poles(loop, speed_rad_s), n_modes)
    history = [w_F]
    for _ in range(max_iter):
        poles = closed_loop_poles(loop, speed_rad_s, w_F)
        w_new = _nth_pair(poles, n_modes)
        history.append(w_new)
        if abs(w_new - w_F) <= tol * w_F:
            return PoleResult(speed_rad_s, w_new, closed_loop_poles(loop, speed_rad_s, w_new), history)
        w_F = w_new
    raise ModelError(f"worst-case pole iteration did not settle within {max_iter} steps "
                     f"(w_F history {np.round(history, 2).tolist()} rad/s) -- raise "
                     "analysis.worst_case.max_iter or check the model")


def _worst_case_from_config(machine, speed_rad_s: float) -> PoleResult:
    wc = machine.analysis.worst_case
    return worst_case_poles(machine.loop, speed_rad_s, n_modes=wc.n_modes,
                            tol=wc.rel_change_tol, max_iter=wc.max_iter)


def whirl_iteration_poles(machine, speed_rad_s: float) -> PoleResult:
    """``analysis.pole_method: whirl_iteration``: every mode damped at its own whirl frequency
    (:func:`~rotor_avc.analysis.whirl_iteration.per_mode_poles`, Werner 2019 Sec. 3.3); ``w_F``
    and the one-entry history are the least damped pole's."""
    res = per_mode_poles(machine.loop, speed_rad_s, rel_tol=machine.analysis.whirl_iteration.rel_tol)
    w_F = float(res.w_F[res.critical])
    return PoleResult(speed_rad_s, w_F, res.poles, [w_F], mode_w_F=res.w_F)


#: ``analysis.pole_method`` (rotor_avc.settings.POLE_METHODS) -> ``f(machine, speed_rad_s) ->
#: PoleResult``; each plant's config names the damping procedure of its paper (Werner 2021:
#: Figure 4's worst case).
POLE_METHODS = {
    "worst_case": _worst_case_from_config,
    "whirl_iteration": whirl_iteration_poles,    # Werner 2019
}


def machine_poles(machine, speed_rad_s: float) -> PoleResult:
    """Poles of a configured machine with the damping procedure its config names."""
    return POLE_METHODS[machine.analysis.pole_method](machine, speed_rad_s)
