"""Balancer setups from a machine config's ``balancer:`` section (validated, SI units).

* ``model: rigid_rotor`` (seed 004, ``config/balancer_rigid_rotor.yaml``): :class:`RigidSetup`;
* any LinearPlant with ``static`` and ``moment`` excitations and a rotor between bearings
  (seed 000, ``config/balancer_foot_mount.yaml``): :class:`MachineSetup`.

Each setup builds the block (estimator + law + supervisor), the actuator and the in-process
run-up scenario, so the command line, the tests and the balancer node share one reading.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import Section
from ..errors import ModelError
from ..machine import Machine, model_supports, models_supporting
from ..model_config.rigid_rotor import rotor_from_config
from ..models.rigid_rotor import RigidRotor
from .actuator import BalancerActuator
from .block import BalancerBlock
from .influence import InfluenceTable, influence_table
from .machine_rls import MachineImbalanceRls
from .plane import MachinePlane, point_mass_unbalance
from .plane_correction import CORRECTION_STRATEGIES, PlaneCorrectionLaw
from .machine_runup import MachineRunup
from .regression import AXES, REGRESSIONS
from .rigid_runup import RigidRunup
from .rls import RigidRotorRls
from .switching import STRATEGIES, RigidSwitchingLaw, switching_schedule, switching_weight


def _flag(sec: Section, key: str, default: bool) -> bool:
    value = sec.raw(key, default)
    if not isinstance(value, bool):
        raise sec.error(key, f"must be true or false (got {value!r})")
    return value


def _optional(sec: Section, key: str, unit: str) -> float | None:
    return None if sec.raw(key, None) is None else sec.number(key, positive=True, unit=unit)


@dataclass(frozen=True)
class RigidSetup:
    """The seed-004 balancer: rotor, run-up, estimator and supervisor settings."""

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
    bal.check_keys(("mass_kg", "axial_position_m", "initial_position_m", "move_time_s",
                    "max_rate_m_per_s", "max_radius_m", "sample_period_s", "estimator",
                    "supervisor", "run_up"))
    w0 = bal.number_list("initial_position_m", [0.0, 0.0], length=2)
    est = bal.section("estimator", {})
    est.check_keys(("regression", "forgetting_factor", "prior_std_m", "noise_std_m",
                    "tilt_noise_std_rad", "gyro_compensation", "axes"))
    sup = bal.section("supervisor", {})
    sup.check_keys(("estimate_until_s", "strategy", "switching_weight"))
    weight = sup.raw("switching_weight", "paper")
    if weight not in ("paper", "derived"):
        weight = sup.number("switching_weight", positive=True)
    run = bal.section("run_up")
    run.check_keys(("accel_rad_s2", "speed0_rad_s", "angle0_rad", "duration_s",
                    "integrator_step_s", "imbalance", "noise"))
    imb = run.section("imbalance")
    imb.check_keys(("mass_kg", "position_m"))
    noise = run.section("noise", {})
    noise.check_keys(("displacement_m", "tilt_rad", "seed"))
    accel = run.number("accel_rad_s2", unit="rad/s^2")
    if accel <= 0:
        raise run.error("accel_rad_s2", f"must be > 0 (got {accel}): the run-up law and the "
                        "closed form of App. A need a constant positive acceleration",
                        fix="give the run-up's angular acceleration, e.g. 300.0")
    runup = RigidRunup(
        rotor=rotor, accel_rad_s2=accel,
        duration_s=run.number("duration_s", positive=True, unit="s"),
        sample_period_s=bal.number("sample_period_s", positive=True, unit="s"),
        integrator_step_s=run.number("integrator_step_s", 5e-5, positive=True, unit="s"),
        imbalance_mass_kg=imb.number("mass_kg", nonnegative=True, unit="kg"),
        imbalance_position_m=tuple(imb.number_list("position_m", length=3)),
        balancer_mass_kg=bal.number("mass_kg", positive=True, unit="kg"),
        balancer_axial_m=bal.number("axial_position_m", unit="m"),
        speed0_rad_s=run.number("speed0_rad_s", 0.0, nonnegative=True, unit="rad/s"),
        angle0_rad=run.number("angle0_rad", 0.0, unit="rad"),
        noise_displacement_m=noise.number("displacement_m", 0.0, nonnegative=True, unit="m"),
        noise_tilt_rad=noise.number("tilt_rad", 0.0, nonnegative=True, unit="rad"),
        seed=noise.integer("seed", 0, minimum=0))
    if abs(runup.balancer_axial_m) > rotor.length_m / 2:
        raise bal.error("axial_position_m", f"balancing plane at {runup.balancer_axial_m} m is "
                        f"outside the rotor (|w_y| <= L/2 = {rotor.length_m / 2} m)",
                        fix="put the plane on the shaft, between the bearings")
    return RigidSetup(
        rotor=rotor, runup=runup, initial_position=complex(*w0),
        move_time_s=bal.number("move_time_s", 0.2, nonnegative=True, unit="s"),
        max_rate_m_s=_optional(bal, "max_rate_m_per_s", "m/s"),
        max_radius_m=_optional(bal, "max_radius_m", "m"),
        estimator=dict(
            regression=est.choice("regression", REGRESSIONS, "midpoint"),
            forgetting=est.number("forgetting_factor", 1.0, minimum=1e-6, maximum=1.0),
            prior_std_m=est.number("prior_std_m", 1e-3, positive=True, unit="m"),
            noise_std_m=est.number("noise_std_m", 0.0, nonnegative=True, unit="m"),
            tilt_noise_std_rad=est.number("tilt_noise_std_rad", 0.0, nonnegative=True, unit="rad"),
            gyro_compensation=_flag(est, "gyro_compensation", False),
            axes=est.choice("axes", AXES, "both")),
        estimate_until_s=sup.number("estimate_until_s", 1.0, nonnegative=True, unit="s"),
        strategy=sup.choice("strategy", STRATEGIES, "optimal"), weight=weight)


@dataclass(frozen=True)
class MachineSetup:
    """A one-plane balancer on a LinearPlant machine (seed 000)."""

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
    bal.check_keys(("plane_axial_position_m", "max_mass_radius_kg_m", "move_time_s",
                    "max_rate_kg_m_per_s", "sample_period_s", "signals", "objective",
                    "speed_step_hz", "estimator", "supervisor", "run_up"))
    brg = cfg.section("machine").section("bearing_axial_position_m")
    try:
        plane = MachinePlane(bal.number("plane_axial_position_m", unit="m"),
                             -brg.number("N", unit="m"), brg.number("D", unit="m"),
                             _optional(bal, "max_mass_radius_kg_m", "kg m"))
    except ModelError as exc:
        raise bal.error("plane_axial_position_m", str(exc)) from None
    run = bal.section("run_up")
    run.check_keys(("accel_rad_s2", "speed0_hz", "stop_hz", "unbalance", "noise_std", "seed"))
    u = np.zeros(2, complex)
    masses = run.raw("unbalance")
    if not isinstance(masses, list) or not masses:
        raise run.error("unbalance", "must be a list of point masses",
                        fix="write [{mass_kg: .., radius_m: .., angle_deg: .., axial_position_m: ..}]")
    for i, item in enumerate(masses):
        sec = Section(item if isinstance(item, dict) else {}, f"{run.path}.unbalance[{i}]",
                      run.source)
        sec.check_keys(("mass_kg", "radius_m", "angle_deg", "axial_position_m"))
        amp = point_mass_unbalance(sec.number("mass_kg", nonnegative=True, unit="kg"),
                                   sec.number("radius_m", nonnegative=True, unit="m"),
                                   math.radians(sec.number("angle_deg", 0.0)),
                                   sec.number("axial_position_m", unit="m"))
        u += [amp["static"], amp["moment"]]
    stop = 2 * math.pi * run.number("stop_hz", positive=True, unit="Hz")
    runup = MachineRunup(run.number("accel_rad_s2", positive=True, unit="rad/s^2"),
                         2 * math.pi * run.number("speed0_hz", 0.0, nonnegative=True, unit="Hz"),
                         stop, bal.number("sample_period_s", positive=True, unit="s"),
                         (u[0], u[1]), run.number("noise_std", 0.0, nonnegative=True),
                         run.integer("seed", 0, minimum=0))
    est = bal.section("estimator", {})
    est.check_keys(("forgetting_factor", "prior_std_kg_m", "prior_std_kg_m2", "noise_std",
                    "min_speed_hz"))
    min_speed = 2 * math.pi * est.number("min_speed_hz", 1.0, positive=True, unit="Hz")
    step = 2 * math.pi * bal.number("speed_step_hz", 0.02, positive=True, unit="Hz")
    grid = np.arange(min_speed, stop + 2 * step, step)
    ids = [a.id for a in machine.plant.actuators]
    signals = bal.raw("signals", ids)
    objective = bal.raw("objective", [o.name for o in machine.plant.outputs
                                      if o.name.startswith("bearing_")])
    for key, names in (("signals", signals), ("objective", objective)):
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            raise bal.error(key, "must be a non-empty list of names",
                            fix="feet with actuators (" + ", ".join(ids) + ") or plant outputs")
    try:
        sig_table = influence_table(machine.loop, signals, grid)
        obj_table = influence_table(machine.loop, objective, grid)
    except ModelError as exc:
        raise bal.error("signals/objective", str(exc)) from None
    sup = bal.section("supervisor", {})
    sup.check_keys(("estimate_until_s", "strategy"))
    return MachineSetup(
        machine=machine, plane=plane, signals=sig_table, objective=obj_table, runup=runup,
        move_time_s=bal.number("move_time_s", 0.0, nonnegative=True, unit="s"),
        max_rate=_optional(bal, "max_rate_kg_m_per_s", "kg m/s"),
        estimator=dict(
            prior_std_kg_m=est.number("prior_std_kg_m", 0.1, positive=True, unit="kg m"),
            prior_std_kg_m2=est.number("prior_std_kg_m2", 0.1, positive=True, unit="kg m^2"),
            noise_std=est.number("noise_std", positive=True), min_speed_rad_s=min_speed,
            forgetting=est.number("forgetting_factor", 1.0, minimum=1e-6, maximum=1.0)),
        estimate_until_s=sup.number("estimate_until_s", 0.0, nonnegative=True, unit="s"),
        strategy=sup.choice("strategy", CORRECTION_STRATEGIES, "least_squares"))
