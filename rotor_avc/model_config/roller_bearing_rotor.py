"""``model: roller_bearing_rotor`` (Werner 2017): the config sections ``stator``, ``rotor``,
``bearings``, ``housings`` and ``foundation``, declared once with the ``variants`` and ``studies``
of the threshold studies (:data:`MODEL_SETTINGS`), and read into :class:`~rotor_avc.models.
roller_bearing_rotor.RotorParams` (see ``config/roller_bearing_stability.yaml``).

Werner 2017's Table 1 (the machine data) is missing from the available text: the config says
which value is stated in the text, inferred from the paper's results or assumed. Values are per
machine side (one bearing, housing, foot, journal) except the total shaft stiffness."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..section import Section
from ..models import roller_bearing_rotor as model
from ..models.plant import LinearPlant
from ..settings import damping_floor_rad_s, read_part, setting
from .sleeve_bearing_motor import StiffnessZY

FOUNDATION_KINDS = ("soft", "rigid")


def _check_loss_factor(sec: Section, tan_delta: float) -> None:
    if tan_delta >= 1.0:
        raise sec.error("tan_delta", f"loss factor {tan_delta} is not a loss factor tan(delta) < 1",
                        fix="give tan(delta) (e.g. 0.04), not a percentage")


@dataclass(frozen=True)
class StatorSettings:
    """``stator:`` the rigid stator with the feet (Werner 2017, Sec. 2, Fig. 1); only the ratios
    b/h and Theta_sx/h^2 are identifiable from the paper's results."""

    mass_kg: float = setting(doc="stator mass m_s (Werner 2017, Table 1)", unit="kg",
                             positive=True)
    roll_inertia_kg_m2: float = setting(doc="stator moment of inertia Theta_sx about the rotor "
                                        "axis (Werner 2017, Table 1)", unit="kg m^2",
                                        positive=True)
    cog_height_m: float = setting(doc="height h of the centre of gravity S above the foot plane "
                                  "(Werner 2017, Table 1)", unit="m", nonnegative=True)
    foot_half_distance_m: float = setting(doc="half foot distance b of eq. (5) (Werner 2017, "
                                          "Table 1: 2b)", unit="m", positive=True)


@dataclass(frozen=True)
class RotorSettings:
    """``rotor:`` the flexible rotor, one mass at mid-span on the shaft journals (Werner 2017,
    Sec. 2)."""

    mass_kg: float = setting(doc="rotor mass m_w (Werner 2017, Table 1)", unit="kg",
                             positive=True)
    shaft_stiffness_n_per_m: float = setting(doc="total shaft stiffness c, rotor mass against "
                                             "the journals (Werner 2017, Table 1)", unit="N/m",
                                             positive=True)
    tan_delta: float = setting(doc="loss factor tan(delta_i) of the internal (rotating) "
                               "damping, below 1 (Werner 2017, eq. 9)", nonnegative=True)
    journal_mass_kg: float = setting(doc="mass m_v of one shaft journal (Werner 2017, Table 1)",
                                     unit="kg", positive=True)

    def check(self, sec: Section) -> None:
        _check_loss_factor(sec, self.tan_delta)


@dataclass(frozen=True)
class BearingSettings:
    """``bearings:`` one roller bearing, without damping or cross terms (Werner 2017, Sec. 4)."""

    stiffness_n_per_m: StiffnessZY = setting(doc="stiffnesses c_rz, c_ry of one bearing "
                                             "(Werner 2017, Secs. 4.3 and 4.9)")


@dataclass(frozen=True)
class HousingSettings:
    """``housings:`` one bearing housing with its end shield (Werner 2017, Sec. 2)."""

    mass_kg: float = setting(doc="mass m_b of one housing (Werner 2017, Table 1)", unit="kg",
                             positive=True)
    stiffness_n_per_m: StiffnessZY = setting(doc="stiffnesses c_bz, c_by of one housing with "
                                             "end shield (Werner 2017, Sec. 4.9)")
    tan_delta: float = setting(doc="loss factor tan(delta_b), below 1 (Werner 2017, Table 1)",
                               nonnegative=True)

    def check(self, sec: Section) -> None:
        _check_loss_factor(sec, self.tan_delta)


