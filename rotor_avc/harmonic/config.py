"""The ``harmonic:`` section of a machine config: adaptive harmonic control, validated.

::

    harmonic:
      actuators: [DL, DR, NL]              # plant actuators driven (default: all)
      sensors: [bearing_D_vz, bearing_N_vz]   # measured quantities (plant outputs, foot signals)
      harmonics: [1]                       # orders of the shaft speed (1x, 2x, ...)
      law: newton                          # steepest_descent | newton | wls
      gain: 0.5                            # adaptation gain per update (dimensionless), or
                                           # auto: per speed from the loop analysis
      adapt_in: forces                     # forces | excitations (1x: adapt the unbalance
      refresh_samples: 0                   #   estimate; phasors re-scheduled every n samples)
      feedforward: quasi_static            # quasi_static | dynamic (adapt_in excitations: the
      feedforward_effort: 1.0e-2           #   internal loop of .internal_model; its LQ weight)
      effort_weight: 0.0                   # wls: effort penalty relative to |G|^2
      leakage: 0.0                         # per update, in [0, 1)
      sensor_weights: [1.0, 1.0]           # optional, one per sensor
      update_every_samples: 0              # 0: once per revolution
      force_limit_n: 5000.0                # optional peak force per actuator
      rate_limit_n_per_s: 1.0e+7           # optional peak force slope per actuator
      min_speed_hz: 2.0                    # off below
      start_s: 0.0                         # switch-on time
      influence:                           # the speed schedule from the model
        rel_step: 0.005                    # relative speed step of the table
        phase_error_deg: 0.0               # deliberate estimate error (robustness studies)
        magnitude_factor: 1.0
      identification:                      # present: online RLS of the influence matrix
        forgetting: 0.98
        dither_n: 0.0                      # dither phasor magnitude (N), random phase
        min_change_n: 1.0e-3               # smaller changes (N) are not learnt from,
        min_rel_change: 0.1                # nor changes below this fraction of the phasors
        seed: 0
      runout:                              # optional simulated sensor runout (.runout)
        - {sensor: bearing_D_vz, order: 2, magnitude: 1.0e-4, phase_deg: 0.0}
      fallback:
        mode: freeze                       # freeze | fade
        divergence_factor: 100.0           # growth of |E| / Omega^2 since switch-on = diverging
        poor_residual: .inf                # identification residual that counts as poor
        patience: 3                        # updates a poor residual may last
        fade_updates: 10

``gain: auto`` picks, at speeds 8 % apart, the largest of :data:`AUTO_GAINS` whose exact
one-revolution loop (:func:`rotor_avc.harmonic.lti.gain_schedule`, on the unperturbed
model; with ``feedforward: dynamic`` the estimate's own loop,
:func:`rotor_avc.harmonic.lti.excitation_loop_poles`) contracts about as fast as the best; the
block uses the nearest speed's gain.

The influence matrix is the model's sampled-loop transfer with the machine's feedback
controllers closed (:mod:`rotor_avc.harmonic.influence`), on the run's damping rule.
"""
from __future__ import annotations

import math
from dataclasses import replace

from ..errors import ModelError
from .block import ADAPT_IN, FALLBACKS, HarmonicController, HarmonicSettings
from .influence import model_schedule, schedule_speeds
from .laws import LAWS
from .runout import WithRunout, runout_terms

HARMONIC_KEYS = ("actuators", "sensors", "harmonics", "law", "gain", "adapt_in", "refresh_samples",
                 "feedforward", "feedforward_effort",
                 "effort_weight", "leakage",
                 "sensor_weights", "update_every_samples", "force_limit_n", "rate_limit_n_per_s",
                 "min_speed_hz", "start_s", "influence", "identification", "fallback", "runout")
INFLUENCE_KEYS = ("rel_step", "phase_error_deg", "magnitude_factor")
IDENTIFICATION_KEYS = ("forgetting", "dither_n", "min_change_n", "min_rel_change", "seed")
FALLBACK_KEYS = ("mode", "divergence_factor", "poor_residual", "patience", "fade_updates")
DEFAULT_REL_STEP = 0.005
FEEDFORWARDS = ("quasi_static", "dynamic")
#: ``gain: auto``: candidate gains and the relative speed step of the analysed speeds
AUTO_GAINS = (0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5)
AUTO_GAIN_STEP = 0.08


def _names(sec, key, known, default=None):
    value = sec.raw(key, default)
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise sec.error(key, f"must be a non-empty list of names (got {value!r})",
                        fix="write it as [A, B, ...] with names from: " + ", ".join(known))
    unknown = [v for v in value if v not in known]
    if unknown or len(set(value)) != len(value):
        raise sec.error(key, f"unknown or repeated names {unknown or value}",
                        fix="use each of these at most once: " + ", ".join(known))
    return value


