"""``model: rigid_rotor`` (seed 004): the config sections ``rotor``, ``bearings`` and ``output``
read into :class:`~rotor_avc.models.rigid_rotor.RigidRotor`."""
from __future__ import annotations

import numpy as np

from ..config import Section
from ..models import rigid_rotor as model
from ..models.plant import LinearPlant
from ..settings import damping_floor_rad_s

#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = ("rotor", "bearings", "output")
#: what the machine built from this model supports (rotor_avc.machine.CAPABILITIES)
SUPPORTS = ("rigid_balancer",)


def rotor_from_config(cfg: Section) -> model.RigidRotor:
    """Read ``rotor``, ``bearings`` and ``output`` of a ``model: rigid_rotor`` config."""
    rot = cfg.section("rotor")
    rot.check_keys(("length_m", "radius_m", "density_kg_m3", "gyroscopic"))
    L = rot.number("length_m", positive=True, unit="m")
    r = rot.number("radius_m", positive=True, unit="m")
    rho = rot.number("density_kg_m3", positive=True, unit="kg/m^3")
    gyro = rot.raw("gyroscopic", False)
    if not isinstance(gyro, bool):
        raise rot.error("gyroscopic", f"must be true or false (got {gyro!r})")
    brg = cfg.section("bearings")
    brg.check_keys(("stiffness_n_per_m", "damping_n_s_per_m"))
    k = brg.number("stiffness_n_per_m", positive=True, unit="N/m")
    c = brg.number("damping_n_s_per_m", nonnegative=True, unit="N s/m")
    out = cfg.section("output")
    out.check_keys(("axial_position_m",))
    l_s = out.number("axial_position_m", unit="m")
    m = rho * np.pi * r**2 * L
    return model.RigidRotor(mass_kg=m, I_t=m * (3 * r**2 + L**2) / 12, I_p=m * r**2 / 2, length_m=L,
                      stiffness_n_per_m=k, damping_n_s_per_m=c, output_axial_m=l_s,
                      gyroscopic=gyro)


def build(cfg: Section) -> LinearPlant:
    """The seed-004 rotor of a validated config."""
    return model.build(rotor_from_config(cfg), cfg.string("name", "rigid_rotor"),
                       damping_floor_rad_s(cfg), cfg.data)
