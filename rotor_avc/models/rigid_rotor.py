"""Zhou & Shi 2001 (Zhou & Shi 2001): rigid rotor on two isotropic bearings, spin axis Y.

Generalised coordinates ``q = [R_X, R_Z, theta, psi]`` (paper eq. 1): translations of the mass
centre and the two tilt angles. The bearings sit at ``y = +-L/2`` (as the conical stiffness
``k L^2 / 2 = 2 k (L/2)^2`` of eq. 1 implies), each with stiffness ``k`` and viscous damping
``c``::

    M = diag(m, m, I_t, I_t),  C = diag(2k, 2k, k L^2/2, k L^2/2),  D_v = diag(2c, 2c, c L^2/2, ...)
    G1[theta, psi] = -I_p, G1[psi, theta] = +I_p      (the I_p phi' terms of A(t), eq. 1)

The shaft is a solid cylinder (the paper gives only ``L`` and ``r``): ``m = rho pi r^2 L``,
``I_t = m (3 r^2 + L^2) / 12``, ``I_p = m r^2 / 2``. ``rotor.gyroscopic: false`` (the paper's
analysis) drops G1. The ``I_p phi''`` coupling of A(t) is a stiffness proportional to the angular
acceleration; a LinearPlant cannot carry it, so only the run-up simulator
(:mod:`rotor_avc.balancing.rigid_runup`) has it. The paper drops both gyroscopic terms.

Excitations in the LinearPlant convention ``Re{(Omega^2 - j Omega') p2 u e^{j phi}}``: a point
mass ``m_u`` at body coordinates ``(u_x, u_y, u_z)`` gives (from the B matrix of eq. 1, with
``f1 = Re{(Omega^2 - j Omega')j e^{j phi}}`` and ``f2 = Re{(Omega^2 - j Omega') e^{j phi}}``)::

    static  u = m_u (u_x - j u_z)       [kg m],    p2 = [1, j, 0, 0]
    moment  u = m_u u_y (u_x - j u_z)   [kg m^2],  p2 = [0, 0, j, -1]

The complex amplitude is the conjugate of the paper's ``a + i b`` form because the rotor turns
from +Z towards +X (clockwise in the X-Z plane) while the LinearPlant phasor turns forwards.
A point on the axis at ``y`` moves by ``X = R_X - y psi``, ``Z = R_Z + y theta``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .plant import Excitation, LinearPlant, Output

COORDS = ("R_X", "R_Z", "theta", "psi")


@dataclass(frozen=True)
class RigidRotor:
    """The paper's rotor: shaft mass and inertias, bearings, output point (SI units)."""

    mass_kg: float
    I_t: float                  # diametral moment of inertia [kg m^2]
    I_p: float                  # polar moment of inertia [kg m^2]
    length_m: float
    stiffness_n_per_m: float    # per bearing
    damping_n_s_per_m: float    # per bearing
    output_axial_m: float       # l_s: axial position of the output point on the spin axis
    gyroscopic: bool = False    # keep the I_p terms of A(t) (the paper's analysis drops them)

    @property
    def omega_n(self) -> np.ndarray:
        """Undamped natural frequencies [rad/s] of the translational and conical mode."""
        k, L = self.stiffness_n_per_m, self.length_m
        return np.sqrt([2 * k / self.mass_kg, k * L**2 / (2 * self.I_t)])

    @property
    def zeta(self) -> np.ndarray:
        """Damping ratios of the two modes (``2 zeta w_n = 2c/m`` and ``c L^2 / 2 I_t``)."""
        c, L = self.damping_n_s_per_m, self.length_m
        two_zeta_w = np.array([2 * c / self.mass_kg, c * L**2 / (2 * self.I_t)])
        return two_zeta_w / (2 * self.omega_n)

    @property
    def modal_mass(self) -> np.ndarray:
        """``(m, I_t)``: divides the modal force of each mode."""
        return np.array([self.mass_kg, self.I_t])

    def d_coefficient(self, axial_m: float) -> float:
        """``d = m w_y / I_t`` of paper eq. (9) for a plane at ``w_y`` [1/m]."""
        return self.mass_kg * axial_m / self.I_t


def axis_point_row(axial_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``X`` and ``Z`` of the spin-axis point at ``y = axial_m``."""
    return np.array([1.0, 0, 0, -axial_m]), np.array([0, 1.0, axial_m, 0])


def build(rot: RigidRotor, name: str, damping_floor_rad_s: float, config: dict | None = None
          ) -> LinearPlant:
    """The Zhou & Shi 2001 rotor as a LinearPlant (see the module docstring); ``config`` is kept on the
    plant for the record."""
    k, c, L = rot.stiffness_n_per_m, rot.damping_n_s_per_m, rot.length_m
    M = np.diag([rot.mass_kg, rot.mass_kg, rot.I_t, rot.I_t])
    C = np.diag([2 * k, 2 * k, k * L**2 / 2, k * L**2 / 2])
    D_v = np.diag([2 * c, 2 * c, c * L**2 / 2, c * L**2 / 2])
    G1 = np.zeros((4, 4))
    if rot.gyroscopic:
        G1[2, 3], G1[3, 2] = -rot.I_p, rot.I_p
    outputs = []
    for point, y in (("output", rot.output_axial_m), ("bearing_A", -L / 2), ("bearing_B", L / 2)):
        row_x, row_z = axis_point_row(y)
        outputs += [Output(f"{point}_x", row_x, 0, "m"), Output(f"{point}_z", row_z, 0, "m")]
    return LinearPlant(
        name=name, coords=COORDS, mass=M, stiffness=C,
        loss_damping=np.zeros((4, 4)), viscous_damping=D_v, gyroscopic=G1,
        circulatory=np.zeros((4, 4)), actuators=(),
        excitations=(Excitation("static", "kg*m", np.array([1.0, 1j, 0, 0])),
                     Excitation("moment", "kg*m^2", np.array([0, 0, 1j, -1.0]))),
        outputs=tuple(outputs), damping_floor_rad_s=damping_floor_rad_s, config=config or {})
