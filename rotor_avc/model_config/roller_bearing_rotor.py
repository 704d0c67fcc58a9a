"""``model: roller_bearing_rotor`` (seed 003): the config sections ``stator``, ``rotor``,
``bearings``, ``housings`` and ``foundation`` read into :class:`~rotor_avc.models.
roller_bearing_rotor.RotorParams` (see ``config/roller_bearing_stability.yaml``)."""
from __future__ import annotations

from ..config import Section
from ..models import roller_bearing_rotor as model
from ..models.plant import LinearPlant
from ..settings import damping_floor_rad_s

#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS); ``variants``
#: and ``studies`` are read by rotor_avc.analysis.stability_study
MODEL_KEYS = ("stator", "rotor", "bearings", "housings", "foundation", "variants", "studies")
FOUNDATION_KINDS = ("soft", "rigid")


def _loss_factor(sec: Section) -> float:
    value = sec.number("tan_delta", nonnegative=True)
    if value >= 1.0:
        raise sec.error("tan_delta", f"loss factor {value} is not a loss factor tan(delta) < 1",
                        fix="give tan(delta) (e.g. 0.04), not a percentage")
    return value


def _zy(sec: Section, key: str, unit: str) -> tuple[float, float]:
    sub = sec.section(key)
    sub.check_keys(("z", "y"))
    return sub.number("z", positive=True, unit=unit), sub.number("y", positive=True, unit=unit)


def read_params(cfg: Section) -> model.RotorParams:
    """Validate and read the config sections ``stator``, ``rotor``, ``bearings``, ``housings``,
    ``foundation`` (see ``config/roller_bearing_stability.yaml``)."""
    st = cfg.section("stator")
    st.check_keys(("mass_kg", "roll_inertia_kg_m2", "cog_height_m", "foot_half_distance_m"))
    ro = cfg.section("rotor")
    ro.check_keys(("mass_kg", "shaft_stiffness_n_per_m", "tan_delta", "journal_mass_kg"))
    br = cfg.section("bearings")
    br.check_keys(("stiffness_n_per_m",))
    ho = cfg.section("housings")
    ho.check_keys(("mass_kg", "stiffness_n_per_m", "tan_delta"))
    fo = cfg.section("foundation")
    fo.check_keys(("kind", "stiffness_n_per_m", "tan_delta"))
    rigid = fo.choice("kind", FOUNDATION_KINDS) == "rigid"
    c_rz, c_ry = _zy(br, "stiffness_n_per_m", "N/m")
    c_bz, c_by = _zy(ho, "stiffness_n_per_m", "N/m")
    if rigid:       # the foundation's stiffness and damping do not enter (digest 3.3)
        c_fz = c_fy = tan_f = 0.0
    else:
        (c_fz, c_fy), tan_f = _zy(fo, "stiffness_n_per_m", "N/m"), _loss_factor(fo)
    return model.RotorParams(
        m_s=st.number("mass_kg", positive=True, unit="kg"),
        theta_sx=st.number("roll_inertia_kg_m2", positive=True, unit="kg m^2"),
        h=st.number("cog_height_m", nonnegative=True, unit="m"),
        b=st.number("foot_half_distance_m", positive=True, unit="m"),
        m_w=ro.number("mass_kg", positive=True, unit="kg"),
        c=ro.number("shaft_stiffness_n_per_m", positive=True, unit="N/m"),
        tan_i=_loss_factor(ro),
        m_v=ro.number("journal_mass_kg", positive=True, unit="kg"),
        c_rz=c_rz, c_ry=c_ry,
        m_b=ho.number("mass_kg", positive=True, unit="kg"),
        c_bz=c_bz, c_by=c_by, tan_b=_loss_factor(ho),
        rigid=rigid, c_fz=c_fz, c_fy=c_fy, tan_f=tan_f)


def whirl_start_rad_s(cfg: Section) -> float:
    """The model's start value of the whirl-frequency iteration (eq. 14) for a config."""
    return model.eq14_whirl_rad_s(read_params(cfg))


def build(cfg: Section) -> LinearPlant:
    """The seed-003 plant of a validated config."""
    return model.build(read_params(cfg), cfg.string("name", "roller_bearing_rotor"),
                       damping_floor_rad_s(cfg), cfg.data)
