"""The Zhou & Shi 2001 regression ``y_j = x_j^T phi_j + e_j`` (paper eq. 2).

Known constants ``a1 = k/m``, ``a2 = c/m``, ``b0 = 1/m``, ``g0 = m/I_t``, ``g1 = m L^2/(2 I_t)``,
``g2 = I_p/I_t``; unknowns ``phi_1 = [b1, b2] = m_u [u_x, u_z] / m`` and ``phi_2 = [b3, b4] =
m_u u_y [u_x, u_z] / m``. With ``f1 = phi'' cos phi - phi'^2 sin phi`` and ``f2 = phi'' sin phi +
phi'^2 cos phi``::

    y1 = R_X'' - [b0 m_b (w_x f2 - w_z f1) - 2 a2 R_X' - 2 a1 R_X],      x1 = [f2, -f1]
    y2 = theta'' - [b0 m_b w_y g0 (w_x f1 + w_z f2) - g1 a2 theta' - g1 a1 theta
                    (+ g2 (phi'' psi + phi' psi') with gyro compensation)],  x2 = g0 [f1, f2]

(the extraction prints ``-2 a2 theta'`` in ``y1``; it must be ``R_X'``, a typo in the paper's
eq. (2)).
The paper uses these two rows only. With ``axes="both"`` the ``R_Z`` and ``psi`` rows, which carry
the same parameters with independent measurement noise, are stacked in::

    y3 = R_Z'' - [b0 m_b (w_x f1 + w_z f2) - 2 a2 R_Z' - 2 a1 R_Z],         x3 = [f1, f2]
    y4 = psi'' - [b0 m_b w_y g0 (w_z f1 - w_x f2) - g1 a2 psi' - g1 a1 psi
                  (- g2 (phi'' theta + phi' theta') with gyro compensation)], x4 = g0 [-f2, f1]

How the acceleration and the evaluation instant are chosen (``regression``):

* ``forward`` -- paper eq. (2): ``(v_k - v_{k-1}) / T`` with everything else at ``t_{k-1}``. Its
  O(T) phase error biases the estimate near resonance (simulated on the paper's example: 12 % for
  ``b1, b2`` at 2.2 s and 29 % for ``b3, b4`` at 3.3 s with ``T = 1e-4 s``);
* ``midpoint`` -- the same difference quotient with ``f`` at ``t_{k-1} + T/2`` and the states and
  balancer position averaged over the two samples (O(T^2); < 0.5 % from 2 s on);
* ``measured`` -- measured accelerations and everything at ``t_k``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..models.rigid_rotor import RigidRotor

REGRESSIONS = ("forward", "midpoint", "measured")
AXES = ("x", "both")


@dataclass(frozen=True)
class RigidSample:
    """What the Zhou & Shi 2001 estimator reads at one instant (SI units; rad for angles)."""

    t: float
    angle: float                 # phi
    speed: float                 # phi'
    accel: float                 # phi''
    R_X: float
    dR_X: float
    theta: float
    dtheta: float
    R_Z: float = 0.0             # Z / psi rows (axes "both")
    dR_Z: float = 0.0
    psi: float = 0.0             # also for gyro compensation
    dpsi: float = 0.0
    w_x: float = 0.0             # actual balancer position [m]
    w_z: float = 0.0
    ddR_X: float = math.nan      # measured accelerations (regression "measured")
    ddtheta: float = math.nan
    ddR_Z: float = math.nan
    ddpsi: float = math.nan


@dataclass(frozen=True)
class RigidRegression:
    """Builds ``(x1, y1, x2, y2)`` from consecutive samples (see the module docstring)."""

    rotor: RigidRotor
    balancer_mass_kg: float
    balancer_axial_m: float
    regression: str = "midpoint"
    gyro_compensation: bool = False
    axes: str = "x"

    def rows(self, prev: RigidSample | None, cur: RigidSample):
        """``(X1, y1, X2, y2)``: rows (m, 2) and outputs (m,) of both filters (m = 1 or 2), or
        ``None`` when the interval is unusable (first sample, non-increasing time)."""
        if self.regression == "measured":
            return self._at(cur, (cur.ddR_X, cur.ddtheta, cur.ddR_Z, cur.ddpsi))
        if prev is None:
            return None
        T = cur.t - prev.t
        if not T > 0:
            return None
        acc = ((cur.dR_X - prev.dR_X) / T, (cur.dtheta - prev.dtheta) / T,
               (cur.dR_Z - prev.dR_Z) / T, (cur.dpsi - prev.dpsi) / T)
        if self.regression == "forward":
            return self._at(prev, acc)
        # midpoint: exact phase at t + T/2 for a constant angular acceleration
        mid = RigidSample(
            t=0.5 * (prev.t + cur.t),
            angle=0.5 * (prev.angle + cur.angle) - (cur.speed - prev.speed) * T / 8,
            speed=0.5 * (prev.speed + cur.speed), accel=0.5 * (prev.accel + cur.accel),
            R_X=0.5 * (prev.R_X + cur.R_X), dR_X=0.5 * (prev.dR_X + cur.dR_X),
            theta=0.5 * (prev.theta + cur.theta), dtheta=0.5 * (prev.dtheta + cur.dtheta),
            R_Z=0.5 * (prev.R_Z + cur.R_Z), dR_Z=0.5 * (prev.dR_Z + cur.dR_Z),
            psi=0.5 * (prev.psi + cur.psi), dpsi=0.5 * (prev.dpsi + cur.dpsi),
            w_x=0.5 * (prev.w_x + cur.w_x), w_z=0.5 * (prev.w_z + cur.w_z))
        return self._at(mid, acc)

    def _at(self, s: RigidSample, acc):
        rot = self.rotor
        m, I_t = rot.mass_kg, rot.I_t
        a1, a2 = rot.stiffness_n_per_m / m, rot.damping_n_s_per_m / m
        g0, g1 = m / I_t, m * rot.length_m**2 / (2 * I_t)
        cphi, sphi = math.cos(s.angle), math.sin(s.angle)
        w2 = s.speed * s.speed
        f1 = s.accel * cphi - w2 * sphi
        f2 = s.accel * sphi + w2 * cphi
        mb, wy = self.balancer_mass_kg, self.balancer_axial_m
        g2 = rot.I_p / I_t if self.gyro_compensation else 0.0
        y1 = acc[0] - ((s.w_x * f2 - s.w_z * f1) * mb / m - 2 * a2 * s.dR_X - 2 * a1 * s.R_X)
        y2 = acc[1] - (mb * wy * (s.w_x * f1 + s.w_z * f2) / I_t - g1 * a2 * s.dtheta
                       - g1 * a1 * s.theta + g2 * (s.accel * s.psi + s.speed * s.dpsi))
        if self.axes == "x":
            return ((f2, -f1),), (y1,), ((g0 * f1, g0 * f2),), (y2,)
        y3 = acc[2] - ((s.w_x * f1 + s.w_z * f2) * mb / m - 2 * a2 * s.dR_Z - 2 * a1 * s.R_Z)
        y4 = acc[3] - (mb * wy * (s.w_z * f1 - s.w_x * f2) / I_t - g1 * a2 * s.dpsi
                       - g1 * a1 * s.psi - g2 * (s.accel * s.theta + s.speed * s.dtheta))
        return (((f2, -f1), (f1, f2)), (y1, y3), ((g0 * f1, g0 * f2), (-g0 * f2, g0 * f1)),
                (y2, y4))
