"""The ``harmonic:`` section of a machine config: adaptive harmonic control, declared.

:data:`HARMONIC_SETTINGS` declares every key (type, default, bounds, unit, meaning; the reference:
``rotor_avc.settings._rows(HARMONIC_SETTINGS, "harmonic")``). For example::

    harmonic:
      actuators: [DL, DR, NL]                 # default: all the plant's actuators
      sensors: [bearing_D_vz, bearing_N_vz]
      harmonics: [1]
      law: newton
      gain: 0.15                              # or auto
      identification: {forgetting: 0.98}      # present: online RLS of the influence matrix
      runout:                                 # optional simulated sensor runout (.runout)
        - {sensor: bearing_D_vz, order: 2, magnitude: 1.0e-4, phase_deg: 0.0}

``gain: auto`` picks, at speeds 8 % apart, the largest of :data:`AUTO_GAINS` whose exact
one-revolution loop (:func:`rotor_avc.harmonic.lti.gain_schedule`, on the unperturbed
model; with ``feedforward: dynamic`` the estimate's own loop,
:func:`rotor_avc.harmonic.lti.excitation_loop_poles`) contracts about as fast as the best; the
block uses the nearest speed's gain.

The influence matrix is the model's sampled-loop transfer with the machine's feedback
controllers closed (:mod:`rotor_avc.harmonic.influence`), on the run's damping rule.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, replace

import numpy as np

from ..section import Section
from ..errors import ModelError
from ..settings import read_settings, setting
from .block import HarmonicController
from .block_settings import ADAPT_IN, FALLBACKS, HarmonicSettings
from .influence import InfluenceSchedule, model_schedule, schedule_speeds
from .laws import LAWS
from .runout import WithRunout
from .supervisor import SupervisorSettings

FEEDFORWARDS = ("quasi_static", "dynamic")
#: ``gain: auto``: candidate gains and the relative speed step of the analysed speeds
AUTO_GAINS = (0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5)
AUTO_GAIN_STEP = 0.08


@dataclass(frozen=True, kw_only=True)
class InfluenceTableEntry:
    """An entry of ``harmonic.influence.table``: one element ``G_h[sensor, actuator]`` of a
    measured influence matrix (``rotor-avc harmonic commission`` writes them,
    :mod:`.commission`)."""

    speed_hz: float = setting(doc="shaft speed it was measured at", unit="Hz", positive=True)
    harmonic: int = setting(1, "order h of the shaft speed", minimum=1)
    sensor: str = setting(doc="one of the section's `sensors`")
    actuator: str = setting(doc="one of the section's `actuators`")
    re: float = setting(doc="real part, sensor unit per N")
    im: float = setting(doc="imaginary part, sensor unit per N")


@dataclass(frozen=True)
class InfluenceSettings:
    """``harmonic.influence``: the influence matrix's speed schedule from the model
    (:mod:`.influence`), or a measured table."""

    rel_step: float = setting(0.005, "relative speed step of the table", positive=True,
                              maximum=0.5)
    phase_error_deg: float = setting(0.0, "deliberate phase error of the estimate (robustness "
                                     "studies; feedforward dynamic: of its internal model's "
                                     "actuators)", unit="deg")
    magnitude_factor: float = setting(1.0, "deliberate magnitude factor of the estimate "
                                      "(feedforward dynamic: of its internal model's actuators)",
                                      positive=True)
    table: tuple[InfluenceTableEntry, ...] = setting((), "measured influence matrices, every "
                                                     "(speed, harmonic, sensor, actuator) once, "
                                                     "used instead of the model's (held "
                                                     "rel_step beyond its first and last speed)")


@dataclass(frozen=True)
class IdentificationSettings:
    """``harmonic.identification``: online RLS of the influence matrix (:mod:`.identification`)."""

    forgetting: float = setting(0.98, "RLS forgetting factor", positive=True, maximum=1.0)
    dither_n: float = setting(0.0, "dither phasor magnitude (random phase)", unit="N",
                              nonnegative=True)
    min_change_n: float = setting(1e-3, "smaller phasor changes are not learnt from", unit="N",
                                  positive=True)
    min_rel_change: float = setting(0.1, "nor changes below this fraction of the phasors",
                                    nonnegative=True, maximum=0.99)
    seed: int = setting(0, "random seed of the dither", minimum=0)


@dataclass(frozen=True)
class FallbackSettings:
    """``harmonic.fallback``: what the block does when its loop diverges or its estimate is poor
    (:mod:`.block`)."""

    mode: str = setting("fade", "`fade` (fade the phasors out) or `freeze` (hold them)",
                        choices=FALLBACKS)
    divergence_factor: float = setting(100.0, "growth of the error magnitude over Omega^2 since "
                                       "switch-on that counts as diverging", minimum=1.0)
    poor_residual: float | None = setting(None, "identification prediction residual that counts "
                                          "as poor (none: never)", positive=True)
    patience: int = setting(3, "updates a poor residual may last", minimum=1)
    fade_updates: int = setting(10, "updates a fade lasts", minimum=1)


@dataclass(frozen=True)
class CommissionSettings:
    """``harmonic.commission``: the influence matrix identified on the machine with test phasors,
    one actuator at a time, and the margin check before adapting (:mod:`.commission`)."""

    test_force_n: float = setting(100.0, "peak force of each test phasor (within force_limit_n "
                                  "and rate_limit_n_per_s)", unit="N", positive=True)
    max_added_vibration: float | None = setting(None, "largest rise of a sensor's 1x (nx) "
                                                "magnitude during a test, sensor unit (none: its "
                                                "level before the test)", positive=True)
    ramp_revolutions: int = setting(5, "revolutions a test phasor is faded in over", minimum=1)
    settle_revolutions: int = setting(40, "revolutions waited before measuring", minimum=1)
    measure_revolutions: int = setting(10, "revolutions averaged", minimum=2)
    max_retries: int = setting(4, "halvings of a test level that added too much vibration",
                               minimum=0)
    min_phase_margin_deg: float = setting(20.0, "refuse adapting when the loop tolerates less "
                                          "phase error of the table", unit="deg",
                                          nonnegative=True, maximum=90.0)


@dataclass(frozen=True, kw_only=True)
class RunoutEntry:
    """An entry of ``harmonic.runout``: ``Re{R_h e^{j h theta}}`` added to one sensor's signal
    (:mod:`.runout`)."""

    sensor: str = setting(doc="one of the section's `sensors`")
    order: int = setting(1, "order h of the shaft angle", minimum=1)
    magnitude: float = setting(doc="magnitude of R_h, in the sensor's unit", nonnegative=True)
    phase_deg: float = setting(0.0, "arg R_h", unit="deg")

    @property
    def amplitude(self) -> complex:
        """``R_h``."""
        phase = math.radians(self.phase_deg)
        return self.magnitude * complex(math.cos(phase), math.sin(phase))


@dataclass(frozen=True, kw_only=True)
class HarmonicControlSettings:
    """``harmonic:`` of a machine config: actuator forces locked to the shaft angle, adapted
    once per revolution (:mod:`.block`, laws :mod:`.laws`)."""

    actuators: tuple[str, ...] | None = setting(None, "plant actuators driven (default: all)",
                                                min_length=1)
    sensors: tuple[str, ...] = setting(doc="measured quantities: plant outputs and foot "
                                       "signals (rotor_avc.sim.stepper.MeasurementLayout)",
                                       min_length=1)
    harmonics: tuple[float, ...] = setting((1.0,), "orders of the shaft speed (1x, 2x, ...): "
                                           "distinct integers >= 1", min_length=1)
    law: str = setting("newton", "update law", choices=LAWS)
    gain: float | str = setting(0.5, "adaptation gain per update, or `auto`: per speed from the "
                                "loop analysis", positive=True, choices=("auto",))
    adapt_in: str = setting("forces", "adapt the phasors (`forces`) or, at 1x, an estimate of "
                            "the excitations (`excitations`)", choices=ADAPT_IN)
    refresh_samples: int = setting(0, "adapt_in excitations: phasors re-scheduled every n "
                                   "samples (0: at the updates only)", minimum=0)
    feedforward: str = setting("quasi_static", "adapt_in excitations: `dynamic` drives the "
                               "internal loop of rotor_avc/harmonic/internal_model.py",
                               choices=FEEDFORWARDS)
    feedforward_effort: float | None = setting(None, "feedforward dynamic: LQ effort weight of "
                                               "the internal loop (default: its DEFAULT_EFFORT)",
                                               positive=True)
    effort_weight: float = setting(0.0, "law wls: effort penalty relative to the squared "
                                   "largest singular value of the influence estimate",
                                   nonnegative=True)
    leakage: float = setting(0.0, "leakage per update", nonnegative=True, maximum=0.999)
    sensor_weights: tuple[float, ...] | None = setting(None, "one per sensor, > 0 (default: "
                                                       "equal)", min_length=1)
    update_every_samples: int = setting(0, "update period (0: once per revolution)", minimum=0)
    force_limit_n: float | None = setting(None, "peak force per actuator (none: no limit)",
                                          unit="N", positive=True)
    rate_limit_n_per_s: float | None = setting(None, "peak force slope per actuator (none: no "
                                               "limit)", unit="N/s", positive=True)
    min_speed_hz: float = setting(2.0, "off below this speed", unit="Hz", positive=True)
    start_s: float = setting(0.0, "switch-on time", unit="s", nonnegative=True)
    influence: InfluenceSettings = setting(InfluenceSettings, "the influence schedule")
    identification: IdentificationSettings | None = setting(None, "present (`{}`: the "
                                                            "defaults): online identification")
    fallback: FallbackSettings = setting(FallbackSettings, "safe fallback")
    supervisor: SupervisorSettings = setting(SupervisorSettings, "never worse than off: fall "
                                             "back, re-identify, adapt again "
                                             "(rotor_avc/harmonic/supervisor.py)")
    runout: tuple[RunoutEntry, ...] = setting((), "simulated sensor runout")
    commission: CommissionSettings = setting(CommissionSettings, "`rotor-avc harmonic "
                                             "commission`: test phasors and margin")

    def check(self, sec: Section) -> None:
        if any(h != int(h) or h < 1 for h in self.harmonics) \
                or len(set(self.harmonics)) != len(self.harmonics):
            raise sec.error("harmonics", "must be a list of distinct integers >= 1 (got ["
                            + ", ".join(f"{h:g}" for h in self.harmonics) + "])",
                            fix="e.g. [1] or [1, 2]")
        if self.sensor_weights is not None:
            w = list(self.sensor_weights)
            if len(w) != len(self.sensors):
                raise sec.error("sensor_weights", f"must have {len(self.sensors)} entries "
                                f"(got {len(w)})")
            if min(w) <= 0:
                raise sec.error("sensor_weights", f"must all be > 0 (got {w})")
        if self.law == "newton" and self.effort_weight > 0:
            raise sec.error("effort_weight", "law newton has no effort penalty",
                            fix="use law: wls for an effort penalty, or drop effort_weight")
        if self.law == "wls" and self.effort_weight <= 0:
            raise sec.error("effort_weight", "law wls needs effort_weight > 0",
                            fix="give effort_weight > 0 (e.g. 1.0e-3) or use law: newton")
        if self.adapt_in == "excitations" and self.harmonics != (1.0,):
            raise sec.error("adapt_in", "excitations act at 1x only", fix="use harmonics: [1]")
        for i, entry in enumerate(self.runout):
            if entry.sensor not in self.sensors:
                raise sec.error(f"runout[{i}].sensor", f"{entry.sensor!r} is not a harmonic "
                                "sensor", fix="use one of: " + ", ".join(self.sensors))
        if self.influence.table and self.adapt_in != "forces":
            raise sec.error("influence.table", "a measured table has no disturbance model: it "
                            "serves adapt_in: forces", fix="drop adapt_in, or drop influence.table")
        if self.feedforward == "dynamic":
            self._check_dynamic(sec)
        elif self.feedforward_effort is not None:
            raise sec.error("feedforward_effort", "weights the internal loop of feedforward: "
                            "dynamic only", fix="add feedforward: dynamic, or drop it")

    def _check_dynamic(self, sec: Section) -> None:
        """ConfigError for a setting the dynamic feed-forward cannot run with."""
        if self.adapt_in != "excitations":
            raise sec.error("feedforward", "dynamic runs the internal loop on the excitation "
                            "estimate", fix="add adapt_in: excitations, or use feedforward: "
                            "quasi_static")
        if self.refresh_samples < 1:
            raise sec.error("refresh_samples", "the dynamic feed-forward needs its block length",
                            fix="give refresh_samples >= 1 (e.g. 25)")
        if self.identification is not None:
            raise sec.error("identification", "the dynamic feed-forward runs its internal model "
                            "with the declared model error (influence.phase_error_deg / "
                            "magnitude_factor), not an identified influence",
                            fix="drop identification, or use feedforward: quasi_static")


#: the ``harmonic:`` declaration
HARMONIC_SETTINGS = HarmonicControlSettings


def harmonic_section(cfg: Section) -> HarmonicControlSettings:
    """The config's ``harmonic:`` section, validated."""
    return read_settings(HARMONIC_SETTINGS, cfg.section("harmonic"))


