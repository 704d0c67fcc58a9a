"""Update laws of frequency-domain (convergent) harmonic control, as matrices.

Once per update ``n`` the block measures the complex error phasors ``E_n`` (M sensors) of one
harmonic and updates the actuator phasors ``U`` (N actuators)::

    U_{n+1} = A_U U_n - B E_n

from the influence-matrix estimate ``G^`` (``E = P + G U`` quasi-steadily, ``P`` the
disturbance), the sensor weights ``W = diag(w)``, the gain ``mu``, the leakage ``l`` and the
relative effort weight ``beta`` (the effort penalty ``R = beta s^2 I`` with ``s`` the largest
singular value of ``W^1/2 G^``):

* ``steepest_descent``: ``U+ = (1 - l) U - (mu / s^2) (G^H W E + R U)`` -- the gradient of
  ``J = E^H W E + U^H R U``, normalised so that ``mu < 2`` is stable for an exact model
  along the strongest direction (robust, slow in weak directions);
* ``newton``: ``U+ = (1 - l) U - mu pinv(W^1/2 G^) W^1/2 E`` -- the (minimum-norm) Gauss-Newton
  step; ``mu = 1`` cancels the error in one update with an exact model;
* ``wls``: ``U+ = (1 - l) U - mu H^-1 (G^H W E + R U)``, ``H = G^H W G^ + R`` -- Newton on ``J``
  with the effort penalty (``beta > 0``), converging to the optimum ``U = -H^-1 G^H W P``.

With the true influence matrix ``G`` the quasi-steady iteration is ``U+ = (A_U - B G) U - B P``,
converging iff the spectral radius of ``A_U - B G`` is below 1 (:func:`convergence_radius`; for a
scalar plant and steepest descent ``|1 - mu e^{-j phi}| < 1``: divergence past 90 degrees of
phase error, whatever the gain). Cheer & Daley compare the laws; Zazas & Daley give the
sample-level picture (:mod:`rotor_avc.harmonic.lti`).
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError

LAWS = ("steepest_descent", "newton", "wls")


def check_law(law: str, gain: float, effort_weight: float, leakage: float) -> None:
    """Refuse settings no law can run with (ModelError naming the setting)."""
    if law not in LAWS:
        raise ModelError(f"unknown update law {law!r}; use one of {', '.join(LAWS)}")
    if not (np.isfinite(gain) and gain > 0):
        raise ModelError(f"the adaptation gain must be > 0 (got {gain})")
    if not (np.isfinite(leakage) and 0 <= leakage < 1):
        raise ModelError(f"the leakage must lie in [0, 1) (got {leakage})")
    if not (np.isfinite(effort_weight) and effort_weight >= 0):
        raise ModelError(f"the effort weight must be >= 0 (got {effort_weight})")
    if law == "newton" and effort_weight > 0:
        raise ModelError("law newton has no effort penalty; use law wls for effort_weight > 0")
    if law == "wls" and effort_weight <= 0:
        raise ModelError("law wls needs effort_weight > 0 (with 0 it is law newton)")


def update_matrices(G_est: np.ndarray, law: str, gain: float, *, effort_weight: float = 0.0,
                    leakage: float = 0.0, sensor_weights=None) -> tuple[np.ndarray, np.ndarray]:
    """``(A_U, B)`` of ``U+ = A_U U - B E`` (module docstring) from the estimate ``G^`` (M, N)."""
    G = np.asarray(G_est, dtype=complex)
    if G.ndim != 2 or not np.all(np.isfinite(G)):
        raise ModelError(f"the influence estimate must be a finite (sensors, actuators) matrix "
                         f"(got shape {G.shape})")
    m, n = G.shape
    w = np.ones(m) if sensor_weights is None else np.asarray(sensor_weights, dtype=float)
    if w.shape != (m,) or np.any(~np.isfinite(w)) or np.any(w <= 0):
        raise ModelError(f"sensor weights must be {m} numbers > 0 (got {w})")
    check_law(law, gain, effort_weight, leakage)
    sw = np.sqrt(w)
    Gw = sw[:, None] * G
    if not np.any(Gw):
        raise ModelError("the influence estimate is zero: the actuators do not reach the sensors")
    eye = np.eye(n)
    if law == "newton":
        return (1 - leakage) * eye + 0j, gain * np.linalg.pinv(Gw) * sw
    s2 = float(np.linalg.norm(Gw, 2)) ** 2
    R = effort_weight * s2 * eye
    if law == "steepest_descent":
        return (1 - leakage) * eye - gain * R / s2, gain * (G.conj().T * w) / s2
    H = Gw.conj().T @ Gw + R
    return ((1 - leakage) * eye - gain * np.linalg.solve(H, R),
            gain * np.linalg.solve(H, G.conj().T * w))


def iteration_matrix(A_U: np.ndarray, B: np.ndarray, G_true: np.ndarray) -> np.ndarray:
    """The quasi-steady error iteration: ``E+ = (I - G B) E`` for pure integrators
    (``A_U = I``: :func:`update_matrices` builds it exactly for a law without leakage or effort
    penalty), else the phasor iteration ``A_U - B G`` (module docstring)."""
    if np.array_equal(A_U, np.eye(A_U.shape[0])):
        return np.eye(G_true.shape[0]) - G_true @ B
    return A_U - B @ G_true


def convergence_radius(A_U: np.ndarray, B: np.ndarray, G_true: np.ndarray) -> float:
    """Spectral radius of :func:`iteration_matrix` (< 1: the quasi-steady loop converges)."""
    return float(np.max(np.abs(np.linalg.eigvals(iteration_matrix(A_U, B, G_true)))))
