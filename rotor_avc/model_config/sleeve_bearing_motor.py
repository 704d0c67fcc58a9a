"""``model: sleeve_bearing_motor`` (Werner 2019): the config sections ``motor``,
``sleeve_bearing``, ``electromagnetic``, ``foundation``, ``actuator`` and ``environment``, declared
once (:data:`MODEL_SETTINGS`) and read into :class:`~rotor_avc.models.sleeve_bearing_motor.
MotorParams` (see ``config/sleeve_bearing_motor.yaml``).

Table numbers are those of Werner 2019's numerical example (Sec. 4.1, Table 2); the symbols those
of its equations. The paper gives neither the oil's data beyond its grade nor its figures of the
bearing coefficients (Fig. 3) and of the electromagnetic field (Fig. 4): those values are the
assumptions the config marks."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..section import Section
from ..errors import ModelError
from ..models import sleeve_bearing_motor as model
from ..models.journal_bearing import JournalBearing, Oil
from ..models.plant import LinearPlant
from ..models.sleeve_bearing_motor import SIDES, ElectromagneticField
from ..settings import damping_floor_rad_s, read_part, setting

EM_MODELS = ("field_damping", "off")
#: a loss factor at or above this is refused as implausible (a percentage given by mistake)
LOSS_FACTOR_LIMIT = 0.5


def _check_loss_factor(sec: Section, key: str, tan_delta: float) -> None:
    if tan_delta >= LOSS_FACTOR_LIMIT:
        raise sec.error(key, f"loss factor {tan_delta} is implausibly large",
                        fix="give tan(delta) as a fraction (0.04), not a percentage")


# -- per direction, per side -------------------------------------------------------------------
@dataclass(frozen=True)
class StiffnessZY:
    """Spring stiffnesses in the vertical (z) and horizontal (y) direction of a plane model
    (Werner 2019 and Werner 2017 alike)."""

    z: float = setting(doc="vertical", unit="N/m", positive=True)
    y: float = setting(doc="horizontal", unit="N/m", positive=True)


@dataclass(frozen=True)
class FoundationSide:
    """One side's foundation point: a mass on two springs to ground (Werner 2019, Table 2)."""

    mass_kg: float = setting(doc="foundation mass m_f of the side (Werner 2019, Table 2)",
                             unit="kg", nonnegative=True)
    stiffness_n_per_m: StiffnessZY = setting(doc="stiffnesses c_fz, c_fy of the side (Werner "
                                             "2019, Table 2)")


@dataclass(frozen=True)
class OilSettings:
    """``sleeve_bearing.oil``: the oil by its viscosity grade data (ISO VG 32 in Werner 2019,
    Table 2; the data beyond nu40 are assumed); the field names are those of Oil."""

    nu40_mm2_s: float = setting(doc="kinematic viscosity at 40 degC (> nu100_mm2_s)",
                                unit="mm^2/s", positive=True)
    nu100_mm2_s: float = setting(doc="kinematic viscosity at 100 degC", unit="mm^2/s",
                                 positive=True)
    density15_kg_m3: float = setting(doc="density at 15 degC", unit="kg/m^3", positive=True)
    expansion_per_k: float = setting(doc="volumetric thermal expansion coefficient",
                                     unit="1/K", nonnegative=True)
    heat_capacity_j_kg_k: float = setting(doc="specific heat capacity", unit="J/(kg K)",
                                          positive=True)


@dataclass(frozen=True)
class FilmGrid:
    """``sleeve_bearing.grid``: the cells of the Reynolds-equation film solution
    (rotor_avc.models.journal_bearing; n_theta >= 24 and a multiple of 4, n_z >= 2)."""

    n_theta: int = setting(120, "cells around the circumference")
    n_z: int = setting(12, "cells over the half width")