def _names(sec: Section, key: str, names, known) -> list[str]:
    """``names`` (of ``key``), each one of ``known`` and given once."""
    names = list(names)
    if not names:
        raise sec.error(key, f"must be a non-empty list of names (got {names!r})",
                        fix="write it as [A, B, ...] with names from: " + ", ".join(known))
    unknown = [v for v in names if v not in known]
    if unknown or len(set(names)) != len(names):
        raise sec.error(key, f"unknown or repeated names {unknown or names}",
                        fix="use each of these at most once: " + ", ".join(known))
    return names


def _actuators(machine, s: HarmonicControlSettings) -> list[str]:
    ids = [a.id for a in machine.plant.actuators]
    return _names(machine.config.section("harmonic"), "actuators",
                  ids if s.actuators is None else s.actuators, ids)


def harmonic_actuators(machine) -> list[str]:
    """The actuators of the ``harmonic:`` section (validated), without building the block."""
    return _actuators(machine, harmonic_section(machine.config))


def harmonic_sensors(machine) -> list[str]:
    """The sensors of the ``harmonic:`` section (validated), without building the block."""
    from ..sim.stepper import MeasurementLayout
    return _names(machine.config.section("harmonic"), "sensors",
                  harmonic_section(machine.config).sensors, MeasurementLayout(machine.plant).names)


