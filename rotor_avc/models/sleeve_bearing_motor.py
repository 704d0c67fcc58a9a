"""Werner 2019 (Werner 2019): 13-DOF plane model of a soft-mounted induction motor with sleeve
bearings and one vertical active mount under each foot line.

Generalised coordinates (eq. 6, 0-based here): ``z_s, z_w, y_s, y_w, phi_s, z_v, z_b, z_fL, z_fR,
y_v, y_b, y_fL, y_fR`` -- stator (at its centre of gravity S), rotor mass, stator roll, shaft
journals and bearing housings (both sides lumped, hence the factors 2 on their masses, springs
and oil films), left/right foundation masses. The rotor turns from +z towards +y.

M, D, C of eqs. (11)-(13) are assembled element by element:

* shaft ``c`` (rotor mass - journals), loss factor ``tan delta_i``, and its rotating damping as
  circulatory stiffness ``d_i Omega (r_z r_y^T - r_y r_z^T)`` with ``r = e_w - e_v``;
* magnetic field (rotor mass - stator): negative spring ``-c_md`` and damper ``d_m`` in z and y;
* oil films (journals - housings): ``2 [c_ij]``, ``2 [d_ij]`` per bearing pair (``speed_terms``);
* housings + end shields (housings - stator): ``2 c_bz``, ``2 c_by``, loss factor ``tan delta_b``;
* actuators (feet ``z_aL,R = z_s -/+ b phi_s``, ``y_a = y_s - h phi_s`` - foundation masses):
  ``c_az``, ``c_ay`` per side, loss factor ``tan delta_a``; the armatures (``m_aa``) ride on the
  feet, the actuator stators (``m_as``) on the foundation masses;
* foundation masses to ground: ``c_fz``, ``c_fy`` per side, loss factor ``tan delta_f``.

Loss-factor damping ``d_n = c_n tan(delta_n) / w_F`` (eq. 1). Actuator ``L`` (``R``): force
vector ``P_az = e1 -/+ b e5 - e8 (e9)`` (eqs. 16-17), sensor row ``z_a = e1 -/+ b e5``.

**Oil films** (paper Fig. 3, missing): the eight coefficients of each bearing from the Reynolds
equation, :mod:`rotor_avc.models.journal_bearing`, under the static load ``(m_w / 2 + m_v) g``
(assumed: the paper states neither the load nor its direction; z = load direction, y = 90 deg
ahead in the direction of rotation), tabulated over the bearing's speed range and interpolated.

**Electromagnetic field** (paper Fig. 4, missing) -- an eccentricity-field model after
Fruechtenicht, Jordan & Seinsch (the paper's refs. [21], [23]): a whirl of the rotor at ``w_F``
creates two eccentricity field waves (pole pairs ``p +/- 1``) whose frequencies seen from the
rotor are ``w_slip +/- (w_F - Omega)`` (``w_slip``: the rotor-frame frequency of the main field).
Rotor-cage currents damp each wave as a first-order lag with time constant ``T_r`` and depth
``k_D``, so the force on the rotor per unit whirl amplitude is::

    c_md - j w_F d_m = c_m [1 - k_D / 2 * sum_+- j x_+- / (1 + j x_+-)]
    x_+- = T_r (w_slip +- (w_F - Omega))

Operating point (paper Sec. 4.1): quadratic load torque; constant flux up to the rated speed
``n_N`` (``c_m`` = its rated value, slip frequency ``w_slip,N (n / n_N)^2``), field weakening
above (flux ~ ``n_N / n``: ``c_m ~ (n_N / n)^2``, ``w_slip ~ (n / n_N)^4``). Magnetic
eccentricity (eq. 9) excites with ``(c_md - j Omega d_m) e_m`` at ``w_F = Omega``.

Excitations per unit amplitude (m), eqs. (8)-(10): ``mass_eccentricity`` ``m_w Omega^2 (e2 - j
e4)``; ``magnetic_eccentricity`` ``(c_md - j Omega d_m)(-e1 + e2 + j e3 - j e4)``; ``bent_rotor``
``c (e2 - j e4 - e6 + j e10)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .journal_bearing import JournalBearing, Oil, coefficient_table
from .plant import Actuator, Excitation, LinearPlant, Output

COORDS = ("z_s", "z_w", "y_s", "y_w", "phi_s", "z_v", "z_b", "z_fL", "z_fR", "y_v", "y_b",
          "y_fL", "y_fR")
IX = {name: k for k, name in enumerate(COORDS)}
SIDES = ("L", "R")


def _e(*pairs) -> np.ndarray:
    v = np.zeros(len(COORDS), complex)
    for name, value in pairs:
        v[IX[name]] += value
    return v


class ElectromagneticField:
    """Magnetic spring ``c_md`` and field damping ``d_m`` (see the module docstring)."""

    def __init__(self, c_m: float, k_D: float, T_r: float, slip_rated_rad_s: float,
                 rated_speed_rad_s: float):
        self.c_m, self.k_D, self.T_r = c_m, k_D, T_r
        self.slip_rated, self.rated_speed = slip_rated_rad_s, rated_speed_rad_s

    def stiffness(self, speed, w_F) -> np.ndarray:
        """Complex ``c_md - j w_F d_m`` (N/m) at rotor speed ``speed``, whirl ``w_F`` (rad/s)."""
        ratio = np.abs(np.asarray(speed, float)) / self.rated_speed
        flux2 = np.where(ratio <= 1.0, 1.0, 1.0 / np.maximum(ratio, 1.0) ** 2)
        slip = self.slip_rated * ratio**2 / flux2
        shift = np.asarray(w_F, float) - np.abs(np.asarray(speed, float))
        x = self.T_r * (slip + shift), self.T_r * (slip - shift)
        return self.c_m * flux2 * (1 - 0.5 * self.k_D * sum(1j * v / (1 + 1j * v) for v in x))

    def coefficients(self, speed, w_F) -> tuple[np.ndarray, np.ndarray]:
        """``(c_md, d_m)`` in N/m and N s/m (eq. 12-13 entries) at ``speed``, ``w_F`` (rad/s)."""
        K = self.stiffness(speed, w_F)
        return K.real, -K.imag / np.asarray(w_F, float)

    def pull(self, speed) -> np.ndarray:
        """``c_md - j Omega d_m`` at synchronous whirl ``w_F = Omega``: eq. (9)'s factor, N/m."""
        return self.stiffness(speed, np.abs(np.asarray(speed, float)))


