"""Balancer setups from a machine config's ``balancer:`` section (declared, validated, SI units).

The section's keys depend on what the config's model supports (rotor_avc.machine.CAPABILITIES);
:data:`BALANCER_SETTINGS` declares both:

* ``rigid_balancer`` (``model: rigid_rotor``, ``config/balancer_rigid_rotor.yaml``):
  Zhou & Shi 2001's one-plane balancer of a rigid rotor during a constant-acceleration run-up --
  RLS imbalance estimate (Sec. 2, eqs. 2-3), optimal switching law (eqs. 7-13, Fig. 4):
  :class:`RigidBalancerSettings` -> :class:`RigidSetup`;
* ``plane_balancer`` (a LinearPlant with ``static`` and ``moment`` excitations and a rotor
  between bearings, ``config/balancer_foot_mount.yaml``): the same estimate and a one-plane
  correction on Werner 2021's machine, through the model's influence coefficients (neither paper
  gives a balancer for this machine): :class:`PlaneBalancerSettings` -> :class:`MachineSetup`.

Each setup builds the block (estimator + law + supervisor), the actuator and the in-process
run-up scenario, so the command line, the tests and the balancer node share one reading; its
``grade`` rates an unbalance by ISO 21940-11:2016 (:mod:`.grade`) against the section's
``permissible_grade_mm_s`` at the run-up's highest speed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..section import Section
from ..errors import ModelError
from ..machine import Machine, model_supports, models_supporting
from ..model_config.rigid_rotor import rotor_from_config
from ..models.rigid_rotor import RigidRotor
from ..settings import read_settings, setting
from .actuator import BalancerActuator
from .block import BalancerBlock
from .grade import RotorGrade
from .influence import InfluenceTable, influence_table
from .machine_rls import MachineImbalanceRls
from .plane import MachinePlane, point_mass_unbalance
from .plane_correction import CORRECTION_STRATEGIES, PlaneCorrectionLaw
from .machine_runup import MachineRunup
from .regression import AXES, REGRESSIONS
from .rigid_runup import RigidRunup
from .rls import RigidRotorRls
from .switching import (STRATEGIES, WEIGHTS, RigidSwitchingLaw, switching_schedule,
                        switching_weight)


def _check_length(sec: Section, key: str, values: tuple, n: int) -> None:
    if len(values) != n:
        raise sec.error(key, f"must have {n} entries (got {len(values)})")


def _check_moves(sec: Section, move_time_s: float, rate_key: str, max_rate) -> None:
    """The actuator moves over a time or at a rate: it cannot jump (:mod:`.actuator`)."""
    if move_time_s == 0 and max_rate is None:
        raise sec.error("move_time_s", "the balancer needs a move time or a max rate (it cannot "
                        "jump)", fix=f"give move_time_s > 0 or {rate_key}")


# -- rigid_balancer: Zhou & Shi 2001 -------------------------------------------------------------
@dataclass(frozen=True)
class RigidEstimatorSettings:
    """``balancer.estimator``: the RLS estimate of the imbalance parameters ``b1 .. b4``
    (Zhou & Shi 2001, Sec. 2, eqs. 2-3; :mod:`.regression`, :mod:`.rls`)."""

    regression: str = setting("midpoint", "difference quotient of the regression (Zhou & Shi "
                              "2001 eq. 2): `forward` (as printed, biased near resonance), "
                              "`midpoint` or `measured` accelerations", choices=REGRESSIONS)
    axes: str = setting("both", "`x`: Zhou & Shi 2001's R_X and theta rows of eq. 2; `both`: "
                        "also the R_Z and psi rows", choices=AXES)
    forgetting_factor: float = setting(1.0, "RLS forgetting factor (1: ordinary least squares, "
                                       "as Zhou & Shi 2001 eq. 3)", minimum=1e-6, maximum=1.0)
    prior_std_m: float = setting(1e-3, "prior standard deviation of b1, b2 (Zhou & Shi 2001 "
                                 "eq. 2; sets P0)", unit="m", positive=True)
    noise_std_m: float = setting(0.0, "standard deviation of the measured R_X, R_Z", unit="m",
                                 nonnegative=True)
    tilt_noise_std_rad: float = setting(0.0, "standard deviation of the measured theta, psi",
                                        unit="rad", nonnegative=True)
    gyro_compensation: bool = setting(False, "subtract the known I_p terms of eq. 1 from y2 (not "
                                      "in Zhou & Shi 2001)")


@dataclass(frozen=True)
class RigidSupervisorSettings:
    """``balancer.supervisor``: the paper's four-step procedure (Zhou & Shi 2001, Fig. 4 g)."""

    estimate_until_s: float = setting(1.0, "step (1) of Zhou & Shi 2001 Sec. 3: the balancer "
                                      "held at its initial position while estimating", unit="s",
                                      nonnegative=True)
    strategy: str = setting("optimal", "`none`, `mode1` (cancel the force imbalance, Zhou & Shi "
                            "2001 eq. 4), `mode2` (the moment imbalance, eq. 5) or `optimal` "
                            "(the switching law, eqs. 7-13; Fig. 4 a, c, e, g)",
                            choices=STRATEGIES)
    switching_weight: float | str = setting("paper", "W of the switch M_1 = W M_2 (Zhou & Shi "
                                            "2001 eq. 13): `paper` (W = l_s, the published "
                                            "2.9506 s), `derived` (W = abs(d) l_s, eq. 13 as "
                                            "written) or a number", positive=True,
                                            choices=WEIGHTS)


