"""Werner 2021 (Werner 2021): 18-DOF machine on four (active) feet over a soft foundation.

Generalised coordinates (eq. 10, 0-based here): machine ``z_s, y_s, x_s, phi_sz, phi_sy,
phi_sx`` and the vertical, lateral and axial displacements of the four foundation points in the
order DL, DR, NL, NR.

The matrices are assembled from the foot kinematics, which the paper defers to its ref. [22];
the actuator vectors (16)-(19) and the Appendix coefficients fix them uniquely::

    z_a,ij = z_s + alpha_i phi_sy + beta_j phi_sx
    y_a,ij = y_s - alpha_i phi_sz - h phi_sx
    x_a,ij = x_s - beta_j phi_sz + h phi_sy
    alpha_D = +a_D, alpha_N = -a_N, beta_L = -b_L, beta_R = +b_R

as ``C = sum_ij sum_q c_aq w_q w_q^T + sum c_fq e e^T`` with ``w_q = [R_q, -e_qf]``,
which reproduces the Appendix formulas (55)-(134) with the typos of (72) and (81) fixed; the test
suite checks it against the Appendix entries written out. Damping: ``D_eta`` from the same
formulas with ``c -> c tan(delta)`` (eq. 8); gyroscopic ``G[phi_sz, phi_sy] = +Omega theta_rx``
(eq. 12); excitations ``P_e = [1, -j, 0...]`` (static, per kg m) and ``P_alpha = [0, 0, 0, 1, -j,
0...]`` (moment, per kg m^2) times ``Omega^2`` (eqs. 13-14).

Mounting ``direct`` (case 1) ties each foundation point rigidly to its foot and reduces the model
to the six machine coordinates, ``q = T_r q6`` (the paper gives no model for case 1); outputs
are expanded with ``T_r``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .plant import Actuator, Excitation, LinearPlant, Output

FEET = ("DL", "DR", "NL", "NR")
DIRECTIONS = ("z", "y", "x")
MACHINE_COORDS = ("z_s", "y_s", "x_s", "phi_sz", "phi_sy", "phi_sx")
COORDS = MACHINE_COORDS + tuple(f"{d}_f{f}" for d in DIRECTIONS for f in FEET)
MOUNTS = ("actuator", "stiff_element", "none")


def foundation_index(direction: str, foot: str) -> int:
    """0-based index of a foundation-point coordinate (z: 6-9, y: 10-13, x: 14-17)."""
    return 6 + 4 * DIRECTIONS.index(direction) + FEET.index(foot)


def foot_kinematic_rows(a_D: float, a_N: float, b_L: float, b_R: float, h: float) -> dict:
    """``{(foot, direction): 6-row}``: motion of machine foot ``foot`` on the machine DOF."""
    rows = {}
    for foot in FEET:
        alpha = a_D if foot[0] == "D" else -a_N
        beta = -b_L if foot[1] == "L" else b_R
        rows[(foot, "z")] = np.array([1.0, 0, 0, 0, alpha, beta])
        rows[(foot, "y")] = np.array([0, 1.0, 0, -alpha, 0, -h])
        rows[(foot, "x")] = np.array([0, 0, 1.0, -beta, h, 0])
    return rows


@dataclass(frozen=True)
class FootElement:
    """An actuator or stiff element between a foot and the foundation (SI units)."""

    armature_mass_kg: float                  # moves with the machine foot
    stator_mass_kg: float                    # moves with the foundation point
    stiffness_n_per_m: dict[str, float]      # per direction z, y, x
    tan_delta: float


@dataclass(frozen=True)
class FootMountParams:
    """The Werner 2021 machine, its feet and the foundation (Tables 1-4; SI units)."""

    stator_mass_kg: float
    rotor_mass_kg: float
    stator_inertia_kg_m2: dict[str, float]   # about z, y, x
    rotor_polar_inertia_kg_m2: float
    rotor_transverse_inertia_kg_m2: float
    foot_height_m: float
    foot_lateral_arm_m: dict[str, float]     # L, R
    foot_axial_arm_m: dict[str, float]       # D, N
    bearing_axial_position_m: dict[str, float]   # D, N
    foundation_mass_kg: float
    foundation_tan_delta: float
    foundation_stiffness_n_per_m: dict[str, float]
    mounting: str                            # elements | direct
    mounts: dict[str, str]                   # foot -> actuator | stiff_element | none
    elements: dict[str, FootElement]         # kind -> its element


def build(p: FootMountParams, name: str, damping_floor_rad_s: float, config: dict | None = None
          ) -> LinearPlant:
    """The Werner 2021 plant from its parameters (rotor_avc.model_config.foot_mount_3d reads them
    from a config); ``config`` is kept on the plant for the record."""
    m_s, m_r = p.stator_mass_kg, p.rotor_mass_kg
    theta_s, theta_rx = p.stator_inertia_kg_m2, p.rotor_polar_inertia_kg_m2
    theta_rzy, h = p.rotor_transverse_inertia_kg_m2, p.foot_height_m
    b_L, b_R = p.foot_lateral_arm_m["L"], p.foot_lateral_arm_m["R"]
    a_D, a_N = p.foot_axial_arm_m["D"], p.foot_axial_arm_m["N"]
    l_D, l_N = p.bearing_axial_position_m["D"], p.bearing_axial_position_m["N"]
    m_f, tan_f, c_f = p.foundation_mass_kg, p.foundation_tan_delta, p.foundation_stiffness_n_per_m
    mounting, mounts, elements = p.mounting, p.mounts, p.elements

    rows = foot_kinematic_rows(a_D, a_N, b_L, b_R, h)
    n = 18
    M = np.zeros((n, n))
    C = np.zeros((n, n))
    D_eta = np.zeros((n, n))
    M[:6, :6] = np.diag([m_s + m_r] * 3 + [theta_s["z"] + theta_rzy, theta_s["y"] + theta_rzy,
                                             theta_s["x"]])
    for foot in FEET:
        el = elements.get(mounts[foot])
        for d in DIRECTIONS:
            k = foundation_index(d, foot)
            M[k, k] += m_f + (el.stator_mass_kg if el else 0.0)
            C[k, k] += c_f[d]
            D_eta[k, k] += c_f[d] * tan_f
            if el is None:
                continue
            r = rows[(foot, d)]
            M[:6, :6] += el.armature_mass_kg * np.outer(r, r)
            w = np.zeros(n)
            w[:6] = r
            w[k] = -1.0
            C += el.stiffness_n_per_m[d] * np.outer(w, w)
            D_eta += el.stiffness_n_per_m[d] * el.tan_delta * np.outer(w, w)
    G1 = np.zeros((n, n))
    G1[3, 4], G1[4, 3] = theta_rx, -theta_rx
    p_e = np.zeros(n, complex)
    p_e[:2] = [1.0, -1j]
    p_alpha = np.zeros(n, complex)
    p_alpha[3:5] = [1.0, -1j]

    # bearing housings on the rotor axis at +l_D (D) and -l_N (N), h = beta = 0
    bearing = {"D": l_D, "N": -l_N}
    out_rows: list[tuple[str, np.ndarray]] = []
    for side, pos in bearing.items():
        out_rows += [(f"bearing_{side}_vz", np.array([1.0, 0, 0, 0, pos, 0])),
                     (f"bearing_{side}_vy", np.array([0, 1.0, 0, -pos, 0, 0])),
                     (f"bearing_{side}_vx", np.array([0, 0, 1.0, 0, 0, 0]))]
    out_rows = [(name, np.concatenate([r, np.zeros(12)])) for name, r in out_rows]
    for foot in FEET:
        for d in DIRECTIONS:
            e = np.zeros(n)
            e[foundation_index(d, foot)] = 1.0
            out_rows.append((f"foundation_{foot}_v{d}", e))
    sensor = {foot: np.concatenate([rows[(foot, "z")], np.zeros(12)]) for foot in FEET}
    actuators = []
    for foot in FEET:
        if mounts[foot] == "actuator":
            P = sensor[foot].copy()
            P[foundation_index("z", foot)] = -1.0    # eqs. (16)-(19): P_a = s - e_zf
            actuators.append((foot, P))

    coords = COORDS
    if mounting == "direct":
        T = np.zeros((n, 6))                          # rigid foot-foundation tie, q = T q6
        T[:6] = np.eye(6)
        for foot in FEET:
            for d in DIRECTIONS:
                T[foundation_index(d, foot)] = rows[(foot, d)]
        M, C, D_eta, G1 = (T.T @ X @ T for X in (M, C, D_eta, G1))
        p_e, p_alpha = T.T @ p_e, T.T @ p_alpha
        out_rows = [(name, r @ T) for name, r in out_rows]
        sensor = {foot: r @ T for foot, r in sensor.items()}
        coords = MACHINE_COORDS
    return LinearPlant(
        name=name,
        coords=coords,
        mass=M, stiffness=C, loss_damping=D_eta, viscous_damping=np.zeros_like(M),
        gyroscopic=G1, circulatory=np.zeros_like(M),
        actuators=tuple(Actuator(foot, P, sensor[foot], "z") for foot, P in actuators),
        excitations=(Excitation("static", "kg*m", p_e), Excitation("moment", "kg*m^2", p_alpha)),
        outputs=tuple(Output(name, r, 1, "m/s") for name, r in out_rows),
        damping_floor_rad_s=damping_floor_rad_s,
        config=config or {},
        force_points=tuple((foot, "z") for foot in FEET),
    )
