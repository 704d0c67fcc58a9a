"""The continuous closed loop of a plant with per-foot controllers G_c(s).

Each controlled actuator ``i`` applies ``f_i = -H_i(s) s_i^T q`` with ``H_i = s^k G_c,i``
(Werner 2021 eqs. 6-7, 15; the reconstructed eq. 31 ``T = sum G_c P_a s^T``). Two exact
representations are provided:

* :meth:`ClosedLoop.dynamic_stiffness` -- ``Z(s) = s^2 M + s (D(w_F) + Omega G1) + C + sum_i
  H_i(s) P_i s_i^T`` for the frequency domain (the compact form of eq. 41);
* :meth:`ClosedLoop.state_space` -- the polynomial part ``h2 s^2 + h1 s + h0`` of every ``H_i``
  folded into ``M, D, C`` (Werner 2021 Figure 5 / eq. 49, which :meth:`embedded_matrices` returns)
  plus states for the strictly proper remainder, which acts on the foot displacement.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.signal

from ..control.spec import ContinuousController
from ..errors import ModelError
from ..models.plant import LinearPlant


@dataclass(frozen=True, eq=False)
class ClosedLoop:
    """A plant and the controllers of (some of) its actuators; the others stay open."""

    plant: LinearPlant
    controllers: dict[str, ContinuousController] = field(default_factory=dict)

    def __post_init__(self):
        for act_id in self.controllers:
            self.plant.actuator(act_id)      # raises with the list of actuators

    @property
    def is_open(self) -> bool:
        return not self.controllers

    def open(self) -> "ClosedLoop":
        return ClosedLoop(self.plant, {})

    def _pairs(self):
        for act_id, ctrl in self.controllers.items():
            act = self.plant.actuator(act_id)
            yield act, ctrl, np.outer(act.force_vector, act.sensor_row)

    # -- frequency domain -----------------------------------------------------------------------
    def dynamic_stiffness(self, s, speed, w_F) -> np.ndarray:
        """``Z(s)`` for arrays of ``s``, ``speed``, ``w_F`` (broadcast) -> shape (..., n, n)."""
        s, speed, w_F = np.broadcast_arrays(np.asarray(s, complex), np.asarray(speed, float),
                                            np.asarray(w_F, float))
        p = self.plant
        sc = s[..., None, None]
        Z = sc**2 * p.mass + sc * p.damping(speed, w_F) + p.stiffness_at(speed, w_F)
        for _, ctrl, ps in self._pairs():
            Z = Z + ctrl.law(s)[..., None, None] * ps
        return Z

    def force_rows(self, s) -> dict[str, np.ndarray]:
        """Per actuator, the row ``r(s)`` with ``f = r(s) . q`` (zero for open actuators)."""
        s = np.asarray(s, complex)
        rows = {}
        for act in self.plant.actuators:
            ctrl = self.controllers.get(act.id)
            gain = -ctrl.law(s) if ctrl is not None else np.zeros(s.shape, complex)
            rows[act.id] = gain[..., None] * act.sensor_row
        return rows

    # -- second-order / state space -----------------------------------------------------------
    def embedded_matrices(self, speed: float, w_F: float):
        """``(M~, D~, C~)`` of Werner 2021 Figure 5 / eq. 49: the closed loop as a second-order
        system ``M~ q'' + D~ q' + C~ q = f``. Refused (the table's "--" cells) when a controller
        needs states of its own, e.g. I on displacement."""
        for act, ctrl, _ in self._pairs():
            _, rnum, _ = ctrl.law_split()
            if np.any(rnum):
                raise ModelError(
                    f"{ctrl.describe()} at {act.id} cannot be embedded into M, D, C (it needs "
                    "controller states); use the state-space closed loop instead")
        return self._polynomial_matrices(speed, w_F)

    def _polynomial_matrices(self, speed: float, w_F: float):
        p = self.plant
        M, D, C = p.mass.copy(), p.damping(speed, w_F), p.stiffness_at(speed, w_F)
        for _, ctrl, ps in self._pairs():
            h, _, _ = ctrl.law_split()
            C = C + h[0] * ps
            D = D + h[1] * ps
            M = M + h[2] * ps
        return M, D, C

    def state_space(self, speed: float, w_F: float):
        """``(A, B)`` of the closed loop with state ``[q, q', x_c]`` and input = generalised
        forces (n). Raises when ``M~`` is singular (an acceleration gain that cancels a mass)."""
        p = self.plant
        n = p.n
        M, D, C = self._polynomial_matrices(speed, w_F)
        blocks = []
        for act, ctrl, _ in self._pairs():
            _, rnum, rden = ctrl.law_split()
            if len(rden) > 1 and np.any(rnum):
                a, b, c, d = scipy.signal.tf2ss(rnum, rden)
                blocks.append((act, a, b[:, 0], c[0]))
        nc = sum(a.shape[0] for _, a, _, _ in blocks)
        cond = np.linalg.cond(M) if np.all(np.isfinite(M)) else np.inf
        if not np.isfinite(cond) or cond > 1e13:
            raise ModelError(
                f"the closed-loop mass matrix M + sum K_m P s^T is singular (cond {cond:.2g}): an "
                "acceleration-feedback gain cancels the machine's mass -- lower the gain")
        # numpy's solve: scipy's getrs is slow for small matrices when its BLAS threads contend
        M_inv = np.linalg.solve(M, np.eye(n))
        A = np.zeros((2 * n + nc, 2 * n + nc))
        A[:n, n:2 * n] = np.eye(n)
        A[n:2 * n, :n] = -M_inv @ C
        A[n:2 * n, n:2 * n] = -M_inv @ D
        k = 2 * n
        for act, a, b, c in blocks:
            m = a.shape[0]
            A[n:2 * n, k:k + m] = -np.outer(M_inv @ act.force_vector, c)
            A[k:k + m, :n] = np.outer(b, act.sensor_row)
            A[k:k + m, k:k + m] = a
            k += m
        B = np.zeros((2 * n + nc, n))
        B[n:2 * n] = M_inv
        return A, B