@dataclass(frozen=True)
class RigidImbalance:
    """``balancer.run_up.imbalance``: the true imbalance, a point mass (Zhou & Shi 2001, Sec. 2)."""

    mass_kg: float = setting(doc="imbalance mass m_u (Zhou & Shi 2001 eq. 1)", unit="kg",
                             nonnegative=True)
    position_m: tuple[float, ...] = setting(doc="(u_x, u_y, u_z) in the body frame (Zhou & Shi "
                                            "2001 eq. 1)", unit="m", min_length=3)

    def check(self, sec: Section) -> None:
        _check_length(sec, "position_m", self.position_m, 3)


@dataclass(frozen=True)
class RigidNoise:
    """``balancer.run_up.noise``: uniform noise on the estimator's displacement signals."""

    displacement_m: float = setting(0.0, "half-width on R_X, R_Z (Zhou & Shi 2001: 1e-5 m on "
                                    "the output)", unit="m", nonnegative=True)
    tilt_rad: float = setting(0.0, "half-width on theta, psi", unit="rad", nonnegative=True)
    seed: int = setting(0, "random seed of the noise", minimum=0)


@dataclass(frozen=True, kw_only=True)
class RigidRunUpSettings:
    """``balancer.run_up``: the in-process run-up of `rotor-avc balance` (Zhou & Shi 2001, Sec. 3:
    constant acceleration from rest, the closed form of App. A)."""

    accel_rad_s2: float = setting(doc="constant angular acceleration alpha (Zhou & Shi 2001 "
                                  "Sec. 3; > 0: the switching law and App. A need it)",
                                  unit="rad/s^2", positive=True)
    speed0_rad_s: float = setting(0.0, "initial speed", unit="rad/s", nonnegative=True)
    angle0_rad: float = setting(0.0, "initial shaft angle", unit="rad")
    duration_s: float = setting(doc="length of the run", unit="s", positive=True)
    integrator_step_s: float = setting(5e-5, "RK4 step of the plant (divides "
                                       "balancer.sample_period_s)", unit="s", positive=True)
    imbalance: RigidImbalance = setting(doc="the true imbalance")
    noise: RigidNoise = setting(RigidNoise, "noise on the estimator's signals")


