"""Werner 2017 (Werner 2017): flexible rotor with internal damping on roller bearings, bearing
housings/end shields and a rigid stator on a soft foundation -- a 9-DOF plane model.

Generalised coordinates (eq. 7, the paper's order): ``z_s, z_w, y_s, y_w, phi_s, z_v, z_b, y_v,
y_b`` -- stator centre of gravity S (vertical, horizontal, roll about x), rotor mass at mid-span,
shaft journals and bearing housings (both machine sides lumped; masses, bearing, housing and foot
stiffnesses are per side, ``c`` is the total shaft stiffness). Mass matrix eq. (8).

Stiffness and loss-factor damping (eqs. 2-4, 9-10; the available text of the paper lacks the
matrices of eqs. 9-10, so they are rebuilt from its model description) are assembled from the
springs ``k w w^T``: shaft ``c`` on ``z_w - z_v`` and ``y_w - y_v``; roller bearings ``2 c_r`` on
``z_b - z_v`` (no damping); housings ``2 c_b`` on ``z_s - z_b``; feet ``c_fz`` on
``z_f = z_s -+ b phi_s`` and ``2 c_fy`` on ``y_f = y_s - h phi_s`` (eq. 5). ``D_eta`` carries the
same springs times their loss factors (``d = c tan(delta) / w_F``). The internal damping's
circulatory part ``d_i Omega`` (the skew entries of eq. 9) is ``N_eta = c tan(delta_i) (w_z w_y^T
- w_y w_z^T)`` with the shaft deflections ``w_z, w_y``, so that ``C += Omega / w_F N_eta``; the
rotor turns and whirls forward from +z towards +y.

``foundation.kind: rigid`` (Table 2 cases d, e) deletes ``z_s, y_s, phi_s``: a 6-DOF rotor whose
housings are grounded. Actuators ``L``/``R`` push vertically between each foot and the ground
(``P_a = s = e_zs -+ b e_phi``) and the unbalance acts on the rotor mass (``f_z + j f_y = m e
Omega^2 e^{j(Omega t + phi)}``); both are additions, as the paper has neither.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .plant import Actuator, Excitation, LinearPlant, Output

COORDS = ("z_s", "z_w", "y_s", "y_w", "phi_s", "z_v", "z_b", "y_v", "y_b")
ROTOR_SIDE = ("z_w", "y_w", "z_v", "z_b", "y_v", "y_b")


@dataclass(frozen=True)
class RotorParams:
    """The model's parameters in SI units (per side unless stated)."""

    m_s: float
    theta_sx: float
    h: float
    b: float
    m_w: float
    c: float
    tan_i: float
    m_v: float
    c_rz: float
    c_ry: float
    m_b: float
    c_bz: float
    c_by: float
    tan_b: float
    rigid: bool
    c_fz: float
    c_fy: float
    tan_f: float


def eq14_whirl_rad_s(p: RotorParams) -> float:
    """Start value of the whirl-frequency iteration, eq. (14): the rotor mass on the series chain
    shaft - bearings - housings of the (assumed softer) horizontal direction, rigidly mounted and
    undamped: ``sqrt(c_total / m_w)``, ``1/c_total = 1/c + 1/(2 c_ry) + 1/(2 c_by)``."""
    c_total = 1.0 / (1.0 / p.c + 1.0 / (2.0 * p.c_ry) + 1.0 / (2.0 * p.c_by))
    return float(np.sqrt(c_total / p.m_w))


def _unit(name: str) -> np.ndarray:
    e = np.zeros(len(COORDS))
    e[COORDS.index(name)] = 1.0
    return e


