"""Seed 001 (Werner 2019): 13-DOF plane model of a soft-mounted induction motor with sleeve
bearings and one vertical active mount under each foot line.

Generalised coordinates (eq. 6, 0-based here): ``z_s, z_w, y_s, y_w, phi_s, z_v, z_b, z_fL, z_fR,
y_v, y_b, y_fL, y_fR`` -- stator (at its centre of gravity S), rotor mass, stator roll, shaft
journals and bearing housings (both sides lumped, hence the factors 2 on their masses, springs
and oil films), left/right foundation masses. The rotor turns from +z towards +y.

M, D, C of eqs. (11)-(13) are assembled element by element (digest 3.1):

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
(digest 5; z = load direction, y = 90 deg ahead in the direction of rotation, digest 7 item 2),
tabulated over the bearing's speed range and interpolated.

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

import math

import numpy as np

from ..config import Section
from ..settings import damping_floor_rad_s
from ..errors import ModelError
from .journal_bearing import JournalBearing, Oil, coefficient_table
from .plant import Actuator, Excitation, LinearPlant, Output

COORDS = ("z_s", "z_w", "y_s", "y_w", "phi_s", "z_v", "z_b", "z_fL", "z_fR", "y_v", "y_b",
          "y_fL", "y_fR")
IX = {name: k for k, name in enumerate(COORDS)}
SIDES = ("L", "R")
#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = ("motor", "sleeve_bearing", "electromagnetic", "foundation", "actuator", "environment")
EM_MODELS = ("field_damping", "off")


def _e(*pairs) -> np.ndarray:
    v = np.zeros(len(COORDS), complex)
    for name, value in pairs:
        v[IX[name]] += value
    return v


def _loss_factor(sec: Section, key: str) -> float:
    value = sec.number(key, nonnegative=True)
    if value >= 0.5:
        raise sec.error(key, f"loss factor {value} is implausibly large",
                        fix="give tan(delta) as a fraction (0.04), not a percentage")
    return value


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


def _electromagnetic(sec: Section, rated_speed_rad_s: float) -> ElectromagneticField | None:
    model = sec.choice("model", EM_MODELS)
    if model == "off":
        sec.check_keys(("model",))
        return None
    sec.check_keys(("model", "magnetic_stiffness_n_per_m", "field_damping_depth",
                    "rotor_time_constant_s", "rated_slip_frequency_rad_s"))
    return ElectromagneticField(
        sec.number("magnetic_stiffness_n_per_m", nonnegative=True, unit="N/m"),
        sec.number("field_damping_depth", nonnegative=True, maximum=1.0),
        sec.number("rotor_time_constant_s", positive=True, unit="s"),
        sec.number("rated_slip_frequency_rad_s", nonnegative=True, unit="rad/s"),
        rated_speed_rad_s)


def _bearing(sec: Section, load_n: float):
    """The oil-film coefficient table of one sleeve bearing from its config section."""
    sec.check_keys(("diameter_m", "width_m", "relative_clearance", "oil", "supply_temperature_c",
                    "effective_temperature_c", "speed_range_rpm", "table_points", "grid"))
    oil_sec = sec.section("oil")
    oil_sec.check_keys(("nu40_mm2_s", "nu100_mm2_s", "density15_kg_m3", "expansion_per_k",
                        "heat_capacity_j_kg_k"))
    grid = sec.section("grid", {})
    grid.check_keys(("n_theta", "n_z"))
    diameter = sec.number("diameter_m", positive=True, unit="m")
    psi = sec.number("relative_clearance", positive=True, maximum=0.02)
    lo, hi = sec.number_list("speed_range_rpm", length=2)
    if not 0 < lo < hi:
        raise sec.error("speed_range_rpm", f"need 0 < min < max (got [{lo}, {hi}])",
                        fix="give [min, max] in rpm covering the analyses' speeds, "
                            "e.g. [100, 6000]")
    effective = (sec.number("effective_temperature_c", unit="degC")
                 if sec.has("effective_temperature_c") else None)
    width = sec.number("width_m", positive=True, unit="m")
    try:
        bearing = JournalBearing(diameter, width, psi * diameter / 2,
                                 grid.integer("n_theta", 120), grid.integer("n_z", 12))
    except ModelError as exc:
        raise sec.error("grid" if "grid" in str(exc) else "relative_clearance", str(exc)) from None
    try:
        oil = Oil(oil_sec.number("nu40_mm2_s", positive=True, unit="mm^2/s"),
                  oil_sec.number("nu100_mm2_s", positive=True, unit="mm^2/s"),
                  oil_sec.number("density15_kg_m3", positive=True, unit="kg/m^3"),
                  oil_sec.number("expansion_per_k", nonnegative=True, unit="1/K"),
                  oil_sec.number("heat_capacity_j_kg_k", positive=True, unit="J/(kg K)"))
    except ModelError as exc:
        raise sec.error("oil", str(exc)) from None
    speeds = np.geomspace(lo, hi, sec.integer("table_points", 64, minimum=8)) * math.pi / 30
    return coefficient_table(bearing, oil, load_n, speeds,
                             sec.number("supply_temperature_c", unit="degC"), effective)


def build(cfg: Section) -> LinearPlant:
    """Build the seed-001 plant from a config (see ``config/sleeve_bearing_motor.yaml``)."""
    mot = cfg.section("motor")
    mot.check_keys(("rated_speed_rpm", "stator_mass_kg", "stator_inertia_kg_m2", "rotor_mass_kg",
                    "journal_mass_kg", "housing_mass_kg", "rotor_stiffness_n_per_m",
                    "rotor_tan_delta", "foot_height_m", "foot_half_distance_m",
                    "housing_stiffness_n_per_m", "housing_tan_delta"))
    m_s = mot.number("stator_mass_kg", positive=True, unit="kg")
    theta = mot.number("stator_inertia_kg_m2", positive=True, unit="kg m^2")
    m_w = mot.number("rotor_mass_kg", positive=True, unit="kg")
    m_v = mot.number("journal_mass_kg", positive=True, unit="kg")
    m_b = mot.number("housing_mass_kg", positive=True, unit="kg")
    c = mot.number("rotor_stiffness_n_per_m", positive=True, unit="N/m")
    tan_i = _loss_factor(mot, "rotor_tan_delta")
    h = mot.number("foot_height_m", nonnegative=True, unit="m")
    b = mot.number("foot_half_distance_m", positive=True, unit="m")
    hs = mot.section("housing_stiffness_n_per_m")
    hs.check_keys(("z", "y"))
    c_b = {d: hs.number(d, positive=True, unit="N/m") for d in ("z", "y")}
    tan_b = _loss_factor(mot, "housing_tan_delta")
    rated = mot.number("rated_speed_rpm", positive=True, unit="rpm") * math.pi / 30

    act = cfg.section("actuator")
    act.check_keys(("stator_mass_kg", "armature_mass_kg", "stiffness_n_per_m", "tan_delta"))
    m_as = act.number("stator_mass_kg", nonnegative=True, unit="kg")
    m_aa = act.number("armature_mass_kg", nonnegative=True, unit="kg")
    acs = act.section("stiffness_n_per_m")
    acs.check_keys(("z", "y"))
    c_a = {d: acs.number(d, positive=True, unit="N/m") for d in ("z", "y")}
    tan_a = _loss_factor(act, "tan_delta")

    fnd = cfg.section("foundation")
    fnd.check_keys(SIDES + ("tan_delta",))
    tan_f = _loss_factor(fnd, "tan_delta")
    m_f, c_f = {}, {}
    for side in SIDES:
        s = fnd.section(side)
        s.check_keys(("mass_kg", "stiffness_n_per_m"))
        m_f[side] = s.number("mass_kg", nonnegative=True, unit="kg")
        st = s.section("stiffness_n_per_m")
        st.check_keys(("z", "y"))
        c_f[side] = {d: st.number(d, positive=True, unit="N/m") for d in ("z", "y")}

    env = cfg.section("environment", {})
    env.check_keys(("gravity_m_s2",))
    g = env.number("gravity_m_s2", 9.81, positive=True, unit="m/s^2")

    # -- elements -> M, C, D_eta ---------------------------------------------------------------
    n = len(COORDS)
    M, C, D_eta = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))

    def spring(k: float, tan_delta: float, *pairs):
        w = _e(*pairs).real
        C[:] += k * np.outer(w, w)
        D_eta[:] += k * tan_delta * np.outer(w, w)

    foot_z = {"L": (("z_s", 1.0), ("phi_s", -b)), "R": (("z_s", 1.0), ("phi_s", b))}
    foot_y = (("y_s", 1.0), ("phi_s", -h))
    for name, mass in (("z_s", m_s), ("y_s", m_s), ("phi_s", theta), ("z_w", m_w), ("y_w", m_w),
                       ("z_v", 2 * m_v), ("y_v", 2 * m_v), ("z_b", 2 * m_b), ("y_b", 2 * m_b)):
        M[IX[name], IX[name]] += mass
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
    em = _electromagnetic(cfg.section("electromagnetic"), rated)
    oil = _bearing(cfg.section("sleeve_bearing"), (m_w / 2 + m_v) * g)
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
        name=cfg.string("name", "sleeve_bearing_motor"), coords=COORDS,
        mass=M, stiffness=C, loss_damping=D_eta, viscous_damping=np.zeros((n, n)),
        gyroscopic=np.zeros((n, n)), circulatory=N_eta, actuators=tuple(actuators),
        excitations=excitations, outputs=tuple(outputs), damping_floor_rad_s=damping_floor_rad_s(cfg),
        speed_terms=speed_terms, config=cfg.data)