def harmonic_settings(sec, n_sensors: int) -> HarmonicSettings:
    """:class:`HarmonicSettings` from the section (ConfigError naming the field)."""
    num = lambda key, default, **kw: sec.number(key, default, **kw)  # noqa: E731
    if isinstance(sec.raw("gain", None), str) and sec.raw("gain") != "auto":
        raise sec.error("gain", f"must be a number > 0 or `auto` (got {sec.raw('gain')!r})",
                        fix="e.g. gain: 0.5, or gain: auto (per speed from the loop analysis)")
    kw = {"law": sec.choice("law", LAWS, default="newton"),
          "gain": 0.5 if sec.raw("gain", None) == "auto" else num("gain", 0.5, positive=True),
          "adapt_in": sec.choice("adapt_in", ADAPT_IN, default="forces"),
          "refresh_samples": sec.integer("refresh_samples", 0, minimum=0),
          "effort_weight": num("effort_weight", 0.0, nonnegative=True),
          "leakage": num("leakage", 0.0, nonnegative=True, maximum=0.999),
          "update_every_samples": sec.integer("update_every_samples", 0, minimum=0),
          "force_limit_n": num("force_limit_n", math.inf, positive=True, unit="N")
          if sec.has("force_limit_n") else math.inf,
          "rate_limit_n_per_s": num("rate_limit_n_per_s", None, positive=True, unit="N/s")
          if sec.has("rate_limit_n_per_s") else math.inf,
          "min_speed_hz": num("min_speed_hz", 2.0, positive=True, unit="Hz"),
          "start_s": num("start_s", 0.0, nonnegative=True, unit="s")}
    if sec.has("sensor_weights"):
        w = sec.number_list("sensor_weights", length=n_sensors)
        if min(w) <= 0:
            raise sec.error("sensor_weights", f"must all be > 0 (got {w})")
        kw["sensor_weights"] = tuple(w)
    if kw["law"] == "newton" and kw["effort_weight"] > 0:
        raise sec.error("effort_weight", "law newton has no effort penalty",
                        fix="use law: wls for an effort penalty, or drop effort_weight")
    if kw["law"] == "wls" and kw["effort_weight"] <= 0:
        raise sec.error("effort_weight", "law wls needs effort_weight > 0",
                        fix="give effort_weight > 0 (e.g. 1.0e-3) or use law: newton")
    if sec.has("identification"):
        ident = sec.section("identification")
        ident.check_keys(IDENTIFICATION_KEYS)
        kw.update(identify=True,
                  forgetting=ident.number("forgetting", 0.98, positive=True, maximum=1.0),
                  dither_n=ident.number("dither_n", 0.0, nonnegative=True, unit="N"),
                  min_change_n=ident.number("min_change_n", 1e-3, positive=True, unit="N"),
                  min_rel_change=ident.number("min_rel_change", 0.1, nonnegative=True,
                                              maximum=0.99),
                  seed=ident.integer("seed", 0, minimum=0))
    fb = sec.section("fallback", {})
    fb.check_keys(FALLBACK_KEYS)
    kw.update(fallback=fb.choice("mode", FALLBACKS, default="freeze"),
              divergence_factor=fb.number("divergence_factor", 100.0, minimum=1.0),
              patience=fb.integer("patience", 3, minimum=1),
              fade_updates=fb.integer("fade_updates", 10, minimum=1))
    if fb.has("poor_residual"):
        kw["poor_residual"] = fb.number("poor_residual", positive=True)
    return HarmonicSettings(**kw)


def harmonic_actuators(machine) -> list[str]:
    """The actuators of the ``harmonic:`` section (validated), without building the block."""
    sec = machine.config.section("harmonic")
    ids = [a.id for a in machine.plant.actuators]
    return _names(sec, "actuators", ids, default=ids)


