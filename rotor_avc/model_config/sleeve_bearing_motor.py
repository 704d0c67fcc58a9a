"""``model: sleeve_bearing_motor`` (seed 001): the config sections ``motor``, ``actuator``,
``foundation``, ``environment``, ``electromagnetic`` and ``sleeve_bearing`` read into
:class:`~rotor_avc.models.sleeve_bearing_motor.MotorParams` (see
``config/sleeve_bearing_motor.yaml``)."""
from __future__ import annotations

import math

import numpy as np

from ..config import Section
from ..errors import ModelError
from ..models import sleeve_bearing_motor as model
from ..models.journal_bearing import JournalBearing, Oil
from ..models.plant import LinearPlant
from ..models.sleeve_bearing_motor import SIDES, ElectromagneticField
from ..settings import damping_floor_rad_s

#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = ("motor", "sleeve_bearing", "electromagnetic", "foundation", "actuator", "environment")
EM_MODELS = ("field_damping", "off")


def _loss_factor(sec: Section, key: str) -> float:
    value = sec.number(key, nonnegative=True)
    if value >= 0.5:
        raise sec.error(key, f"loss factor {value} is implausibly large",
                        fix="give tan(delta) as a fraction (0.04), not a percentage")
    return value


def _stiffness_zy(sec: Section, key: str) -> dict[str, float]:
    """A ``{z: .., y: ..}`` stiffness in N/m."""
    sub = sec.section(key)
    sub.check_keys(("z", "y"))
    return {d: sub.number(d, positive=True, unit="N/m") for d in ("z", "y")}


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


def _bearing(sec: Section) -> model.SleeveBearing:
    """One sleeve bearing (geometry, oil, table speeds, temperatures) from its config section."""
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
    return model.SleeveBearing(bearing, oil, speeds, sec.number("supply_temperature_c", unit="degC"),
                               effective)


def read_params(cfg: Section) -> model.MotorParams:
    """Validate and read every section of a seed-001 config."""
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
    c_b = _stiffness_zy(mot, "housing_stiffness_n_per_m")
    tan_b = _loss_factor(mot, "housing_tan_delta")
    rated = mot.number("rated_speed_rpm", positive=True, unit="rpm") * math.pi / 30

    act = cfg.section("actuator")
    act.check_keys(("stator_mass_kg", "armature_mass_kg", "stiffness_n_per_m", "tan_delta"))
    m_as = act.number("stator_mass_kg", nonnegative=True, unit="kg")
    m_aa = act.number("armature_mass_kg", nonnegative=True, unit="kg")
    c_a = _stiffness_zy(act, "stiffness_n_per_m")
    tan_a = _loss_factor(act, "tan_delta")

    fnd = cfg.section("foundation")
    fnd.check_keys(SIDES + ("tan_delta",))
    tan_f = _loss_factor(fnd, "tan_delta")
    m_f, c_f = {}, {}
    for side in SIDES:
        s = fnd.section(side)
        s.check_keys(("mass_kg", "stiffness_n_per_m"))
        m_f[side] = s.number("mass_kg", nonnegative=True, unit="kg")
        c_f[side] = _stiffness_zy(s, "stiffness_n_per_m")

    env = cfg.section("environment", {})
    env.check_keys(("gravity_m_s2",))
    g = env.number("gravity_m_s2", 9.81, positive=True, unit="m/s^2")
    return model.MotorParams(
        stator_mass_kg=m_s, stator_inertia_kg_m2=theta, rotor_mass_kg=m_w, journal_mass_kg=m_v,
        housing_mass_kg=m_b, rotor_stiffness_n_per_m=c, rotor_tan_delta=tan_i, foot_height_m=h,
        foot_half_distance_m=b, housing_stiffness_n_per_m=c_b, housing_tan_delta=tan_b,
        actuator_stator_mass_kg=m_as, actuator_armature_mass_kg=m_aa,
        actuator_stiffness_n_per_m=c_a, actuator_tan_delta=tan_a, foundation_mass_kg=m_f,
        foundation_stiffness_n_per_m=c_f, foundation_tan_delta=tan_f, gravity_m_s2=g,
        electromagnetic=_electromagnetic(cfg.section("electromagnetic"), rated),
        sleeve_bearing=_bearing(cfg.section("sleeve_bearing")))


def build(cfg: Section) -> LinearPlant:
    """The seed-001 plant of a validated config."""
    return model.build(read_params(cfg), cfg.string("name", "sleeve_bearing_motor"),
                       damping_floor_rad_s(cfg), cfg.data)
