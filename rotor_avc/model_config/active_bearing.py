"""``model: active_bearing`` (Sci. Rep. 2023): the config sections ``rotor``, ``unbalance``,
``active_bearings``, ``sensors``, ``piezo`` and ``feedforward``, declared once
(:data:`MODEL_SETTINGS`) and read into the numbers of :mod:`rotor_avc.models.active_bearing` and
:mod:`rotor_avc.models.piezo` (see ``config/active_bearing.yaml``).

The paper's Table 1 (the parameters) has no body in the available text: only the shaft geometry
is stated, the other values are placeholders the config marks. The symbols are those of its
equations."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..section import Section
from ..models import active_bearing as model
from ..models.active_bearing import BEARINGS, PLANES
from ..models.piezo import PiezoStack
from ..models.plant import LinearPlant
from ..settings import FEEDFORWARD_METHODS, damping_floor_rad_s, read_part, setting

#: what the machine built from this model supports (rotor_avc.machine.CAPABILITIES)
SUPPORTS = ("feedforward",)


def _check_bearing_names(sec: Section, key: str) -> None:
    """The named entries of ``key`` are exactly the bearings ``"1"`` and ``"2"``."""
    entries = sec.section(key)
    entries.check_keys(BEARINGS)
    for i in BEARINGS:
        entries.raw(i)                                       # raises "missing" with the fix


@dataclass(frozen=True)
class RotorSettings:
    """``rotor:`` the rigid SM45C steel shaft, a uniform cylinder whose mass and inertias follow
    from its geometry (Sci. Rep. 2023, Fig. 2)."""

    density_kg_m3: float = setting(doc="shaft density (Sci. Rep. 2023: SM45C steel, value "
                                   "assumed)", unit="kg/m^3", positive=True)
    diameter_m: float = setting(doc="shaft diameter (Sci. Rep. 2023, Fig. 2)", unit="m",
                                positive=True)
    length_m: float = setting(doc="shaft length L (Sci. Rep. 2023, Fig. 2)", unit="m",
                              positive=True)
    bearing_arm_m: dict[str, float] = setting(doc="l1, l2: centre of mass -> bearing `1`, `2`, "
                                              "on the shaft (<= L/2) (Sci. Rep. 2023, eqs. 2, "
                                              "4)", unit="m", positive=True)
    tilt_stiffness_n_m_per_rad: float = setting(doc="tilt stiffness k_r in K(6,6) (Sci. Rep. "
                                                "2023, eq. 3; undefined in the text)",
                                                unit="N m/rad", nonnegative=True)

    def check(self, sec: Section) -> None:
        _check_bearing_names(sec, "bearing_arm_m")
        for i in BEARINGS:
            arm = self.bearing_arm_m[i]
            if arm > self.length_m / 2:
                raise sec.section("bearing_arm_m").error(
                    i, f"bearing {i} at {arm} m from the centre of mass is off the "
                    f"{self.length_m} m shaft", fix=f"give a distance <= {self.length_m / 2} m")


@dataclass(frozen=True)
class PlaneSettings:
    """``active_bearings.<i>.y`` and ``.x``: one bearing in one direction, its actuator mass and
    Kelvin-Voigt elements: ball bearing (b), piezo stack (ac), backing spring (sp) and rubber
    grommet (pre) (Sci. Rep. 2023, eqs. 1-5)."""

    actuator_mass_kg: float = setting(doc="actuator mass m_as", unit="kg", positive=True)
    k_b_n_per_m: float = setting(doc="ball-bearing stiffness k_b", unit="N/m", positive=True)
    c_b_n_s_per_m: float = setting(doc="ball-bearing damping c_b (stated 0)", unit="N s/m",
                                   nonnegative=True)
    k_ac_n_per_m: float = setting(doc="piezo-stack stiffness k_ac", unit="N/m", positive=True)
    c_ac_n_s_per_m: float = setting(doc="piezo-stack damping c_ac", unit="N s/m",
                                    nonnegative=True)
    k_sp_n_per_m: float = setting(doc="backing-spring stiffness k_sp", unit="N/m",
                                  nonnegative=True)
    c_sp_n_s_per_m: float = setting(doc="backing-spring damping c_sp (in C(3,3), undefined in "
                                    "the text)", unit="N s/m", nonnegative=True)
    k_pre_n_per_m: float = setting(doc="grommet stiffness k_pre", unit="N/m", nonnegative=True)
    c_pre_n_s_per_m: float = setting(doc="grommet damping c_pre", unit="N s/m",
                                     nonnegative=True)


@dataclass(frozen=True)
class BearingSettings:
    """``active_bearings.<i>``: bearing ``1`` or ``2``, its housing one body in y and x."""

    housing_mass_kg: float = setting(doc="housing mass m_Bh (Sci. Rep. 2023, Table 1)",
                                     unit="kg", positive=True)
    y: PlaneSettings = setting(doc="the y direction (Sci. Rep. 2023, Table 1)")
    x: PlaneSettings = setting(doc="the x direction (Sci. Rep. 2023, Table 1)")


@dataclass(frozen=True)
class SensorsSettings:
    """``sensors:`` the shaft's response points, paired in order into the sensor transform Pi
    (Sci. Rep. 2023, eq. 11: five per side)."""

    bearing1_side_m: tuple[float, ...] = setting(doc="distances l_sen of the points on the "
                                                 "bearing-1 side from the centre of mass, each "
                                                 "0 < l_sen <= L/2", unit="m", min_length=1)
    bearing2_side_m: tuple[float, ...] = setting(doc="the same on the bearing-2 side, as many",
                                                 unit="m", min_length=1)


@dataclass(frozen=True)
class UnbalanceSettings:
    """``unbalance:`` the rotor's unbalance m_o e (Sci. Rep. 2023, eqs. 16-17)."""

    mass_kg: float = setting(doc="unbalance mass m_o", unit="kg", positive=True)
    eccentricity_m: float = setting(doc="its eccentricity e", unit="m", positive=True)