@dataclass(frozen=True, kw_only=True)
class RigidBalancerSettings:
    """``balancer:`` of ``model: rigid_rotor``: Zhou & Shi 2001's mass-redistribution balancer."""

    mass_kg: float = setting(doc="balancer mass m_b (Zhou & Shi 2001 eq. 1)", unit="kg",
                             positive=True)
    axial_position_m: float = setting(doc="w_y, the balancing plane (Zhou & Shi 2001 eq. 1), "
                                      "on the rotor: at most L/2 from its centre", unit="m")
    initial_position_m: tuple[float, ...] = setting((0.0, 0.0), "(w_x, w_z) at the start (Zhou "
                                                    "& Shi 2001: zero)", unit="m", min_length=2)
    move_time_s: float = setting(0.2, "duration of a linear move (Zhou & Shi 2001: 0.2 s)",
                                 unit="s", nonnegative=True)
    max_rate_m_per_s: float | None = setting(None, "speed limit of a move (none: no limit)",
                                             unit="m/s", positive=True)
    max_radius_m: float | None = setting(None, "largest radius of (w_x, w_z) (none: no limit)",
                                         unit="m", positive=True)
    sample_period_s: float = setting(doc="T, the estimator's sample period (Zhou & Shi 2001 "
                                     "eq. 2)", unit="s", positive=True)
    permissible_grade_mm_s: float = setting(2.5, "permissible balance quality grade G of the "
                                            "residual unbalance (ISO 21940-11:2016 6.2, "
                                            "Table 1: G 2.5 e.g. for electric motors)",
                                            unit="mm/s", positive=True)
    estimator: RigidEstimatorSettings = setting(RigidEstimatorSettings, "the RLS estimate")
    supervisor: RigidSupervisorSettings = setting(RigidSupervisorSettings, "when and where the "
                                                  "balancer moves")
    run_up: RigidRunUpSettings = setting(doc="the in-process run-up (`rotor-avc balance`)")

    def check(self, sec: Section) -> None:
        _check_length(sec, "initial_position_m", self.initial_position_m, 2)
        _check_moves(sec, self.move_time_s, "max_rate_m_per_s", self.max_rate_m_per_s)


@dataclass(frozen=True)
class RigidSetup:
    """Zhou & Shi 2001's balancer: rotor, run-up, estimator and supervisor settings."""

    rotor: RigidRotor
    runup: RigidRunup
    initial_position: complex
    move_time_s: float
    max_rate_m_s: float | None
    max_radius_m: float | None
    estimator: dict
    estimate_until_s: float
    strategy: str
    weight: object
    grade: RotorGrade

    def schedule(self, weight=None):
        W = switching_weight(self.rotor, self.runup.balancer_axial_m,
                             self.weight if weight is None else weight)
        return switching_schedule(self.rotor, self.runup.accel_rad_s2, self.runup.duration_s, W,
                                  self.runup.speed0_rad_s)

    def block(self, strategy: str | None = None, weight=None, **estimator) -> BalancerBlock:
        sc = self.runup
        est = RigidRotorRls(self.rotor, sc.balancer_mass_kg, sc.balancer_axial_m,
                            **{**self.estimator, **estimator})
        law = RigidSwitchingLaw(sc.balancer_mass_kg, sc.balancer_axial_m, self.schedule(weight),
                                strategy or self.strategy)
        return BalancerBlock(est, law, self.estimate_until_s, self.initial_position)

    def actuator(self) -> BalancerActuator:
        return BalancerActuator(self.move_time_s, self.max_rate_m_s, self.max_radius_m,
                                self.initial_position)


