"""Exact sampled-data form of a LinearPlant at one speed (DESIGN.md section 3).

State ``x = [q; q']``. Over one sample period ``T`` with the actuator forces ``u`` held (zero-order
hold) and the rotor at constant speed ``Omega``, the solution is exact::

    x_{k+1} = Phi x_k + Gamma_u u_k + Re{ sum_j Gamma_e[:, j] a_j e^{j theta_k} }

where ``a_j`` is the complex amplitude of excitation ``j`` and ``theta_k`` the shaft angle at
``t_k``. ``Gamma_e = int_0^T e^{A(T-tau)} B F_j e^{j Omega tau} dtau`` comes from the matrix
exponential of an augmented system (a complex oscillator state), which stays exact even when
``j Omega`` sits on a lightly damped pole.

Measurements follow the sampling contract: the acceleration at ``t_k`` uses the forces held
over the previous interval, ``q''_k = Acc_x x_k + Acc_f (P u_{k-1} + f_e(t_k))``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import ModelError
from .plant import LinearPlant


@dataclass(frozen=True, eq=False)
class DiscretePlant:
    """``Phi``, ``Gamma_u`` (columns: ``plant.actuators`` order), ``Gamma_e`` (columns:
    ``plant.excitations`` order, complex) and the continuous ``A``, ``B`` at one operating point."""

    plant: LinearPlant
    sample_period_s: float
    speed_rad_s: float
    w_F: float
    A: np.ndarray
    B: np.ndarray
    Phi: np.ndarray
    Gamma_u: np.ndarray
    Gamma_e: np.ndarray

    @property
    def accel_state(self) -> np.ndarray:
        """``q'' = accel_state @ x + accel_force @ f`` (rows of A below the identity)."""
        n = self.plant.n
        return self.A[n:]

    @property
    def accel_force(self) -> np.ndarray:
        return self.B[self.plant.n:]


def continuous_state_space(plant: LinearPlant, speed_rad_s: float, w_F: float):
    """``A`` (2n x 2n) and ``B`` (2n x n, generalised forces) of the open-loop plant."""
    n = plant.n
    M = plant.mass
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -np.linalg.solve(M, plant.stiffness_at(speed_rad_s, w_F))
    A[n:, n:] = -np.linalg.solve(M, plant.damping(speed_rad_s, w_F))
    B = np.zeros((2 * n, n))
    B[n:] = np.linalg.inv(M)
    return A, B


def discretize_plant(plant: LinearPlant, speed_rad_s: float, w_F: float,
                     sample_period_s: float) -> DiscretePlant:
    """Exact ZOH discretisation of the actuator inputs and exact sinusoidal excitation."""
    T = float(sample_period_s)
    if not np.isfinite(T) or T <= 0:
        raise ModelError(f"sample period must be > 0 (got {sample_period_s})")
    A, B = continuous_state_space(plant, speed_rad_s, w_F)
    N = A.shape[0]
    Bu = B @ np.array([a.force_vector for a in plant.actuators]).reshape(-1, plant.n).T
    m = Bu.shape[1]
    # ZOH: expm([[A, Bu], [0, 0]] T) = [[Phi, Gamma_u], [0, I]]
    aug = np.zeros((N + m, N + m))
    aug[:N, :N] = A
    aug[:N, N:] = Bu
    finite = bool(np.all(np.isfinite(aug)))
    if finite:
        with np.errstate(all="ignore"):
            E = scipy.linalg.expm(aug * T)
        finite = bool(np.all(np.isfinite(E)))
    if not finite:
        raise ModelError(
            f"{plant.name}: at {speed_rad_s / (2 * np.pi):.4g} Hz the model's exact "
            f"discretisation over a {T:g} s sample overflows (a mode growing by orders of "
            "magnitude per sample, or non-finite matrices) -- check the machine's parameters "
            "(masses, stiffnesses, bearing load and clearance) for a value off by orders of "
            "magnitude")
    Phi, Gamma_u = E[:N, :N], E[:N, N:]
    # sinusoid: expm([[A, B F], [0, j Omega]] T) top-right = int e^{A(T-tau)} B F e^{j Omega tau}
    excs = plant.excitations
    Ge = np.zeros((N, len(excs)), complex)
    for j, exc in enumerate(excs):
        aug = np.zeros((N + 1, N + 1), complex)
        aug[:N, :N] = A
        aug[:N, N] = B @ exc.phasor(speed_rad_s)
        aug[N, N] = 1j * speed_rad_s
        Ge[:, j] = scipy.linalg.expm(aug * T)[:N, N]
    return DiscretePlant(plant, T, float(speed_rad_s), float(w_F), A, B, Phi, Gamma_u, Ge)