def harmonic_from_config(machine, sample_period_s: float, max_speed_rad_s: float,
                         w_F: float | None = None) -> HarmonicController:
    """The block of the machine's ``harmonic:`` section for speeds up to ``max_speed_rad_s``
    (the run's), with the machine's feedback controllers in its influence model; ``w_F`` the
    run's frozen damping frequency (None: ``max(Omega, floor)``)."""
    from ..analysis.sampled_loop import machine_sampled_loop
    from ..sim.stepper import MeasurementLayout
    sec = machine.config.section("harmonic")
    sec.check_keys(HARMONIC_KEYS)
    plant = machine.plant
    actuators = harmonic_actuators(machine)
    sensors = _names(sec, "sensors", MeasurementLayout(plant).names)
    harmonics = sec.raw("harmonics", [1])
    if not isinstance(harmonics, list) or not harmonics or any(
            isinstance(h, bool) or not isinstance(h, int) or h < 1 for h in harmonics) \
            or len(set(harmonics)) != len(harmonics):
        raise sec.error("harmonics",
                        f"must be a list of distinct integers >= 1 (got {harmonics!r})",
                        fix="e.g. [1] or [1, 2]")
    settings = harmonic_settings(sec, len(sensors))
    terms = runout_terms(sec, sensors)
    inf = sec.section("influence", {})
    inf.check_keys(INFLUENCE_KEYS)
    rel_step = inf.number("rel_step", DEFAULT_REL_STEP, positive=True, maximum=0.5)
    start = 2 * math.pi * settings.min_speed_hz
    if max_speed_rad_s < start:
        raise sec.error("min_speed_hz", f"{settings.min_speed_hz:g} Hz is above the run's "
                        f"highest speed {max_speed_rad_s / (2 * math.pi):g} Hz",
                        fix="lower min_speed_hz")
    loop = machine_sampled_loop(machine, sample_period_s)
    excitations = settings.adapt_in == "excitations"
    if excitations and sorted(harmonics) != [1]:
        raise sec.error("adapt_in", "excitations act at 1x only", fix="use harmonics: [1]")
    dynamic = sec.choice("feedforward", FEEDFORWARDS, default="quasi_static") == "dynamic"
    if dynamic:
        _check_dynamic(sec, inf, settings)
    try:
        schedule = model_schedule(loop, sensors, actuators, sorted(harmonics),
                                  schedule_speeds(start, max_speed_rad_s, rel_step), w_F,
                                  disturbance=excitations)
    except ModelError as exc:
        raise sec.error("sensors" if "unbalance response" in str(exc) else "harmonics",
                        str(exc)) from None
    if sec.raw("gain", None) == "auto":
        from .lti import gain_schedule
        n = max(int(math.ceil(math.log(max_speed_rad_s / start) / math.log1p(AUTO_GAIN_STEP))), 1)
        speeds, gains = gain_schedule(loop, schedule, settings,
                                      [start * (max_speed_rad_s / start) ** (i / n)
                                       for i in range(n + 1)], AUTO_GAINS, w_F,
                                      excitation_loop=dynamic)
        settings = replace(settings, gain_speeds_rad_s=speeds, gain_values=gains)
    schedule = schedule.perturbed(inf.number("phase_error_deg", 0.0),
                                  inf.number("magnitude_factor", 1.0, positive=True))
    if dynamic:
        block = _dynamic_block(sec, loop, schedule, sample_period_s, settings, w_F)
    elif sec.has("feedforward_effort"):
        raise sec.error("feedforward_effort", "weights the internal loop of feedforward: "
                        "dynamic only", fix="add feedforward: dynamic, or drop it")
    else:
        block = HarmonicController(schedule, sample_period_s, settings)
    return WithRunout(block, terms) if terms else block


def _check_dynamic(sec, inf, settings) -> None:
    """ConfigError for a setting the dynamic feed-forward cannot run with."""
    if settings.adapt_in != "excitations":
        raise sec.error("feedforward", "dynamic runs the internal loop on the excitation "
                        "estimate", fix="add adapt_in: excitations, or use feedforward: "
                        "quasi_static")
    if settings.refresh_samples < 1:
        raise sec.error("refresh_samples", "the dynamic feed-forward needs its block length",
                        fix="give refresh_samples >= 1 (e.g. 25)")
    if settings.identify or inf.has("phase_error_deg") or inf.has("magnitude_factor"):
        raise sec.error("feedforward", "dynamic runs on the model itself: no influence "
                        "identification or perturbation",
                        fix="drop identification and influence.phase_error_deg / "
                        "magnitude_factor, or use feedforward: quasi_static")


def _dynamic_block(sec, loop, schedule, sample_period_s, settings, w_F):
    """The block with the dynamic feed-forward (:mod:`.dynamic_block`)."""
    from .dynamic_block import DynamicHarmonicController
    from .internal_model import DEFAULT_EFFORT, internal_tables
    effort = sec.number("feedforward_effort", DEFAULT_EFFORT, positive=True)
    try:
        tables = internal_tables(loop, schedule.actuators, schedule.sensors,
                                 schedule.speeds_rad_s, settings.refresh_samples, w_F, effort,
                                 settings.sensor_weights)
    except ModelError as exc:
        raise sec.error("feedforward", str(exc)) from None
    return DynamicHarmonicController(schedule, sample_period_s, settings, tables)

