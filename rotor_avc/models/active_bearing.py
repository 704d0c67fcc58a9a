"""Sci. Rep. 2023 (Sci. Rep. 2023): rigid shaft on two piezo-actuated active bearings, 12 DOF.

Generalised coordinates (eqs. 6-7, 0-based here): the y block ``eps_r_y`` (rotor centre
of mass), ``eps_bh_y_1``, ``eps_ac_y_1``, ``eps_bh_y_2``, ``eps_ac_y_2`` (bearing housings and
actuator masses), ``theta_x`` (tilt about x), then the same six for x with ``theta_y``.

The rotor's centre of mass is at ``z = 0`` (mid-length), bearing 1 at ``z = -l1``, bearing 2 at
``z = +l2``. The shaft moves as ``y(z) = eps_r_y - z theta_x`` and ``x(z) = eps_r_x + z theta_y``
(right-handed, spin about +z; the lever signs of eqs. 2 and 4). Stiffness and viscous damping
are assembled from the springs ``k w w^T`` (Kelvin-Voigt elements): ball bearing ``k_b, c_b``
between shaft and housing, piezo stack ``k_ac, c_ac`` between housing and actuator mass, rubber
grommet ``k_pre, c_pre`` from housing to ground, backing spring ``k_sp, c_sp`` from actuator mass
to ground, and ``k_r`` on the tilt (no damping analogue, eq. 3). This reproduces eqs. (2)-(5)
with one typo corrected: row 5 holds ``k_ac,2 + k_sp,2`` (the paper prints ``k_ac,1``).

Corrections of the paper built in, each justified by a test of the physics it restores:

* the ``Omega I`` block of eq. (10) is the gyroscopic matrix: ``G[theta_x, theta_y] =
  +Omega I_p``, ``G[theta_y, theta_x] = -Omega I_p`` (``I_p`` the shaft's polar inertia);
* the four actuator forces act on the actuator masses (eqs. 8-9 show one force only);
* the unbalance is a rotating force ``m_o e (Omega^2 - j Omega') e^{j theta}`` on the
  centre of mass with ``p2 = e_x - j e_y``: ``f_x = m_o e Omega^2 cos(theta)``, ``f_y = m_o e
  Omega^2 sin(theta)`` (eqs. 16-17 print x and y in phase, a line rather than a rotating force);
* the sensor transform ``Pi`` (eq. 11) puts sensor 1 on the bearing-1 side in both planes (eq. 11
  uses one tilt row for both, which puts the y-plane sensor 1 on the bearing-2 side).

Actuators ``y1, x1, y2, x2`` push on the actuator masses; each one's sensor row is the motion of
its housing in its direction (the paper cancels housing motion). Outputs (displacements, m): the
housings ``housing_<i>_<d>``, the piezo elongations ``stroke_<i>_<d> = eps_ac - eps_bh`` and the
shaft points ``shaft_L<k>_<d>`` (bearing-1 side, ``z = -l_sen``) and ``shaft_R<k>_<d>``
(bearing-2 side), read through ``Pi`` (eqs. 11-13) for each configured sensor pair.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .plant import Actuator, Excitation, LinearPlant, Output

PLANES = ("y", "x")
BEARINGS = ("1", "2")
PLANE_COORDS = {d: (f"eps_r_{d}", f"eps_bh_{d}_1", f"eps_ac_{d}_1", f"eps_bh_{d}_2",
                    f"eps_ac_{d}_2", "theta_x" if d == "y" else "theta_y") for d in PLANES}
COORDS = PLANE_COORDS["y"] + PLANE_COORDS["x"]
#: actuator ids in the paper's order (eqs. 38-39): y then x at bearing 1, then bearing 2
ACTUATOR_IDS = ("y1", "x1", "y2", "x2")
#: ``d(z)/d(theta)`` of the shaft motion in each plane: ``y = eps - z theta_x``, ``x = eps + z theta_y``
LEVER_SIGN = {"y": -1.0, "x": 1.0}


def index(coord: str) -> int:
    """0-based index of a generalised coordinate."""
    return COORDS.index(coord)


def plane_mask(plane: str) -> np.ndarray:
    """Boolean mask of the coordinates of one plane (``theta_x`` belongs to the y plane)."""
    return np.isin(np.array(COORDS), PLANE_COORDS[plane])


def shaft_row(z_m: float, plane: str) -> np.ndarray:
    """Row giving the shaft displacement at axial position ``z_m`` in one plane."""
    row = np.zeros(len(COORDS))
    row[index(PLANE_COORDS[plane][0])] = 1.0
    row[index(PLANE_COORDS[plane][5])] = LEVER_SIGN[plane] * z_m
    return row


def basis(coord: str) -> np.ndarray:
    """Unit row selecting one generalised coordinate."""
    row = np.zeros(len(COORDS))
    row[index(coord)] = 1.0
    return row


def sensor_transform(l1_sen: float, l2_sen: float) -> np.ndarray:
    """``Pi`` of eq. (11), ``q = Pi q'``, for sensor 1 at ``z = -l1_sen`` (bearing-1 side) and
    sensor 2 at ``z = +l2_sen`` in both planes (the paper's eq. (11) puts the y-plane sensor 1 on
    the bearing-2 side).

    ``q' = [xi_sen1_y, xi_sen2_y, eps_bh_y_1, eps_ac_y_1, eps_bh_y_2, eps_ac_y_2, (same for x)]``
    (eqs. 12-13). The centre of mass is the internal-division point of the two sensors."""
    L = l1_sen + l2_sen
    Pi = np.zeros((12, 12))
    for b, plane in enumerate(PLANES):
        o = 6 * b
        Pi[o, o:o + 2] = [l2_sen / L, l1_sen / L]
        Pi[o + 1:o + 5, o + 2:o + 6] = np.eye(4)
        tilt = -LEVER_SIGN[plane] / L            # y: (xi1 - xi2)/L, x: (xi2 - xi1)/L
        Pi[o + 5, o:o + 2] = [tilt, -tilt]
    return Pi


def shaft_mass_properties(density: float, diameter: float, length: float) -> tuple[float, float, float]:
    """``(m_R, I_R, I_p)`` of a uniform cylindrical shaft: mass, transverse inertia about the
    centre of mass ``m (3 r^2 + L^2) / 12`` and polar inertia ``m r^2 / 2``."""
    r = diameter / 2
    m = density * np.pi * r**2 * length
    return m, m * (3 * r**2 + length**2) / 12, m * r**2 / 2


@dataclass(frozen=True)
class BearingPlane:
    """One bearing in one plane (SI units): actuator mass, and stiffness ``k_*`` [N/m] and
    damping ``c_*`` [N s/m] of the ball bearing (b), piezo actuator (ac), spring (sp) and rubber
    grommet (pre), eqs. (1)-(5)."""

    m_as: float
    k_b: float
    c_b: float
    k_ac: float
    c_ac: float
    k_sp: float
    c_sp: float
    k_pre: float
    c_pre: float


@dataclass(frozen=True)
class ActiveBearingParams:
    """The Sci. Rep. 2023 rotor on two active bearings (SI units)."""

    density_kg_m3: float
    diameter_m: float
    length_m: float
    bearing_z_m: dict[str, float]                 # bearing -> axial position (from the centre)
    tilt_stiffness_n_m_per_rad: float
    housing_mass_kg: dict[str, float]             # bearing -> housing mass
    planes: dict[tuple[str, str], BearingPlane]   # (bearing, plane) -> its parameters
    sensor_pairs: tuple[tuple[float, float], ...]  # (l1_sen, l2_sen) from the centre of mass


def build(p: ActiveBearingParams, name: str, damping_floor_rad_s: float,
          config: dict | None = None) -> LinearPlant:
    """The Sci. Rep. 2023 plant from its parameters (rotor_avc.model_config.active_bearing reads them
    from a config); ``config`` is kept on the plant for the record."""
    m_R, I_R, I_p = shaft_mass_properties(p.density_kg_m3, p.diameter_m, p.length_m)
    z_bearing, k_r = p.bearing_z_m, p.tilt_stiffness_n_m_per_rad
    n = len(COORDS)
    M, K, C = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    for i in BEARINGS:
        for d in PLANES:
            pl = p.planes[(i, d)]
            bh, ac = basis(f"eps_bh_{d}_{i}"), basis(f"eps_ac_{d}_{i}")
            M[index(f"eps_bh_{d}_{i}"), index(f"eps_bh_{d}_{i}")] = p.housing_mass_kg[i]
            M[index(f"eps_ac_{d}_{i}"), index(f"eps_ac_{d}_{i}")] = pl.m_as
            for w, k, c in ((shaft_row(z_bearing[i], d) - bh, pl.k_b, pl.c_b),
                            (bh - ac, pl.k_ac, pl.c_ac),
                            (bh, pl.k_pre, pl.c_pre),
                            (ac, pl.k_sp, pl.c_sp)):
                K += k * np.outer(w, w)
                C += c * np.outer(w, w)
    for d in PLANES:
        r, t = index(PLANE_COORDS[d][0]), index(PLANE_COORDS[d][5])
        M[r, r], M[t, t] = m_R, I_R
        K[t, t] += k_r
    G1 = np.zeros((n, n))
    G1[index("theta_x"), index("theta_y")] = I_p
    G1[index("theta_y"), index("theta_x")] = -I_p
    p2 = basis("eps_r_x") - 1j * basis("eps_r_y")

    outputs = []
    for i in BEARINGS:
        for d in PLANES:
            outputs.append(Output(f"housing_{i}_{d}", basis(f"eps_bh_{d}_{i}"), 0, "m"))
            outputs.append(Output(f"stroke_{i}_{d}", basis(f"eps_ac_{d}_{i}") - basis(f"eps_bh_{d}_{i}"),
                                  0, "m"))
    inverses = [np.linalg.inv(sensor_transform(*pair)) for pair in p.sensor_pairs]  # q' = Pi^-1 q
    for s, side in enumerate("LR"):
        for k, inv in enumerate(inverses, start=1):
            outputs += [Output(f"shaft_{side}{k}_{d}", inv[6 * b + s], 0, "m")
                        for b, d in enumerate(PLANES)]

    actuators = tuple(Actuator(a, basis(f"eps_ac_{a[0]}_{a[1]}"), basis(f"eps_bh_{a[0]}_{a[1]}"), a[0])
                      for a in ACTUATOR_IDS)
    return LinearPlant(
        name=name,
        coords=COORDS,
        mass=M, stiffness=K, loss_damping=np.zeros_like(M), viscous_damping=C,
        gyroscopic=G1, circulatory=np.zeros_like(M),
        actuators=actuators,
        excitations=(Excitation("unbalance", "kg*m", p2),),
        outputs=tuple(outputs),
        damping_floor_rad_s=damping_floor_rad_s,
        config=config or {},
    )