# -- the sections ------------------------------------------------------------------------------
@dataclass(frozen=True)
class MotorSettings:
    """``motor:`` the two-pole induction motor: rigid stator, flexible rotor, bearing housings
    with end shields (Werner 2019, Table 2); the field names are those of MotorParams."""

    rated_speed_rpm: float = setting(doc="rated speed n_N: constant flux up to it, field "
                                     "weakening above (Werner 2019, Sec. 4.1)", unit="rpm",
                                     positive=True)
    stator_mass_kg: float = setting(doc="stator mass m_s (Werner 2019, Table 2)", unit="kg",
                                    positive=True)
    stator_inertia_kg_m2: float = setting(doc="stator moment of inertia theta_sx about the "
                                          "rotor axis (Werner 2019, Table 2)", unit="kg m^2",
                                          positive=True)
    rotor_mass_kg: float = setting(doc="rotor mass m_w (Werner 2019, Table 2)", unit="kg",
                                   positive=True)
    journal_mass_kg: float = setting(doc="mass m_v of one shaft journal; the model lumps both "
                                     "(Werner 2019, Table 2)", unit="kg", positive=True)
    housing_mass_kg: float = setting(doc="mass m_b of one bearing housing; the model lumps both "
                                     "(Werner 2019, Table 2)", unit="kg", positive=True)
    rotor_stiffness_n_per_m: float = setting(doc="rotor stiffness c, rotor mass against the "
                                             "journals (Werner 2019, Table 2)", unit="N/m",
                                             positive=True)
    rotor_tan_delta: float = setting(doc="loss factor tan(delta_i) of the rotor, its rotating "
                                     f"damping; below {LOSS_FACTOR_LIMIT:g} (Werner 2019, "
                                     "Table 2)", nonnegative=True)
    foot_height_m: float = setting(doc="height h of the centre of gravity S above the feet "
                                   "(Werner 2019, Table 2)", unit="m", nonnegative=True)
    foot_half_distance_m: float = setting(doc="half foot distance b (Werner 2019, Table 2: 2b)",
                                          unit="m", positive=True)
    housing_stiffness_n_per_m: StiffnessZY = setting(
        doc="stiffnesses c_bz, c_by of one side's housing and end shield (Werner 2019, Table 2)")
    housing_tan_delta: float = setting(doc="loss factor tan(delta_b) of housing and end shield; "
                                       f"below {LOSS_FACTOR_LIMIT:g} (Werner 2019, Table 2)",
                                       nonnegative=True)

    def check(self, sec: Section) -> None:
        _check_loss_factor(sec, "rotor_tan_delta", self.rotor_tan_delta)
        _check_loss_factor(sec, "housing_tan_delta", self.housing_tan_delta)


@dataclass(frozen=True, kw_only=True)
class SleeveBearingSettings:
    """``sleeve_bearing:`` one of the two identical plain cylindrical bearings, whose oil-film
    coefficients (Werner 2019, Fig. 3, missing) are computed from the Reynolds equation and
    tabulated over speed (rotor_avc.models.journal_bearing)."""

    diameter_m: float = setting(doc="bore d_b (Werner 2019, Table 2)", unit="m", positive=True)
    width_m: float = setting(doc="width b_b (Werner 2019, Table 2)", unit="m", positive=True)
    relative_clearance: float = setting(doc="mean relative clearance Psi_m after DIN 31698 "
                                        "(Werner 2019, Table 2)", positive=True, maximum=0.02)
    oil: OilSettings = setting(doc="the oil (Werner 2019, Table 2: ISO VG 32)")
    supply_temperature_c: float = setting(doc="oil supply temperature T_in (Werner 2019, "
                                          "Table 2)", unit="degC")
    effective_temperature_c: float | None = setting(None, "fixed effective film temperature "
                                                    "(default: the adiabatic heat balance)",
                                                    unit="degC")
    speed_range_rpm: tuple[float, ...] = setting(doc="[min, max] of the coefficient table, "
                                                 "covering the analyses' speeds", unit="rpm")
    table_points: int = setting(64, "log-spaced speeds of the coefficient table", minimum=8)
    grid: FilmGrid = setting(FilmGrid, "the film solution's grid")

    def check(self, sec: Section) -> None:
        if len(self.speed_range_rpm) != 2:
            raise sec.error("speed_range_rpm", f"must have 2 entries (got "
                            f"{len(self.speed_range_rpm)})", fix="give [min, max] in rpm")
        lo, hi = self.speed_range_rpm
        if not 0 < lo < hi:
            raise sec.error("speed_range_rpm", f"need 0 < min < max (got [{lo}, {hi}])",
                            fix="give [min, max] in rpm covering the analyses' speeds, "
                                "e.g. [100, 6000]")