def _block_settings(s: HarmonicControlSettings) -> HarmonicSettings:
    """The block's :class:`HarmonicSettings` (``gain: auto``: the block's default gain, replaced
    by the gain schedule)."""
    kw = dict(law=s.law, adapt_in=s.adapt_in, refresh_samples=s.refresh_samples,
              effort_weight=s.effort_weight, leakage=s.leakage,
              sensor_weights=s.sensor_weights, update_every_samples=s.update_every_samples,
              force_limit_n=math.inf if s.force_limit_n is None else s.force_limit_n,
              rate_limit_n_per_s=(math.inf if s.rate_limit_n_per_s is None
                                  else s.rate_limit_n_per_s),
              min_speed_hz=s.min_speed_hz, start_s=s.start_s, fallback=s.fallback.mode,
              divergence_factor=s.fallback.divergence_factor, patience=s.fallback.patience,
              fade_updates=s.fallback.fade_updates, supervisor=s.supervisor)
    if s.gain != "auto":
        kw["gain"] = s.gain
    if s.fallback.poor_residual is not None:
        kw["poor_residual"] = s.fallback.poor_residual
    ident = s.identification
    if ident is not None:
        kw.update(identify=True, forgetting=ident.forgetting, dither_n=ident.dither_n,
                  min_change_n=ident.min_change_n, min_rel_change=ident.min_rel_change,
                  seed=ident.seed)
    return HarmonicSettings(**kw)