def rigid_setup(cfg: Section) -> RigidSetup:
    rotor = rotor_from_config(cfg)
    bal = cfg.section("balancer")
    s = read_settings(RigidBalancerSettings, bal)
    if abs(s.axial_position_m) > rotor.length_m / 2:
        raise bal.error("axial_position_m", f"balancing plane at {s.axial_position_m} m is "
                        f"outside the rotor (|w_y| <= L/2 = {rotor.length_m / 2} m)",
                        fix="put the plane on the shaft, between the bearings")
    run, est, sup = s.run_up, s.estimator, s.supervisor
    runup = RigidRunup(
        rotor=rotor, accel_rad_s2=run.accel_rad_s2, duration_s=run.duration_s,
        sample_period_s=s.sample_period_s, integrator_step_s=run.integrator_step_s,
        imbalance_mass_kg=run.imbalance.mass_kg, imbalance_position_m=run.imbalance.position_m,
        balancer_mass_kg=s.mass_kg, balancer_axial_m=s.axial_position_m,
        speed0_rad_s=run.speed0_rad_s, angle0_rad=run.angle0_rad,
        noise_displacement_m=run.noise.displacement_m, noise_tilt_rad=run.noise.tilt_rad,
        seed=run.noise.seed)
    return RigidSetup(
        rotor=rotor, runup=runup, initial_position=complex(*s.initial_position_m),
        move_time_s=s.move_time_s, max_rate_m_s=s.max_rate_m_per_s, max_radius_m=s.max_radius_m,
        estimator=dict(regression=est.regression, forgetting=est.forgetting_factor,
                       prior_std_m=est.prior_std_m, noise_std_m=est.noise_std_m,
                       tilt_noise_std_rad=est.tilt_noise_std_rad,
                       gyro_compensation=est.gyro_compensation, axes=est.axes),
        estimate_until_s=sup.estimate_until_s, strategy=sup.strategy,
        weight=sup.switching_weight,
        grade=RotorGrade(rotor.mass_kg, (("bearing y-", -rotor.length_m / 2),
                                         ("bearing y+", rotor.length_m / 2)), 1.0,
                         runup.top_speed_rad_s, s.permissible_grade_mm_s))


# -- plane_balancer: one plane on a LinearPlant machine ------------------------------------------
@dataclass(frozen=True, kw_only=True)
class PlaneEstimatorSettings:
    """``balancer.estimator``: RLS of the static and moment unbalance through the model's
    influence coefficients (:mod:`.machine_rls`; Zhou & Shi 2001's estimate on Werner 2021's
    machine)."""

    forgetting_factor: float = setting(1.0, "RLS forgetting factor (1: ordinary least squares)",
                                       minimum=1e-6, maximum=1.0)
    prior_std_kg_m: float = setting(0.1, "prior standard deviation of the static unbalance u_e "
                                    "(Werner 2021 eq. 13)", unit="kg m", positive=True)
    prior_std_kg_m2: float = setting(0.1, "prior standard deviation of the moment unbalance "
                                     "u_alpha (Werner 2021 eq. 14)", unit="kg m^2",
                                     positive=True)
    noise_std: float = setting(doc="standard deviation of the signals' noise, in their unit "
                               "(m/s^2 for foot accelerations)", positive=True)
    min_speed_hz: float = setting(1.0, "the estimate holds below this speed (no usable signal)",
                                  unit="Hz", positive=True)


@dataclass(frozen=True)
class PlaneSupervisorSettings:
    """``balancer.supervisor``: when the balancer moves and which correction it makes
    (:mod:`.plane_correction`)."""

    estimate_until_s: float = setting(0.0, "the balancer held at zero while estimating",
                                      unit="s", nonnegative=True)
    strategy: str = setting("least_squares", "`none`, `static` / `moment` (cancel one unbalance "
                            "type, Zhou & Shi 2001 eqs. 4-5), `bang_bang` (the better of the two "
                            "at each speed, eq. 13) or `least_squares` (the smallest objective "
                            "response)", choices=CORRECTION_STRATEGIES)