@dataclass(frozen=True)
class SleeveBearing:
    """One sleeve bearing: geometry, oil, the speeds of its coefficient table, temperatures."""

    bearing: JournalBearing
    oil: Oil
    speeds_rad_s: np.ndarray
    supply_temperature_c: float
    effective_temperature_c: float | None = None


@dataclass(frozen=True)
class MotorParams:
    """The Werner 2019 motor, its actuators and foundation (SI units; per side where stated)."""

    stator_mass_kg: float
    stator_inertia_kg_m2: float
    rotor_mass_kg: float
    journal_mass_kg: float
    housing_mass_kg: float
    rotor_stiffness_n_per_m: float
    rotor_tan_delta: float
    foot_height_m: float
    foot_half_distance_m: float
    housing_stiffness_n_per_m: dict[str, float]       # z, y
    housing_tan_delta: float
    actuator_stator_mass_kg: float
    actuator_armature_mass_kg: float
    actuator_stiffness_n_per_m: dict[str, float]      # z, y
    actuator_tan_delta: float
    foundation_mass_kg: dict[str, float]              # side L, R
    foundation_stiffness_n_per_m: dict[str, dict[str, float]]   # side -> z, y
    foundation_tan_delta: float
    gravity_m_s2: float
    electromagnetic: ElectromagneticField | None
    sleeve_bearing: SleeveBearing