def _springs(p: RotorParams) -> list[tuple[float, float, np.ndarray]]:
    """``(stiffness, loss factor, w)`` of every spring of eqs. (9)-(10)."""
    e = {name: _unit(name) for name in COORDS}
    foot_y = e["y_s"] - p.h * e["phi_s"]
    return [
        (p.c, p.tan_i, e["z_w"] - e["z_v"]), (p.c, p.tan_i, e["y_w"] - e["y_v"]),   # shaft
        (2 * p.c_rz, 0.0, e["z_b"] - e["z_v"]), (2 * p.c_ry, 0.0, e["y_b"] - e["y_v"]),  # bearings
        (2 * p.c_bz, p.tan_b, e["z_s"] - e["z_b"]), (2 * p.c_by, p.tan_b, e["y_s"] - e["y_b"]),
        (p.c_fz, p.tan_f, e["z_s"] - p.b * e["phi_s"]), (p.c_fz, p.tan_f, e["z_s"] + p.b * e["phi_s"]),
        (2 * p.c_fy, p.tan_f, foot_y),                                              # feet (eq. 5)
    ]


def matrices(p: RotorParams) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(M, C, D_eta, N_eta)`` of the 9-DOF model (eqs. 8-10 with ``D = D_eta / w_F`` and
    ``C(Omega) = C + Omega / w_F N_eta``)."""
    M = np.diag([p.m_s, p.m_w, p.m_s, p.m_w, p.theta_sx, 2 * p.m_v, 2 * p.m_b, 2 * p.m_v, 2 * p.m_b])
    C = np.zeros((9, 9))
    D_eta = np.zeros((9, 9))
    for k, tan_delta, w in _springs(p):
        C += k * np.outer(w, w)
        D_eta += k * tan_delta * np.outer(w, w)
    w_z, w_y = _unit("z_w") - _unit("z_v"), _unit("y_w") - _unit("y_v")
    N_eta = p.c * p.tan_i * (np.outer(w_z, w_y) - np.outer(w_y, w_z))
    return M, C, D_eta, N_eta


def build(p: RotorParams, name: str, damping_floor_rad_s: float, config: dict | None = None
          ) -> LinearPlant:
    """The Werner 2017 plant from its parameters (rotor_avc.model_config.roller_bearing_rotor reads
    them from a config); ``config`` is kept on the plant for the record."""
    M, C, D_eta, N_eta = matrices(p)
    e = {name: _unit(name) for name in COORDS}
    foot = {"L": e["z_s"] - p.b * e["phi_s"], "R": e["z_s"] + p.b * e["phi_s"]}
    foot_y = e["y_s"] - p.h * e["phi_s"]
    unbalance = (e["z_w"] - 1j * e["y_w"]).astype(complex)
    outputs = [Output("housing_vz", e["z_b"], 1, "m/s"), Output("housing_vy", e["y_b"], 1, "m/s"),
               Output("rotor_z", e["z_w"], 0, "m"), Output("rotor_y", e["y_w"], 0, "m")]
    actuators: list[Actuator] = []
    keep = list(range(9))
    if p.rigid:
        keep = [COORDS.index(name) for name in ROTOR_SIDE]
    else:
        for fid, row in foot.items():
            outputs += [Output(f"foot_{fid}_az", row, 2, "m/s^2"), Output(f"foot_{fid}_vz", row, 1, "m/s")]
            actuators.append(Actuator(fid, row, row, "z"))
        outputs += [Output("foot_ay", foot_y, 2, "m/s^2"), Output("foot_vy", foot_y, 1, "m/s")]
    ix = np.ix_(keep, keep)
    return LinearPlant(
        name=name,
        coords=tuple(COORDS[i] for i in keep),
        mass=M[ix], stiffness=C[ix], loss_damping=D_eta[ix],
        viscous_damping=np.zeros((len(keep), len(keep))),
        gyroscopic=np.zeros((len(keep), len(keep))), circulatory=N_eta[ix],
        actuators=tuple(Actuator(a.id, a.force_vector[keep], a.sensor_row[keep], a.axis)
                        for a in actuators),
        excitations=(Excitation("unbalance", "kg*m", unbalance[keep]),),
        outputs=tuple(Output(o.name, o.row[keep], o.order, o.unit) for o in outputs),
        damping_floor_rad_s=damping_floor_rad_s,
        config=config or {},
    )