@dataclass(frozen=True, kw_only=True)
class PointMass:
    """An entry of ``balancer.run_up.unbalance``: a point mass on the rotor (:mod:`.plane`)."""

    mass_kg: float = setting(doc="mass m", unit="kg", nonnegative=True)
    radius_m: float = setting(doc="radius e", unit="m", nonnegative=True)
    angle_deg: float = setting(0.0, "angle phi, from +z towards +y (Werner 2021's phase "
                               "convention)", unit="deg")
    axial_position_m: float = setting(doc="axial position a, + towards bearing D", unit="m")


@dataclass(frozen=True, kw_only=True)
class PlaneRunUpSettings:
    """``balancer.run_up``: the in-process run-up of `rotor-avc balance`."""

    accel_rad_s2: float = setting(doc="constant angular acceleration", unit="rad/s^2",
                                  positive=True)
    speed0_hz: float = setting(0.0, "initial speed", unit="Hz", nonnegative=True)
    stop_hz: float = setting(doc="final speed (also bounds the influence table)", unit="Hz",
                             positive=True)
    unbalance: tuple[PointMass, ...] = setting(doc="the true unbalance: point masses on the "
                                               "rotor", min_length=1)
    noise_std: float = setting(0.0, "Gaussian noise on every balancer signal, in its unit",
                               nonnegative=True)
    seed: int = setting(0, "random seed of the noise", minimum=0)


@dataclass(frozen=True, kw_only=True)
class PlaneBalancerSettings:
    """``balancer:`` of a model with a rotor between bearings (Werner 2021's machine): one
    balancing plane, its estimate, law and run-up."""

    plane_axial_position_m: float = setting(doc="axial position a of the balancing plane on "
                                            "Werner 2021's rotor axis, + towards bearing D, "
                                            "between the bearings", unit="m")
    max_mass_radius_kg_m: float | None = setting(None, "largest correction (none: no limit)",
                                                 unit="kg m", positive=True)
    move_time_s: float = setting(0.0, "shortest move", unit="s", nonnegative=True)
    max_rate_kg_m_per_s: float | None = setting(None, "rate limit of the correction (none: no "
                                                "limit)", unit="kg m/s", positive=True)
    sample_period_s: float = setting(doc="the balancer's sample period", unit="s",
                                     positive=True)
    permissible_grade_mm_s: float = setting(2.5, "permissible balance quality grade G of the "
                                            "residual unbalance (ISO 21940-11:2016 6.2, "
                                            "Table 1: G 2.5 e.g. for electric motors)",
                                            unit="mm/s", positive=True)
    signals: tuple[str, ...] | None = setting(None, "the estimate's signals: feet with actuators "
                                              "(their vertical accelerations) or plant outputs "
                                              "(default: every actuator's foot)", min_length=1)
    objective: tuple[str, ...] | None = setting(None, "plant outputs whose 1x response the law "
                                                "minimises (default: the `bearing_*` outputs)",
                                                min_length=1)
    speed_step_hz: float = setting(0.02, "speed step of the influence-coefficient table (well "
                                   "below the half-power bandwidths)", unit="Hz", positive=True)
    estimator: PlaneEstimatorSettings = setting(doc="the RLS estimate")
    supervisor: PlaneSupervisorSettings = setting(PlaneSupervisorSettings, "when and how the "
                                                  "balancer corrects")
    run_up: PlaneRunUpSettings = setting(doc="the in-process run-up (`rotor-avc balance`)")

    def check(self, sec: Section) -> None:
        _check_moves(sec, self.move_time_s, "max_rate_kg_m_per_s", self.max_rate_kg_m_per_s)


#: the ``balancer:`` declaration per capability of the config's model (rotor_avc.machine)
BALANCER_SETTINGS = {"rigid_balancer": RigidBalancerSettings,
                     "plane_balancer": PlaneBalancerSettings}


def plane_balancer_settings(bal: Section) -> PlaneBalancerSettings:
    """The ``balancer:`` section of a ``plane_balancer`` model, validated."""
    return read_settings(PlaneBalancerSettings, bal)


