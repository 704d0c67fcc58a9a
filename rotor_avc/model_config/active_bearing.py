"""``model: active_bearing`` (seed 002): the config sections ``rotor``, ``active_bearings``,
``sensors``, ``unbalance`` and ``piezo`` read into the numbers of :mod:`rotor_avc.models.
active_bearing` and :mod:`rotor_avc.models.piezo` (see ``config/active_bearing.yaml``)."""
from __future__ import annotations

from ..config import Section
from ..models import active_bearing as model
from ..models.active_bearing import BEARINGS, PLANES
from ..models.piezo import PiezoStack
from ..models.plant import LinearPlant
from ..settings import damping_floor_rad_s

#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS); ``unbalance``,
#: ``piezo`` and ``feedforward`` are read by :func:`unbalance_kg_m`, :func:`piezo_from_config` and
#: rotor_avc.analysis.active_bearing_ff
MODEL_KEYS = ("rotor", "unbalance", "active_bearings", "sensors", "piezo", "feedforward")
#: what the machine built from this model supports (rotor_avc.machine.CAPABILITIES)
SUPPORTS = ("feedforward",)
#: keys of one bearing plane -> the parameter they give (stiffness N/m, damping N s/m)
PLANE_KEYS = {"k_b_n_per_m": "k_b", "c_b_n_s_per_m": "c_b", "k_ac_n_per_m": "k_ac",
              "c_ac_n_s_per_m": "c_ac", "k_sp_n_per_m": "k_sp", "c_sp_n_s_per_m": "c_sp",
              "k_pre_n_per_m": "k_pre", "c_pre_n_s_per_m": "c_pre"}


def unbalance_kg_m(cfg: Section) -> float:
    """The configured unbalance ``m_o e`` [kg m] (eqs. 16-17)."""
    sec = cfg.section("unbalance")
    sec.check_keys(("mass_kg", "eccentricity_m"))
    return (sec.number("mass_kg", positive=True, unit="kg")
            * sec.number("eccentricity_m", positive=True, unit="m"))


def sensor_offsets(cfg: Section) -> list[tuple[float, float]]:
    """Sensor pairs ``(l1_sen, l2_sen)`` [m from the centre of mass], validated on the shaft."""
    sec = cfg.section("sensors")
    sec.check_keys(("bearing1_side_m", "bearing2_side_m"))
    half = cfg.section("rotor").number("length_m", positive=True, unit="m") / 2
    sides = {}
    for key in ("bearing1_side_m", "bearing2_side_m"):
        values = sec.number_list(key, min_length=1)
        if any(not 0.0 < v <= half for v in values):
            raise sec.error(key, f"every offset must lie on the shaft, 0 < l_sen <= {half} m "
                                 f"(got {values})",
                            fix="give distances from the centre of mass (positive, in m)")
        sides[key] = values
    left, right = sides["bearing1_side_m"], sides["bearing2_side_m"]
    if len(left) != len(right):
        raise sec.error("bearing2_side_m", f"has {len(right)} entries, bearing1_side_m has "
                                           f"{len(left)}", fix="give the sensors in pairs (eq. 11)")
    return list(zip(left, right))


def piezo_from_config(cfg: Section) -> PiezoStack:
    """The ``piezo:`` section of a machine config (one stack type for every actuator)."""
    sec = cfg.section("piezo")
    sec.check_keys(("free_stroke_m", "blocked_force_n", "bandwidth_hz", "max_voltage_v",
                    "min_voltage_v"))
    max_v = sec.number("max_voltage_v", positive=True, unit="V")
    min_v = sec.number("min_voltage_v", 0.0, unit="V")
    if min_v >= max_v:
        raise sec.error("min_voltage_v", f"{min_v} V is not below max_voltage_v {max_v} V",
                        fix="give the drive range as min_voltage_v < max_voltage_v")
    return PiezoStack(free_stroke_m=sec.number("free_stroke_m", positive=True, unit="m"),
                      blocked_force_n=sec.number("blocked_force_n", positive=True, unit="N"),
                      bandwidth_hz=sec.number("bandwidth_hz", positive=True, unit="Hz"),
                      max_voltage_v=max_v, min_voltage_v=min_v)


def _plane(sec: Section) -> model.BearingPlane:
    sec.check_keys(("actuator_mass_kg",) + tuple(PLANE_KEYS))
    m_as = sec.number("actuator_mass_kg", positive=True, unit="kg")
    values = {name: sec.number(key, positive=key in ("k_b_n_per_m", "k_ac_n_per_m"),
                               nonnegative=True, unit="N/m" if key.startswith("k_") else "N s/m")
              for key, name in PLANE_KEYS.items()}
    return model.BearingPlane(m_as=m_as, **values)


def read_params(cfg: Section) -> model.ActiveBearingParams:
    """Validate and read ``rotor``, ``active_bearings`` and ``sensors``."""
    rotor = cfg.section("rotor")
    rotor.check_keys(("density_kg_m3", "diameter_m", "length_m", "bearing_arm_m",
                      "tilt_stiffness_n_m_per_rad"))
    length = rotor.number("length_m", positive=True, unit="m")
    density = rotor.number("density_kg_m3", positive=True, unit="kg/m^3")
    diameter = rotor.number("diameter_m", positive=True, unit="m")
    arms = rotor.section("bearing_arm_m")
    arms.check_keys(BEARINGS)
    z_bearing = {}
    for i, sign in zip(BEARINGS, (-1.0, 1.0)):
        arm = arms.number(i, positive=True, unit="m")
        if arm > length / 2:
            raise arms.error(i, f"bearing {i} at {arm} m from the centre of mass is off the "
                                f"{length} m shaft", fix=f"give a distance <= {length / 2} m")
        z_bearing[i] = sign * arm
    k_r = rotor.number("tilt_stiffness_n_m_per_rad", nonnegative=True, unit="N m/rad")
    brg = cfg.section("active_bearings")
    brg.check_keys(BEARINGS)
    housing, planes = {}, {}
    for i in BEARINGS:
        sec = brg.section(i)
        sec.check_keys(("housing_mass_kg",) + PLANES)
        housing[i] = sec.number("housing_mass_kg", positive=True, unit="kg")
        for d in PLANES:
            planes[(i, d)] = _plane(sec.section(d))
    return model.ActiveBearingParams(density, diameter, length, z_bearing, k_r, housing, planes,
                                     tuple(sensor_offsets(cfg)))


def build(cfg: Section) -> LinearPlant:
    """The seed-002 plant of a validated config."""
    return model.build(read_params(cfg), cfg.string("name", "active_bearing"),
                       damping_floor_rad_s(cfg), cfg.data)