def harmonic_from_config(machine, sample_period_s: float, max_speed_rad_s: float,
                         w_F: float | None = None) -> HarmonicController:
    """The block of the machine's ``harmonic:`` section for speeds up to ``max_speed_rad_s``
    (the run's), with the machine's feedback controllers in its influence model; ``w_F`` the
    run's frozen damping frequency (None: ``max(Omega, floor)``)."""
    from ..analysis.sampled_loop import machine_sampled_loop
    from ..sim.stepper import MeasurementLayout
    sec = machine.config.section("harmonic")
    s = harmonic_section(machine.config)
    actuators = _actuators(machine, s)
    sensors = _names(sec, "sensors", s.sensors, MeasurementLayout(machine.plant).names)
    harmonics = sorted(int(h) for h in s.harmonics)
    settings = _block_settings(s)
    start = 2 * math.pi * s.min_speed_hz
    if max_speed_rad_s < start:
        raise sec.error("min_speed_hz", f"{s.min_speed_hz:g} Hz is above the run's "
                        f"highest speed {max_speed_rad_s / (2 * math.pi):g} Hz",
                        fix="lower min_speed_hz")
    loop = machine_sampled_loop(machine, sample_period_s)
    dynamic = s.feedforward == "dynamic"
    try:
        if s.influence.table:
            schedule = table_schedule(sec, s, sensors, actuators, harmonics)
        else:
            schedule = model_schedule(loop, sensors, actuators, harmonics,
                                      schedule_speeds(start, max_speed_rad_s, s.influence.rel_step),
                                      w_F, disturbance=s.adapt_in == "excitations")
    except ModelError as exc:
        raise sec.error("sensors" if "unbalance response" in str(exc) else "harmonics",
                        str(exc)) from None
    if s.gain == "auto":
        from .lti import gain_schedule
        n = max(int(math.ceil(math.log(max_speed_rad_s / start) / math.log1p(AUTO_GAIN_STEP))), 1)
        speeds, gains = gain_schedule(loop, schedule, settings,
                                      [start * (max_speed_rad_s / start) ** (i / n)
                                       for i in range(n + 1)], AUTO_GAINS, w_F,
                                      excitation_loop=dynamic)
        settings = replace(settings, gain_speeds_rad_s=speeds, gain_values=gains)
    schedule = schedule.perturbed(s.influence.phase_error_deg, s.influence.magnitude_factor)
    if dynamic:
        block = _dynamic_block(sec, loop, schedule, sample_period_s, settings, w_F,
                               s.feedforward_effort, s.influence)
    else:
        block = HarmonicController(schedule, sample_period_s, settings)
    terms = [(sensors.index(r.sensor), r.order, r.amplitude) for r in s.runout]
    return WithRunout(block, terms) if terms else block


