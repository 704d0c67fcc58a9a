"""Forced response over speed by one modal decomposition (DESIGN.md section 2).

With the damping of forced response at ``w_F = Omega`` the dynamic stiffness at ``s = j Omega``
of a plant without speed terms, with controllers that embed into ``M, D, C`` (Werner 2021 Figure 5,
eq. 49: ``H = h0 + h1 s + h2 s^2``), is a quadratic matrix polynomial in the speed::

    Z(Omega) = K0 + Omega K1 + Omega^2 K2
    K0 = C + N_eta + j D_eta + sum h0 P s^T      (loss factor: j Omega D_eta / Omega = j D_eta)
    K1 = j (D_v + sum h1 P s^T)
    K2 = -(M + sum h2 P s^T) + j G1              (gyroscopics: j Omega . Omega G1)

Its companion linearisation in the scaled speed ``mu = Omega / w0`` (``w0^2 = |K0| / |K2|``
balances the blocks), ``L = [[0, I], [-K2'^-1 K0, -K2'^-1 K1']]`` with ``K1' = w0 K1``,
``K2' = w0^2 K2``, satisfies ``(L - mu I) [q; mu q] = [0; -K2'^-1 F]``. One eigendecomposition
``L = V diag(mu_k) V^-1`` then serves every speed::

    q(Omega) = V_top diag(1 / (mu_k - mu)) W F(Omega),    W = -(V^-1)[:, n:] K2'^-1

at ``O(n^2)`` per speed (a matrix-vector product) instead of an ``O(n^3)`` solve. Everything else
-- speed-dependent plant terms (oil films, field damping), controllers with states of their own,
speeds where the damping frequency is not the speed (below the floor) -- keeps the batched solve
of ``Z(j Omega) q = F``. :func:`solve_over_speed` chooses per call.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .loop import ClosedLoop

#: below this many speeds the batched solve is cheaper than one eigendecomposition
MODAL_MIN_SPEEDS = 200
#: eigenvector bases worse conditioned than this fall back to the batched solve
MAX_BASIS_CONDITION = 1e7


def quadratic_coefficients(loop: ClosedLoop):
    """``(K0, K1, K2)`` of ``Z(Omega)`` at ``w_F = Omega`` (module docstring), or ``None`` where
    the dynamic stiffness is not a polynomial in the speed."""
    p = loop.plant
    if p.speed_terms is not None:
        return None
    K0 = p.stiffness + p.circulatory + 1j * p.loss_damping
    K1 = 1j * p.viscous_damping
    K2 = -p.mass + 1j * p.gyroscopic
    for _, ctrl, ps in loop._pairs():
        h, rnum, _ = ctrl.law_split()
        if np.any(rnum):
            return None                                   # controller states: not embeddable
        K0 = K0 + h[0] * ps
        K1 = K1 + 1j * h[1] * ps
        K2 = K2 - h[2] * ps
    return K0, K1, K2


@dataclass(frozen=True)
class ModalStiffness:
    """The eigendecomposition of the linearised ``Z(Omega)``: ``q = V_top (W F) / (mu_k - mu)``."""

    w0: float
    mu: np.ndarray            # (2n,) eigenvalues in Omega / w0
    v_top: np.ndarray         # (n, 2n)
    w: np.ndarray             # (2n, n)

    @classmethod
    def of(cls, loop: ClosedLoop) -> "ModalStiffness | None":
        """The decomposition, or ``None`` where the modal route does not apply or is ill-posed."""
        coeffs = quadratic_coefficients(loop)
        if coeffs is None:
            return None
        K0, K1, K2 = coeffs
        n = K0.shape[0]
        w0 = float(np.sqrt(np.linalg.norm(K0, 1) / np.linalg.norm(K2, 1)))
        K1s, K2s = w0 * K1, w0**2 * K2
        if np.linalg.cond(K2s) > 1e12:
            return None
        K2_inv = np.linalg.inv(K2s)
        L = np.zeros((2 * n, 2 * n), complex)
        L[:n, n:] = np.eye(n)
        L[n:, :n] = -K2_inv @ K0
        L[n:, n:] = -K2_inv @ K1s
        mu, V = scipy.linalg.eig(L, overwrite_a=True, check_finite=False)
        V_inv = np.linalg.inv(V)
        if np.linalg.norm(V, 1) * np.linalg.norm(V_inv, 1) > MAX_BASIS_CONDITION:
            return None
        return cls(w0, mu, V[:n], -V_inv[:, n:] @ K2_inv)

    def solve(self, speeds: np.ndarray, F: np.ndarray) -> np.ndarray:
        """``q`` for the forces ``F`` (N, n, m) at the speeds (N,) -> (N, n, m)."""
        N, n, m = F.shape
        gain = 1.0 / (self.mu[None, None, :] - speeds[:, None, None] / self.w0)   # (N, 1, 2n)
        forces = F.transpose(0, 2, 1).reshape(N * m, n)
        eta = (forces @ self.w.T).reshape(N, m, -1) * gain                        # modal coords
        return (eta.reshape(N * m, -1) @ self.v_top.T).reshape(N, m, n).transpose(0, 2, 1)


def solve_over_speed(loop: ClosedLoop, speeds: np.ndarray, w_F: np.ndarray,
                     F: np.ndarray) -> np.ndarray:
    """``q = Z(j Omega)^-1 F`` at every speed (N,) with damping frequencies ``w_F`` (N,) and
    forces ``F`` (N, n, m): the modal route where ``w_F == Omega`` on at least
    :data:`MODAL_MIN_SPEEDS` speeds and the stiffness is a polynomial in the speed, the batched
    solve elsewhere."""
    modal = speeds == w_F
    decomposition = ModalStiffness.of(loop) if np.count_nonzero(modal) >= MODAL_MIN_SPEEDS else None
    if decomposition is not None and np.all(modal):
        return decomposition.solve(speeds, F)
    Q = np.empty(F.shape, complex)
    if decomposition is None:
        modal[:] = False
    else:
        Q[modal] = decomposition.solve(speeds[modal], F[modal])
    rest = ~modal
    Z = loop.dynamic_stiffness(1j * speeds[rest], speeds[rest], w_F[rest])
    Q[rest] = np.linalg.solve(Z, F[rest])
    return Q