@dataclass(frozen=True)
class PiezoSettings:
    """``piezo:`` the one stack type of every actuator (rotor_avc.models.piezo; the paper gives
    no actuator data); the field names are those of PiezoStack."""

    free_stroke_m: float = setting(doc="nominal stroke at max_voltage_v", unit="m",
                                   positive=True)
    blocked_force_n: float = setting(doc="blocked force at max_voltage_v", unit="N",
                                     positive=True)
    bandwidth_hz: float = setting(doc="first-order lag of stack and amplifier", unit="Hz",
                                  positive=True)
    max_voltage_v: float = setting(doc="top of the drive range", unit="V", positive=True)
    min_voltage_v: float = setting(0.0, "bottom of the drive range (< max_voltage_v)", unit="V")

    def check(self, sec: Section) -> None:
        if self.min_voltage_v >= self.max_voltage_v:
            raise sec.error("min_voltage_v", f"{self.min_voltage_v} V is not below "
                            f"max_voltage_v {self.max_voltage_v} V",
                            fix="give the drive range as min_voltage_v < max_voltage_v")


@dataclass(frozen=True)
class FeedforwardSettings:
    """``feedforward:`` the quantified 1x actuator forces (rotor_avc.analysis.active_bearing_ff)."""

    method: str = setting("paper", "`paper`: eqs. (38)-(39) sign-fixed, per bearing; `exact`: "
                          "the 4x4 joint solve (Sci. Rep. 2023)", choices=FEEDFORWARD_METHODS)


