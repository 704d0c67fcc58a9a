"""``model: foot_mount_3d`` (seed 000): the config sections ``machine``, ``foundation``,
``mounting``, ``feet`` and ``elements`` read into :class:`~rotor_avc.models.foot_mount_3d.
FootMountParams` (see ``config/foot_mount_*.yaml``)."""
from __future__ import annotations

from ..config import Section
from ..models import foot_mount_3d as model
from ..models.foot_mount_3d import DIRECTIONS, FEET, MOUNTS
from ..models.plant import LinearPlant
from ..settings import damping_floor_rad_s

#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = ("machine", "foundation", "mounting", "elements", "feet")
#: what the machine built from this model supports (rotor_avc.machine.CAPABILITIES)
SUPPORTS = ("plane_balancer",)


def _xyz(sec: Section, key: str, *, positive: bool, unit: str) -> dict[str, float]:
    sub = sec.section(key)
    sub.check_keys(DIRECTIONS)
    return {d: sub.number(d, positive=positive, nonnegative=True, unit=unit) for d in DIRECTIONS}


def _loss_factor(sec: Section, key: str = "tan_delta") -> float:
    value = sec.number(key, nonnegative=True)
    if value >= 0.2:
        raise sec.error(key, f"loss factor {value} is outside the model's range (eq. 44 needs "
                             "tan(delta) < 0.2)", fix="give the loss factor tan(delta), not a percentage")
    return value


def _element(sec: Section) -> model.FootElement:
    sec.check_keys(("armature_mass_kg", "stator_mass_kg", "stiffness_n_per_m", "tan_delta"))
    return model.FootElement(
        armature_mass_kg=sec.number("armature_mass_kg", nonnegative=True, unit="kg"),
        stator_mass_kg=sec.number("stator_mass_kg", nonnegative=True, unit="kg"),
        stiffness_n_per_m=_xyz(sec, "stiffness_n_per_m", positive=True, unit="N/m"),
        tan_delta=_loss_factor(sec))


def read_params(cfg: Section) -> model.FootMountParams:
    """Validate and read the sections ``machine``, ``foundation``, ``mounting``, ``feet`` and
    ``elements``."""
    mach = cfg.section("machine")
    mach.check_keys(("stator_mass_kg", "rotor_mass_kg", "stator_inertia_kg_m2",
                     "rotor_polar_inertia_kg_m2", "rotor_transverse_inertia_kg_m2",
                     "foot_height_m", "foot_lateral_arm_m", "foot_axial_arm_m",
                     "bearing_axial_position_m"))
    m_s = mach.number("stator_mass_kg", positive=True, unit="kg")
    m_r = mach.number("rotor_mass_kg", positive=True, unit="kg")
    theta_s = _xyz(mach, "stator_inertia_kg_m2", positive=True, unit="kg m^2")
    theta_rx = mach.number("rotor_polar_inertia_kg_m2", nonnegative=True, unit="kg m^2")
    theta_rzy = mach.number("rotor_transverse_inertia_kg_m2", nonnegative=True, unit="kg m^2")
    h = mach.number("foot_height_m", nonnegative=True, unit="m")
    lat = mach.section("foot_lateral_arm_m")
    lat.check_keys(("L", "R"))
    ax = mach.section("foot_axial_arm_m")
    ax.check_keys(("D", "N"))
    brg = mach.section("bearing_axial_position_m")
    brg.check_keys(("D", "N"))
    b_L, b_R = lat.number("L", positive=True, unit="m"), lat.number("R", positive=True, unit="m")
    a_D, a_N = ax.number("D", positive=True, unit="m"), ax.number("N", positive=True, unit="m")
    l_D, l_N = brg.number("D", nonnegative=True, unit="m"), brg.number("N", nonnegative=True, unit="m")

    fnd = cfg.section("foundation")
    fnd.check_keys(("mass_kg", "tan_delta", "stiffness_n_per_m"))
    m_f = fnd.number("mass_kg", positive=True, unit="kg")
    tan_f = _loss_factor(fnd)
    c_f = _xyz(fnd, "stiffness_n_per_m", positive=True, unit="N/m")

    mounting = cfg.choice("mounting", ("elements", "direct"))
    feet_sec = cfg.section("feet", {}) if mounting == "direct" else cfg.section("feet")
    feet_sec.check_keys(FEET)
    mounts = {f: feet_sec.choice(f, MOUNTS, default="none") for f in FEET}
    if mounting == "direct" and any(m != "none" for m in mounts.values()):
        raise cfg.error("feet", "mounting: direct ties every foot rigidly to the foundation, so "
                                "no foot can carry an element",
                        fix="set every foot to `none` or use `mounting: elements`")
    elements_sec = cfg.section("elements", {})
    elements_sec.check_keys(("actuator", "stiff_element"))
    elements = {kind: _element(elements_sec.section(kind))     # every one given is validated
                for kind in set(elements_sec.keys()) | (set(mounts.values()) - {"none"})}
    return model.FootMountParams(
        stator_mass_kg=m_s, rotor_mass_kg=m_r, stator_inertia_kg_m2=theta_s,
        rotor_polar_inertia_kg_m2=theta_rx, rotor_transverse_inertia_kg_m2=theta_rzy,
        foot_height_m=h, foot_lateral_arm_m={"L": b_L, "R": b_R},
        foot_axial_arm_m={"D": a_D, "N": a_N}, bearing_axial_position_m={"D": l_D, "N": l_N},
        foundation_mass_kg=m_f, foundation_tan_delta=tan_f, foundation_stiffness_n_per_m=c_f,
        mounting=mounting, mounts=mounts, elements=elements)


def build(cfg: Section) -> LinearPlant:
    """The seed-000 plant of a validated config."""
    return model.build(read_params(cfg), cfg.string("name", "foot_mount_3d"),
                       damping_floor_rad_s(cfg), cfg.data)