@dataclass(frozen=True)
class MachineSetup:
    """A one-plane balancer on a LinearPlant machine (Werner 2021's)."""

    machine: Machine
    plane: MachinePlane
    signals: InfluenceTable
    objective: InfluenceTable
    runup: MachineRunup
    move_time_s: float
    max_rate: float | None
    estimator: dict
    estimate_until_s: float
    strategy: str
    grade: RotorGrade

    def block(self, strategy: str | None = None) -> BalancerBlock:
        est = MachineImbalanceRls(self.signals, self.plane, **self.estimator)
        law = PlaneCorrectionLaw(self.objective, self.plane, strategy or self.strategy)
        return BalancerBlock(est, law, self.estimate_until_s)

    def actuator(self) -> BalancerActuator:
        return BalancerActuator(self.move_time_s, self.max_rate,
                                self.plane.max_mass_radius_kg_m)


def machine_setup(machine: Machine) -> MachineSetup:
    cfg = machine.config
    bal = cfg.section("balancer")
    if not model_supports(cfg, "plane_balancer"):
        raise cfg.error("balancer", f"model {cfg.string('model')} has no one-plane machine "
                        "balancer (it is placed between the machine's bearings)",
                        fix="use it with model: " + ", ".join(models_supporting("plane_balancer")))
    s = plane_balancer_settings(bal)
    brg = cfg.section("machine").section("bearing_axial_position_m")
    try:
        plane = MachinePlane(s.plane_axial_position_m, -brg.number("N", unit="m"),
                             brg.number("D", unit="m"), s.max_mass_radius_kg_m)
    except ModelError as exc:
        raise bal.error("plane_axial_position_m", str(exc)) from None
    run, est = s.run_up, s.estimator
    u = np.zeros(2, complex)
    for mass in run.unbalance:
        amp = point_mass_unbalance(mass.mass_kg, mass.radius_m, math.radians(mass.angle_deg),
                                   mass.axial_position_m)
        u += [amp["static"], amp["moment"]]
    stop = 2 * math.pi * run.stop_hz
    runup = MachineRunup(run.accel_rad_s2, 2 * math.pi * run.speed0_hz, stop, s.sample_period_s,
                         (u[0], u[1]), run.noise_std, run.seed)
    min_speed = 2 * math.pi * est.min_speed_hz
    step = 2 * math.pi * s.speed_step_hz
    grid = np.arange(min_speed, stop + 2 * step, step)
    ids = [a.id for a in machine.plant.actuators]
    signals = ids if s.signals is None else list(s.signals)
    objective = ([o.name for o in machine.plant.outputs if o.name.startswith("bearing_")]
                 if s.objective is None else list(s.objective))
    for key, names in (("signals", signals), ("objective", objective)):
        if not names:
            raise bal.error(key, "must be a non-empty list of names",
                            fix="feet with actuators (" + ", ".join(ids) + ") or plant outputs")
    try:
        sig_table = influence_table(machine.loop, signals, grid)
        obj_table = influence_table(machine.loop, objective, grid)
    except ModelError as exc:
        raise bal.error("signals/objective", str(exc)) from None
    return MachineSetup(
        machine=machine, plane=plane, signals=sig_table, objective=obj_table, runup=runup,
        move_time_s=s.move_time_s, max_rate=s.max_rate_kg_m_per_s,
        estimator=dict(prior_std_kg_m=est.prior_std_kg_m, prior_std_kg_m2=est.prior_std_kg_m2,
                       noise_std=est.noise_std, min_speed_rad_s=min_speed,
                       forgetting=est.forgetting_factor),
        estimate_until_s=s.supervisor.estimate_until_s, strategy=s.supervisor.strategy,
        grade=RotorGrade(cfg.section("machine").number("rotor_mass_kg", unit="kg"),
                         (("bearing N", plane.rotor_min_m), ("bearing D", plane.rotor_max_m)),
                         1j, stop, s.permissible_grade_mm_s))