@dataclass(frozen=True, kw_only=True)
class ActiveBearingSettings:
    """The top-level keys of a ``model: active_bearing`` config (Sci. Rep. 2023)."""

    rotor: RotorSettings = setting(doc="the shaft (Sci. Rep. 2023, Fig. 2)")
    unbalance: UnbalanceSettings | None = setting(None, "the unbalance (required by "
                                                  "`rotor-avc active-bearing`)")
    active_bearings: dict[str, BearingSettings] = setting(doc="bearings `1` and `2` "
                                                          "(Sci. Rep. 2023, Table 1)")
    sensors: SensorsSettings = setting(doc="the shaft's response points (Sci. Rep. 2023, "
                                       "eq. 11)")
    piezo: PiezoSettings | None = setting(None, "the piezo stacks (required by "
                                          "`rotor-avc active-bearing`)")
    feedforward: FeedforwardSettings = setting(FeedforwardSettings, "the 1x feed-forward")

    def check(self, sec: Section) -> None:
        _check_bearing_names(sec, "active_bearings")
        sensors, half = sec.section("sensors"), self.rotor.length_m / 2
        for key in ("bearing1_side_m", "bearing2_side_m"):
            values = list(getattr(self.sensors, key))
            if any(not 0.0 < v <= half for v in values):
                raise sensors.error(key, f"every offset must lie on the shaft, 0 < l_sen <= "
                                         f"{half} m (got {values})",
                                    fix="give distances from the centre of mass (positive, in m)")
        left, right = self.sensors.bearing1_side_m, self.sensors.bearing2_side_m
        if len(left) != len(right):
            raise sensors.error("bearing2_side_m", f"has {len(right)} entries, bearing1_side_m "
                                f"has {len(left)}", fix="give the sensors in pairs (eq. 11)")


#: the declaration of this model's top-level config keys
MODEL_SETTINGS = ActiveBearingSettings
#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = tuple(f.name for f in dataclasses.fields(MODEL_SETTINGS))


def model_settings(cfg: Section) -> ActiveBearingSettings:
    """The config's :data:`MODEL_SETTINGS`. The bearings' names are checked first: the entries
    of a name are read before :meth:`ActiveBearingSettings.check`, and a misspelt name is to be
    refused as unknown, not for what it holds."""
    _check_bearing_names(cfg, "active_bearings")
    return read_part(MODEL_SETTINGS, cfg)


def _analysis_section(cfg: Section, key: str):
    """A validated section the plant does without but an analysis needs (``unbalance``,
    ``piezo``)."""
    value = getattr(model_settings(cfg), key)
    if value is None:
        raise cfg.error(key, "missing", fix=f"add `{key}:` to the file")
    return value


def unbalance_kg_m(cfg: Section) -> float:
    """The configured unbalance ``m_o e`` [kg m] (eqs. 16-17)."""
    u = _analysis_section(cfg, "unbalance")
    return u.mass_kg * u.eccentricity_m


def piezo_from_config(cfg: Section) -> PiezoStack:
    """The ``piezo:`` section of a machine config (one stack type for every actuator)."""
    return PiezoStack(**dataclasses.asdict(_analysis_section(cfg, "piezo")))


def _plane(p: PlaneSettings) -> model.BearingPlane:
    return model.BearingPlane(m_as=p.actuator_mass_kg, k_b=p.k_b_n_per_m, c_b=p.c_b_n_s_per_m,
                              k_ac=p.k_ac_n_per_m, c_ac=p.c_ac_n_s_per_m, k_sp=p.k_sp_n_per_m,
                              c_sp=p.c_sp_n_s_per_m, k_pre=p.k_pre_n_per_m,
                              c_pre=p.c_pre_n_s_per_m)


def read_params(cfg: Section) -> model.ActiveBearingParams:
    """Validate the keys of :data:`MODEL_SETTINGS` into the model's parameters."""
    s = model_settings(cfg)
    r, bearings = s.rotor, s.active_bearings
    z_bearing = {i: sign * r.bearing_arm_m[i] for i, sign in zip(BEARINGS, (-1.0, 1.0))}
    return model.ActiveBearingParams(
        r.density_kg_m3, r.diameter_m, r.length_m, z_bearing, r.tilt_stiffness_n_m_per_rad,
        {i: bearings[i].housing_mass_kg for i in BEARINGS},
        {(i, d): _plane(getattr(bearings[i], d)) for i in BEARINGS for d in PLANES},
        tuple(zip(s.sensors.bearing1_side_m, s.sensors.bearing2_side_m)))


def build(cfg: Section) -> LinearPlant:
    """The Sci. Rep. 2023 plant of a validated config."""
    return model.build(read_params(cfg), cfg.string("name", "active_bearing"),
                       damping_floor_rad_s(cfg), cfg.data)
