"""``model: foot_mount_3d`` (Werner 2021): the config sections ``machine``, ``foundation``,
``mounting``, ``elements`` and ``feet``, declared once (:data:`MODEL_SETTINGS`) and read into
:class:`~rotor_avc.models.foot_mount_3d.FootMountParams` (see ``config/foot_mount_*.yaml``).

Table numbers are those of Werner 2021's numerical example (Sec. 4); the symbols those of its
equations."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..section import Section
from ..models import foot_mount_3d as model
from ..models.foot_mount_3d import MOUNTS
from ..models.plant import LinearPlant
from ..settings import damping_floor_rad_s, read_part, setting

#: what the machine built from this model supports (rotor_avc.machine.CAPABILITIES)
SUPPORTS = ("plane_balancer",)
#: the model's range of a loss factor (Werner 2021, eq. 44: tan(delta) < 0.2)
LOSS_FACTOR_LIMIT = 0.2


def _check_loss_factor(sec: Section, tan_delta: float) -> None:
    if tan_delta >= LOSS_FACTOR_LIMIT:
        raise sec.error("tan_delta", f"loss factor {tan_delta} is outside the model's range "
                        f"(eq. 44 needs tan(delta) < {LOSS_FACTOR_LIMIT:g})",
                        fix="give the loss factor tan(delta), not a percentage")


# -- per direction, per side -------------------------------------------------------------------
@dataclass(frozen=True)
class PrincipalInertias:
    """Moments of inertia about the vertical, lateral and axial axis (the order of eq. 10)."""

    z: float = setting(doc="about the vertical axis z", unit="kg m^2", positive=True)
    y: float = setting(doc="about the lateral axis y", unit="kg m^2", positive=True)
    x: float = setting(doc="about the rotor axis x", unit="kg m^2", positive=True)


@dataclass(frozen=True)
class Stiffnesses:
    """Spring stiffnesses in the vertical, lateral and axial direction (the order of eq. 10)."""

    z: float = setting(doc="vertical", unit="N/m", positive=True)
    y: float = setting(doc="lateral", unit="N/m", positive=True)
    x: float = setting(doc="axial", unit="N/m", positive=True)


@dataclass(frozen=True)
class LateralArms:
    """Lateral lever arms of the left and right feet from S."""

    L: float = setting(doc="b_L of the left feet", unit="m", positive=True)
    R: float = setting(doc="b_R of the right feet", unit="m", positive=True)


@dataclass(frozen=True)
class AxialArms:
    """Axial lever arms of the drive-side and non-drive-side feet from S."""

    D: float = setting(doc="a_D of the drive-side feet", unit="m", positive=True)
    N: float = setting(doc="a_N of the non-drive-side feet", unit="m", positive=True)


@dataclass(frozen=True)
class BearingPositions:
    """Axial distances of the bearing housings B_D (at +l_D) and B_N (at -l_N) from S."""

    D: float = setting(doc="l_D of the drive-side bearing housing", unit="m", nonnegative=True)
    N: float = setting(doc="l_N of the non-drive-side bearing housing", unit="m",
                       nonnegative=True)


# -- the sections ------------------------------------------------------------------------------
@dataclass(frozen=True)
class MachineSettings:
    """``machine:`` the rigid machine, stator and rotor with a common centre of gravity S
    (Werner 2021, Table 1); the field names are those of FootMountParams."""

    stator_mass_kg: float = setting(doc="stator mass m_s (Werner 2021, Table 1)", unit="kg",
                                    positive=True)
    rotor_mass_kg: float = setting(doc="rotor mass m_r (Werner 2021, Table 1)", unit="kg",
                                   positive=True)
    stator_inertia_kg_m2: PrincipalInertias = setting(
        doc="stator moments of inertia theta_sz, theta_sy, theta_sx (Werner 2021, Table 1)")
    rotor_polar_inertia_kg_m2: float = setting(
        doc="rotor polar moment of inertia theta_rx: gyroscopic matrix (eq. 12) and moment "
            "unbalance only (Werner 2021, Table 1)", unit="kg m^2", nonnegative=True)
    rotor_transverse_inertia_kg_m2: float = setting(
        doc="rotor transverse moment of inertia theta_ry = theta_rz (Werner 2021, Table 1)",
        unit="kg m^2", nonnegative=True)
    foot_height_m: float = setting(doc="height h of the feet below S (Werner 2021, Table 1)",
                                   unit="m", nonnegative=True)
    foot_lateral_arm_m: LateralArms = setting(
        doc="lateral arms b_L, b_R of the feet (Werner 2021, Table 1)")
    foot_axial_arm_m: AxialArms = setting(
        doc="axial arms a_D, a_N of the feet (Werner 2021, Table 1)")
    bearing_axial_position_m: BearingPositions = setting(
        doc="axial positions l_D, l_N of the bearing housings (Werner 2021, Table 1)")


@dataclass(frozen=True)
class FoundationSettings:
    """``foundation:`` the soft foundation under each foot, one point mass on three springs
    (Werner 2021, Table 2; the same at DL, DR, NL and NR)."""

    mass_kg: float = setting(doc="modal mass m_f of a foundation point (Werner 2021, Table 2)",
                             unit="kg", positive=True)
    tan_delta: float = setting(doc="loss factor tan(delta_f), below 0.2 (Werner 2021, Table 2 "
                               "and eq. 44)", nonnegative=True)
    stiffness_n_per_m: Stiffnesses = setting(
        doc="stiffnesses c_fz, c_fy, c_fx of a foundation point (Werner 2021, Table 2)")

    def check(self, sec: Section) -> None:
        _check_loss_factor(sec, self.tan_delta)


@dataclass(frozen=True)
class ElementSettings:
    """An actuator or passive stiff element between a foot and its foundation point; the field
    names are those of FootElement."""

    armature_mass_kg: float = setting(doc="armature mass m_aa, moves with the machine foot "
                                      "(Werner 2021, Tables 3-4)", unit="kg", nonnegative=True)
    stator_mass_kg: float = setting(doc="stator mass m_as, moves with the foundation point "
                                    "(Werner 2021, Tables 3-4)", unit="kg", nonnegative=True)
    stiffness_n_per_m: Stiffnesses = setting(
        doc="stiffnesses c_az, c_ay, c_ax (Werner 2021, Tables 3-4)")
    tan_delta: float = setting(doc="loss factor tan(delta_a), below 0.2 (Werner 2021, Tables "
                               "3-4 and eq. 44)", nonnegative=True)

    def check(self, sec: Section) -> None:
        _check_loss_factor(sec, self.tan_delta)


@dataclass(frozen=True)
class FootElements:
    """``elements:`` the kinds of element a foot may stand on (named in ``feet``)."""

    actuator: ElementSettings | None = setting(
        None, "the active actuator: its force acts between foot and foundation (Werner 2021, "
        "Table 3)")
    stiff_element: ElementSettings | None = setting(
        None, "the passive stiff element (Werner 2021, Table 4)")


@dataclass(frozen=True)
class Feet:
    """``feet:`` what stands between each foot and its foundation point (Werner 2021, Sec. 4:
    actuators at DL, DR and NL, the stiff element at NR)."""

    DL: str = setting("none", "foot DL (drive side, left)", choices=MOUNTS)
    DR: str = setting("none", "foot DR (drive side, right)", choices=MOUNTS)
    NL: str = setting("none", "foot NL (non-drive side, left)", choices=MOUNTS)
    NR: str = setting("none", "foot NR (non-drive side, right)", choices=MOUNTS)


@dataclass(frozen=True)
class FootMountSettings:
    """The top-level keys of a ``model: foot_mount_3d`` config (Werner 2021)."""

    machine: MachineSettings = setting(doc="the machine (Werner 2021, Table 1)")
    foundation: FoundationSettings = setting(doc="the foundation (Werner 2021, Table 2)")
    mounting: str = setting(doc="`elements`: each foot on what `feet` names (Werner 2021, cases "
                            "2 and 3); `direct`: every foot tied rigidly to the foundation "
                            "(case 1)", choices=("elements", "direct"))
    elements: FootElements = setting(FootElements, "the elements `feet` may name (Werner 2021, "
                                     "Tables 3-4); every one given is validated")
    feet: Feet = setting(Feet, "the element of each foot, `none` without (required with "
                         "`mounting: elements`)")

    def check(self, sec: Section) -> None:
        mounts = dataclasses.asdict(self.feet)
        if self.mounting == "elements":
            sec.raw("feet")                                  # raises "missing" with the fix
        elif any(m != "none" for m in mounts.values()):
            raise sec.error("feet", "mounting: direct ties every foot rigidly to the foundation, "
                            "so no foot can carry an element",
                            fix="set every foot to `none` or use `mounting: elements`")
        for kind in mounts.values():
            if kind != "none" and getattr(self.elements, kind) is None:
                raise sec.section("elements", {}).error(kind, "missing",
                                                        fix=f"add `{kind}:` to elements")


#: the declaration of this model's top-level config keys
MODEL_SETTINGS = FootMountSettings
#: top-level config keys this model reads (next to rotor_avc.machine.COMMON_KEYS)
MODEL_KEYS = tuple(f.name for f in dataclasses.fields(MODEL_SETTINGS))


def read_params(cfg: Section) -> model.FootMountParams:
    """Validate the keys of :data:`MODEL_SETTINGS` into the model's parameters."""
    s = read_part(MODEL_SETTINGS, cfg)
    elements = {kind: model.FootElement(**element)
                for kind, element in dataclasses.asdict(s.elements).items() if element is not None}
    return model.FootMountParams(
        **dataclasses.asdict(s.machine), foundation_mass_kg=s.foundation.mass_kg,
        foundation_tan_delta=s.foundation.tan_delta,
        foundation_stiffness_n_per_m=dataclasses.asdict(s.foundation.stiffness_n_per_m),
        mounting=s.mounting, mounts=dataclasses.asdict(s.feet), elements=elements)


def build(cfg: Section) -> LinearPlant:
    """The Werner 2021 plant of a validated config."""
    return model.build(read_params(cfg), cfg.string("name", "foot_mount_3d"),
                       damping_floor_rad_s(cfg), cfg.data)