@dataclass(frozen=True)
class ElectromagneticSettings:
    """``electromagnetic:`` the eccentricity-field model of the magnetic pull (Werner 2019,
    Fig. 4, missing: an assumed model after Fruechtenicht, Jordan & Seinsch, the paper's refs.
    [21], [23]; see rotor_avc.models.sleeve_bearing_motor)."""

    model: str = setting(doc="`field_damping` (magnetic spring with field damping) or `off` (no "
                         "magnetic terms)", choices=EM_MODELS)
    magnetic_stiffness_n_per_m: float | None = setting(
        None, "undamped magnetic spring c_m at rated flux (model field_damping)", unit="N/m",
        nonnegative=True)
    field_damping_depth: float | None = setting(None, "depth k_D of the field damping (model "
                                                "field_damping)", nonnegative=True, maximum=1.0)
    rotor_time_constant_s: float | None = setting(None, "time constant T_r of the eccentricity "
                                                  "fields (model field_damping)", unit="s",
                                                  positive=True)
    rated_slip_frequency_rad_s: float | None = setting(
        None, "rotor-frame slip frequency w_slip,N at the rated point (model field_damping)",
        unit="rad/s", nonnegative=True)

    def check(self, sec: Section) -> None:
        for f in dataclasses.fields(self)[1:]:               # the fields after `model`
            given = getattr(self, f.name) is not None
            if self.model == "off" and given:
                raise sec.error(f.name, "only used with `model: field_damping`",
                                fix=f"drop {f.name} or set model: field_damping")
            if self.model == "field_damping" and not given:
                raise sec.error(f.name, "missing", fix=f"add `{f.name}:` to {sec.path} (model "
                                "field_damping needs it), or set model: off")


@dataclass(frozen=True)
class FoundationSettings:
    """``foundation:`` the soft steel-frame foundation under each foot line (Werner 2019,
    Table 2)."""

    L: FoundationSide = setting(doc="the left side: m_fL, c_fzL, c_fyL (Werner 2019, Table 2)")
    R: FoundationSide = setting(doc="the right side: m_fR, c_fzR, c_fyR (Werner 2019, Table 2)")
    tan_delta: float = setting(doc="loss factor tan(delta_f) of both sides; below "
                               f"{LOSS_FACTOR_LIMIT:g} (Werner 2019, Table 2)", nonnegative=True)

    def check(self, sec: Section) -> None:
        _check_loss_factor(sec, "tan_delta", self.tan_delta)


@dataclass(frozen=True)
class ActuatorSettings:
    """``actuator:`` the active mount of each foot line, its force vertical only (Werner 2019,
    Table 2, per motor side); the field names are those of MotorParams without ``actuator_``."""

    stator_mass_kg: float = setting(doc="actuator stator mass m_as, moves with the foundation "
                                    "mass (Werner 2019, Table 2)", unit="kg", nonnegative=True)
    armature_mass_kg: float = setting(doc="armature mass m_aa, moves with the motor foot "
                                      "(Werner 2019, Table 2)", unit="kg", nonnegative=True)
    stiffness_n_per_m: StiffnessZY = setting(doc="stiffnesses c_az, c_ay (Werner 2019, Table 2)")
    tan_delta: float = setting(doc="loss factor tan(delta_a); below "
                               f"{LOSS_FACTOR_LIMIT:g} (Werner 2019, Table 2)", nonnegative=True)

    def check(self, sec: Section) -> None:
        _check_loss_factor(sec, "tan_delta", self.tan_delta)