@dataclass(frozen=True)
class FoundationSettings:
    """``foundation:`` the welded steel frame under each foot, or none (Werner 2017, Sec. 4.4;
    Table 2 cases d, e: rigid)."""

    kind: str = setting(doc="`soft` (the stator on the foundation springs) or `rigid` (the "
                        "stator fixed: stiffness_n_per_m and tan_delta do not enter, Werner "
                        "2017, Table 2 d, e)", choices=FOUNDATION_KINDS)
    stiffness_n_per_m: StiffnessZY | None = setting(
        None, "stiffnesses c_fz, c_fy under one foot (Werner 2017, Sec. 4.4; required with kind "
        "soft)")
    tan_delta: float | None = setting(None, "loss factor tan(delta_f), below 1 (Werner 2017, "
                                      "Table 1; required with kind soft)", nonnegative=True)

    def check(self, sec: Section) -> None:
        for key in ("stiffness_n_per_m", "tan_delta"):
            if self.kind == "soft" and getattr(self, key) is None:
                raise sec.error(key, "missing", fix=f"add `{key}:` to {sec.path} (kind soft "
                                "needs it), or set kind: rigid")
        if self.tan_delta is not None:
            _check_loss_factor(sec, self.tan_delta)


@dataclass(frozen=True, kw_only=True)
class StudySettings:
    """``studies.<name>``: a threshold-of-stability map (Werner 2017, Figs. 7-11) run by
    `rotor-avc stability --study` (rotor_avc.analysis.stability_study)."""

    variants: tuple[str, ...] = setting((), "variants applied first, in the order given")
    vary: tuple[str, ...] = setting(doc="one or two varied parameters, each `PATHS=RANGE` "
                                    "(rotor_avc.analysis.stability_study)")

    def check(self, sec: Section) -> None:
        if not 1 <= len(self.vary) <= 2:
            raise sec.error("vary", "must be a list of one or two `PATHS=RANGE` strings",
                            fix='write ["bearings.stiffness_n_per_m.z=1.0e+8:3.0e+8:21"]')


@dataclass(frozen=True)
class RollerBearingRotorSettings:
    """The top-level keys of a ``model: roller_bearing_rotor`` config (Werner 2017)."""

    stator: StatorSettings = setting(doc="the stator (Werner 2017, Table 1)")
    rotor: RotorSettings = setting(doc="the rotor (Werner 2017, Table 1)")
    bearings: BearingSettings = setting(doc="the roller bearings (Werner 2017, Table 1)")
    housings: HousingSettings = setting(doc="the bearing housings with end shields (Werner "
                                        "2017, Table 1)")
    foundation: FoundationSettings = setting(doc="the foundation (Werner 2017, Table 1)")
    variants: dict[str, dict] | None = setting(
        None, "named overrides, each dotted config paths -> values, validated as the config "
        "when applied (`rotor-avc stability --variant`; Werner 2017, Table 2 cases b-e)")
    studies: dict[str, StudySettings] | None = setting(None, "named threshold studies "
                                                       "(Werner 2017, Secs. 4.4-4.9)")


#: the declaration of this model's top-level config keys
MODEL_SETTINGS = RollerBearingRotorSettings
#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = tuple(f.name for f in dataclasses.fields(MODEL_SETTINGS))


def read_params(cfg: Section) -> model.RotorParams:
    """Validate the keys of :data:`MODEL_SETTINGS` into the model's parameters."""
    s = read_part(MODEL_SETTINGS, cfg)
    st, ro, ho, fo = s.stator, s.rotor, s.housings, s.foundation
    rigid = fo.kind == "rigid"
    if rigid:       # the foundation's stiffness and damping do not enter (no z_s, y_s, phi_s)
        c_fz = c_fy = tan_f = 0.0
    else:
        c_fz, c_fy, tan_f = fo.stiffness_n_per_m.z, fo.stiffness_n_per_m.y, fo.tan_delta
    return model.RotorParams(
        m_s=st.mass_kg, theta_sx=st.roll_inertia_kg_m2, h=st.cog_height_m,
        b=st.foot_half_distance_m, m_w=ro.mass_kg, c=ro.shaft_stiffness_n_per_m,
        tan_i=ro.tan_delta, m_v=ro.journal_mass_kg, c_rz=s.bearings.stiffness_n_per_m.z,
        c_ry=s.bearings.stiffness_n_per_m.y, m_b=ho.mass_kg, c_bz=ho.stiffness_n_per_m.z,
        c_by=ho.stiffness_n_per_m.y, tan_b=ho.tan_delta, rigid=rigid, c_fz=c_fz, c_fy=c_fy,
        tan_f=tan_f)


def whirl_start_rad_s(cfg: Section) -> float:
    """The model's start value of the whirl-frequency iteration (Werner 2017, eq. 14)."""
    return model.eq14_whirl_rad_s(read_params(cfg))


def build(cfg: Section) -> LinearPlant:
    """The Werner 2017 plant of a validated config."""
    return model.build(read_params(cfg), cfg.string("name", "roller_bearing_rotor"),
                       damping_floor_rad_s(cfg), cfg.data)