def table_schedule(sec: Section, s: HarmonicControlSettings, sensors, actuators, harmonics
                   ) -> InfluenceSchedule:
    """The measured ``influence.table`` as a schedule, every (speed, harmonic, sensor, actuator)
    given once; held ``influence.rel_step`` beyond its first and last speed, so that a table of
    one speed serves a run at that speed."""
    tsec = sec.section("influence")
    speeds = sorted({e.speed_hz for e in s.influence.table})
    axes = (speeds, list(harmonics), list(sensors), list(actuators))
    values = {}
    for i, e in enumerate(s.influence.table):
        for key, value, known in (("harmonic", e.harmonic, harmonics),
                                  ("sensor", e.sensor, sensors),
                                  ("actuator", e.actuator, actuators)):
            if value not in known:
                raise tsec.error(f"table[{i}].{key}", f"{value!r} is not one of the section's",
                                 fix="use one of: " + ", ".join(map(str, known)))
        key = (e.speed_hz, e.harmonic, e.sensor, e.actuator)
        if key in values:
            raise tsec.error(f"table[{i}]", f"repeats {key}", fix="give each element once")
        values[key] = complex(e.re, e.im)
    mats = np.zeros(tuple(len(a) for a in axes), complex)
    for idx in np.ndindex(*mats.shape):
        key = tuple(a[n] for a, n in zip(axes, idx))
        if key not in values:
            raise tsec.error("table", f"has no element for speed_hz {key[0]:g}, harmonic "
                             f"{key[1]}, sensor {key[2]}, actuator {key[3]}",
                             fix="give every (speed, harmonic, sensor, actuator) once")
        mats[idx] = values[key]
    step = s.influence.rel_step
    w = 2 * math.pi * np.array([speeds[0] * (1 - step), *speeds, speeds[-1] * (1 + step)])
    return InfluenceSchedule(w, tuple(harmonics), np.concatenate([mats[:1], mats, mats[-1:]]),
                             tuple(sensors), tuple(actuators))


def _dynamic_block(sec, loop, schedule, sample_period_s, settings, w_F, effort, influence):
    """The block with the dynamic feed-forward (:mod:`.dynamic_block`), its internal model's
    actuators off by the declared ``influence`` error."""
    from .dynamic_block import DynamicHarmonicController
    from .internal_model import DEFAULT_EFFORT, internal_tables
    try:
        tables = internal_tables(loop, schedule.actuators, schedule.sensors,
                                 schedule.speeds_rad_s, settings.refresh_samples, w_F,
                                 DEFAULT_EFFORT if effort is None else effort,
                                 settings.sensor_weights)
    except ModelError as exc:
        raise sec.error("feedforward", str(exc)) from None
    error = cmath.rect(influence.magnitude_factor, math.radians(influence.phase_error_deg))
    return DynamicHarmonicController(schedule, sample_period_s, settings, tables, error)