def build(p: MotorParams, name: str, damping_floor_rad_s: float, config: dict | None = None
          ) -> LinearPlant:
    """The Werner 2019 plant from its parameters (rotor_avc.model_config.sleeve_bearing_motor reads
    them from a config); ``config`` is kept on the plant for the record."""
    m_s, theta, m_w = p.stator_mass_kg, p.stator_inertia_kg_m2, p.rotor_mass_kg
    m_v, m_b = p.journal_mass_kg, p.housing_mass_kg
    c, tan_i = p.rotor_stiffness_n_per_m, p.rotor_tan_delta
    h, b = p.foot_height_m, p.foot_half_distance_m
    c_b, tan_b = p.housing_stiffness_n_per_m, p.housing_tan_delta
    m_as, m_aa = p.actuator_stator_mass_kg, p.actuator_armature_mass_kg
    c_a, tan_a = p.actuator_stiffness_n_per_m, p.actuator_tan_delta
    m_f, c_f, tan_f = p.foundation_mass_kg, p.foundation_stiffness_n_per_m, p.foundation_tan_delta
    g, em, sb = p.gravity_m_s2, p.electromagnetic, p.sleeve_bearing

    # -- elements -> M, C, D_eta ---------------------------------------------------------------
    n = len(COORDS)
    M, C, D_eta = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))

    def spring(k: float, tan_delta: float, *pairs):
        w = _e(*pairs).real
        C[:] += k * np.outer(w, w)
        D_eta[:] += k * tan_delta * np.outer(w, w)

    foot_z = {"L": (("z_s", 1.0), ("phi_s", -b)), "R": (("z_s", 1.0), ("phi_s", b))}
    foot_y = (("y_s", 1.0), ("phi_s", -h))
    for coord, mass in (("z_s", m_s), ("y_s", m_s), ("phi_s", theta), ("z_w", m_w), ("y_w", m_w),
                        ("z_v", 2 * m_v), ("y_v", 2 * m_v), ("z_b", 2 * m_b), ("y_b", 2 * m_b)):
        M[IX[coord], IX[coord]] += mass
    for side in SIDES:
        for rows in (foot_z[side], foot_y):
            w = _e(*rows).real
            M += m_aa * np.outer(w, w)
        for d in ("z", "y"):
            M[IX[f"{d}_f{side}"], IX[f"{d}_f{side}"]] += m_as + m_f[side]
            spring(c_f[side][d], tan_f, (f"{d}_f{side}", 1.0))
        spring(c_a["z"], tan_a, *foot_z[side], (f"z_f{side}", -1.0))
        spring(c_a["y"], tan_a, *foot_y, (f"y_f{side}", -1.0))
    for d in ("z", "y"):
        spring(c, tan_i, (f"{d}_w", 1.0), (f"{d}_v", -1.0))
        spring(2 * c_b[d], tan_b, (f"{d}_b", 1.0), (f"{d}_s", -1.0))
    r_z, r_y = _e(("z_w", 1.0), ("z_v", -1.0)).real, _e(("y_w", 1.0), ("y_v", -1.0)).real
    N_eta = c * tan_i * (np.outer(r_z, r_y) - np.outer(r_y, r_z))

    # -- oil films and magnetic field: speed_terms ----------------------------------------------
    oil = coefficient_table(sb.bearing, sb.oil, (m_w / 2 + m_v) * g, sb.speeds_rad_s,
                            sb.supply_temperature_c, sb.effective_temperature_c)
    film = np.zeros((2, n))                          # journal - housing, z and y
    film[0, [IX["z_v"], IX["z_b"]]] = 1.0, -1.0
    film[1, [IX["y_v"], IX["y_b"]]] = 1.0, -1.0
    film_patterns = 2 * np.einsum("ai,bj->abij", film, film)   # 2 [c_ab] -> C, per (a, b)
    mag = np.zeros((2, n))                           # rotor - stator, z and y
    mag[0, [IX["z_w"], IX["z_s"]]] = 1.0, -1.0
    mag[1, [IX["y_w"], IX["y_s"]]] = 1.0, -1.0
    mag_pattern = mag.T @ mag

    def speed_terms(speed, w_F):
        K, Dm = oil.at(np.abs(speed))
        dC = np.tensordot(K, film_patterns, axes=([-2, -1], [0, 1]))
        dD = np.tensordot(Dm, film_patterns, axes=([-2, -1], [0, 1]))
        if em is not None:
            c_md, d_m = em.coefficients(speed, w_F)
            dC -= np.asarray(c_md)[..., None, None] * mag_pattern
            dD += np.asarray(d_m)[..., None, None] * mag_pattern
        return dC, dD

    # -- actuators, excitations, outputs -------------------------------------------------------
    actuators = []
    for side in SIDES:
        sensor = _e(*foot_z[side]).real
        actuators.append(Actuator(side, sensor - _e((f"z_f{side}", 1.0)).real, sensor, "z"))
    zero = np.zeros(n, complex)
    magnetic = _e(("z_s", -1.0), ("z_w", 1.0), ("y_s", 1j), ("y_w", -1j)) if em else zero
    excitations = (
        Excitation("mass_eccentricity", "m", m_w * _e(("z_w", 1.0), ("y_w", -1j))),
        Excitation("magnetic_eccentricity", "m", zero, None, magnetic,
                   em.pull if em else None),
        Excitation("bent_rotor", "m", zero, None,
                   c * _e(("z_w", 1.0), ("y_w", -1j), ("z_v", -1.0), ("y_v", 1j))),
    )
    outputs = [Output(f"bearing_v{d}", _e((f"{d}_b", 1.0)).real, 1, "m/s") for d in ("z", "y")]
    outputs += [Output(f"foundation_{side}_v{d}", _e((f"{d}_f{side}", 1.0)).real, 1, "m/s")
                for side in SIDES for d in ("z", "y")]
    return LinearPlant(
        name=name, coords=COORDS,
        mass=M, stiffness=C, loss_damping=D_eta, viscous_damping=np.zeros((n, n)),
        gyroscopic=np.zeros((n, n)), circulatory=N_eta, actuators=tuple(actuators),
        excitations=excitations, outputs=tuple(outputs), damping_floor_rad_s=damping_floor_rad_s,
        speed_terms=speed_terms, config=config or {})