@dataclass(frozen=True)
class EnvironmentSettings:
    """``environment:`` what loads the sleeve bearings statically."""

    gravity_m_s2: float = setting(9.81, "g of the static bearing load (m_w / 2 + m_v) g (the "
                                  "split between the bearings is assumed, Werner 2019 gives "
                                  "none)", unit="m/s^2", positive=True)


@dataclass(frozen=True)
class SleeveBearingMotorSettings:
    """The top-level keys of a ``model: sleeve_bearing_motor`` config (Werner 2019)."""

    motor: MotorSettings = setting(doc="the motor (Werner 2019, Table 2)")
    sleeve_bearing: SleeveBearingSettings = setting(doc="the sleeve bearings (Werner 2019, "
                                                    "Table 2)")
    electromagnetic: ElectromagneticSettings = setting(doc="the magnetic pull (Werner 2019, "
                                                       "Fig. 4: assumed model)")
    foundation: FoundationSettings = setting(doc="the foundation (Werner 2019, Table 2)")
    actuator: ActuatorSettings = setting(doc="the active mounts (Werner 2019, Table 2)")
    environment: EnvironmentSettings = setting(EnvironmentSettings, "gravity")


#: the declaration of this model's top-level config keys
MODEL_SETTINGS = SleeveBearingMotorSettings
#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = tuple(f.name for f in dataclasses.fields(MODEL_SETTINGS))


def _sleeve_bearing(s: SleeveBearingSettings, cfg: Section) -> model.SleeveBearing:
    """One sleeve bearing (geometry, oil, table speeds, temperatures); what the model refuses is
    reported at ``sleeve_bearing.<key>``."""
    try:
        bearing = JournalBearing(s.diameter_m, s.width_m, s.relative_clearance * s.diameter_m / 2,
                                 s.grid.n_theta, s.grid.n_z)
    except ModelError as exc:
        key = "grid" if "grid" in str(exc) else "relative_clearance"
        raise cfg.error(f"sleeve_bearing.{key}", str(exc)) from None
    try:
        oil = Oil(**dataclasses.asdict(s.oil))
    except ModelError as exc:
        raise cfg.error("sleeve_bearing.oil", str(exc)) from None
    lo, hi = s.speed_range_rpm
    speeds = np.geomspace(lo, hi, s.table_points) * math.pi / 30
    return model.SleeveBearing(bearing, oil, speeds, s.supply_temperature_c,
                               s.effective_temperature_c)


def read_params(cfg: Section) -> model.MotorParams:
    """Validate the keys of :data:`MODEL_SETTINGS` into the model's parameters."""
    s = read_part(MODEL_SETTINGS, cfg)
    motor = dataclasses.asdict(s.motor)
    rated_rad_s = motor.pop("rated_speed_rpm") * math.pi / 30
    em = s.electromagnetic
    em_field = None if em.model == "off" else ElectromagneticField(
        em.magnetic_stiffness_n_per_m, em.field_damping_depth, em.rotor_time_constant_s,
        em.rated_slip_frequency_rad_s, rated_rad_s)
    sides = {side: getattr(s.foundation, side) for side in SIDES}
    return model.MotorParams(
        **motor, **{f"actuator_{k}": v for k, v in dataclasses.asdict(s.actuator).items()},
        foundation_mass_kg={side: f.mass_kg for side, f in sides.items()},
        foundation_stiffness_n_per_m={side: dataclasses.asdict(f.stiffness_n_per_m)
                                      for side, f in sides.items()},
        foundation_tan_delta=s.foundation.tan_delta, gravity_m_s2=s.environment.gravity_m_s2,
        electromagnetic=em_field, sleeve_bearing=_sleeve_bearing(s.sleeve_bearing, cfg))


def build(cfg: Section) -> LinearPlant:
    """The Werner 2019 plant of a validated config."""
    return model.build(read_params(cfg), cfg.string("name", "sleeve_bearing_motor"),
                       damping_floor_rad_s(cfg), cfg.data)
