"""A balancing plane on the Werner 2021 rotor: point masses -> static and moment unbalance.

Werner 2021's excitations (eqs. 13-14) are ``P_e = [1, -j, 0, ...]`` on ``(z_s, y_s)`` per kg m and
``P_alpha = [0, 0, 0, 1, -j, 0, ...]`` on ``(phi_sz, phi_sy)`` per kg m^2, the physical force
being ``Re{Omega^2 P u e^{j theta}}``: a static amplitude ``u_e = m e e^{j phi}`` turns from +z
towards +y. The rotor axis is ``x``; an axis point at axial position ``a`` (measured like the
bearing positions, + towards D) moves by ``z = z_s + a phi_sy`` and ``y = y_s - a phi_sz``
(``foot_kinematic_rows`` with ``h = beta = 0``).

A point mass ``m`` at radius ``e``, angle ``phi`` in the plane at ``a`` exerts
``F_z = m e Omega^2 cos(theta + phi)``, ``F_y = m e Omega^2 sin(theta + phi)`` (plus the
tangential ``Omega'`` terms, carried by the same phasor). By virtual work its generalised moments
are ``Q_phi_sy = a F_z`` and ``Q_phi_sz = -a F_y``. Matching ``Re{Omega^2 u_alpha e^{j theta}} =
-a m e Omega^2 sin(theta + phi)`` and ``Re{-j Omega^2 u_alpha e^{j theta}} = a m e Omega^2
cos(theta + phi)`` gives::

    u_e = m e e^{j phi},      u_alpha = j a u_e

So ``P_e u_e + P_alpha u_alpha = [1, -j, 0, j a, a, 0] u_e``, the kinematic rows of the point
(tested against the model). Two equal masses at ``+-a`` on opposite sides give ``u_e = 0`` and
``u_alpha = 2 j a m e e^{j phi}``: a pure moment unbalance.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError


def point_mass_unbalance(mass_kg: float, radius_m: float, angle_rad: float,
                         axial_m: float) -> dict[str, complex]:
    """``{"static": u_e [kg m], "moment": u_alpha [kg m^2]}`` of one point mass."""
    u_e = mass_kg * radius_m * complex(math.cos(angle_rad), math.sin(angle_rad))
    return {"static": u_e, "moment": 1j * axial_m * u_e}


@dataclass(frozen=True)
class MachinePlane:
    """A one-plane balancer at axial position ``axial_m`` on a rotor spanning
    ``[rotor_min_m, rotor_max_m]``. Its position is the correction mass-radius ``c`` [kg m]
    (complex, Werner 2021 phase convention), limited to ``max_mass_radius_kg_m``."""

    axial_m: float
    rotor_min_m: float
    rotor_max_m: float
    max_mass_radius_kg_m: float | None = None

    def __post_init__(self):
        if not (math.isfinite(self.axial_m) and self.rotor_min_m <= self.axial_m
                <= self.rotor_max_m):
            raise ModelError(
                f"balancing plane at {self.axial_m} m is outside the rotor "
                f"[{self.rotor_min_m}, {self.rotor_max_m}] m -- put the plane between the "
                "bearings (machine.bearing_axial_position_m: -N ... +D)")
        if self.axial_m == 0:
            raise ModelError("a balancing plane through the centre of gravity (axial 0 m) "
                             "cannot correct moment unbalance -- move it towards a bearing")

    def corrections(self, c: complex) -> dict[str, complex]:
        """Excitation amplitudes of the correction ``c``: ``{"static": c, "moment": j a c}``."""
        c = complex(c)
        return {"static": c, "moment": 1j * self.axial_m * c}

    @property
    def influence(self) -> np.ndarray:
        """``[1, j a]``: the amplitudes per unit correction (static, moment)."""
        return np.array([1.0, 1j * self.axial_m])

    def cancelling(self, excitation: str, amplitude: complex) -> complex:
        """Correction that cancels one unbalance type (single-mode balancing)."""
        k = {"static": 0, "moment": 1}.get(excitation)
        if k is None:
            raise ModelError(f"unknown unbalance type {excitation!r} (static or moment)")
        return -amplitude / self.influence[k]
