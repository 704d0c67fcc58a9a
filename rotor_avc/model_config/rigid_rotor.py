"""``model: rigid_rotor`` (Zhou & Shi 2001): the config sections ``rotor``, ``bearings`` and
``output``, declared once (:data:`MODEL_SETTINGS`) and read into
:class:`~rotor_avc.models.rigid_rotor.RigidRotor`."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..section import Section
from ..models import rigid_rotor as model
from ..models.plant import LinearPlant
from ..settings import damping_floor_rad_s, read_part, setting

#: what the machine built from this model supports (rotor_avc.machine.CAPABILITIES)
SUPPORTS = ("rigid_balancer",)


@dataclass(frozen=True)
class ShaftSettings:
    """``rotor:`` a solid cylindrical shaft spinning about Y (Zhou & Shi 2001, Sec. 3):
    ``m = rho pi r^2 L``, ``I_t = m (3 r^2 + L^2) / 12``, ``I_p = m r^2 / 2``."""

    length_m: float = setting(doc="shaft length L (Zhou & Shi 2001, Sec. 3)", unit="m",
                              positive=True)
    radius_m: float = setting(doc="shaft radius r (Zhou & Shi 2001, Sec. 3)", unit="m",
                              positive=True)
    density_kg_m3: float = setting(doc="shaft density rho (not in Zhou & Shi 2001; steel, 7800, "
                                   "reproduces its switching time 2.9506 s)", unit="kg/m^3",
                                   positive=True)
    gyroscopic: bool = setting(False, "keep the I_p terms of A(t) (Zhou & Shi 2001, eq. 1), "
                               "which the paper's analysis drops")


@dataclass(frozen=True)
class BearingSettings:
    """``bearings:`` two identical isotropic bearings at y = +-L/2 (Zhou & Shi 2001, eq. 1)."""

    stiffness_n_per_m: float = setting(doc="stiffness k of each bearing (Zhou & Shi 2001, "
                                       "Sec. 3)", unit="N/m", positive=True)
    damping_n_s_per_m: float = setting(doc="viscous damping c of each bearing (Zhou & Shi 2001, "
                                       "Sec. 3)", unit="N s/m", nonnegative=True)


@dataclass(frozen=True)
class OutputSettings:
    """``output:`` the point on the spin axis whose motion is the output."""

    axial_position_m: float = setting(doc="axial position l_s of the output point from the mass "
                                      "centre (Zhou & Shi 2001, Sec. 3 and eq. 10)", unit="m")


@dataclass(frozen=True)
class RigidRotorSettings:
    """The top-level keys of a ``model: rigid_rotor`` config (Zhou & Shi 2001)."""

    rotor: ShaftSettings = setting(doc="the shaft (Zhou & Shi 2001, Sec. 3)")
    bearings: BearingSettings = setting(doc="the two bearings (Zhou & Shi 2001, Sec. 3)")
    output: OutputSettings = setting(doc="the output point (Zhou & Shi 2001, Sec. 3)")


#: the declaration of this model's top-level config keys
MODEL_SETTINGS = RigidRotorSettings
#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = tuple(f.name for f in dataclasses.fields(MODEL_SETTINGS))


def rotor_from_config(cfg: Section) -> model.RigidRotor:
    """Validate ``rotor``, ``bearings`` and ``output`` of a ``model: rigid_rotor`` config
    (:data:`MODEL_SETTINGS`) into the rotor."""
    s = read_part(MODEL_SETTINGS, cfg)
    L, r = s.rotor.length_m, s.rotor.radius_m
    m = s.rotor.density_kg_m3 * np.pi * r**2 * L
    return model.RigidRotor(mass_kg=m, I_t=m * (3 * r**2 + L**2) / 12, I_p=m * r**2 / 2,
                            length_m=L, stiffness_n_per_m=s.bearings.stiffness_n_per_m,
                            damping_n_s_per_m=s.bearings.damping_n_s_per_m,
                            output_axial_m=s.output.axial_position_m,
                            gyroscopic=s.rotor.gyroscopic)


def build(cfg: Section) -> LinearPlant:
    """The Zhou & Shi 2001 rotor of a validated config."""
    return model.build(rotor_from_config(cfg), cfg.string("name", "rigid_rotor"),
                       damping_floor_rad_s(cfg), cfg.data)
