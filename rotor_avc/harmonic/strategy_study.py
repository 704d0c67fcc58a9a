"""Strategy comparison: one machine and speed profile under no control, the paper's feedback,
adaptive harmonic control (each law; and, for 1x on plant outputs, the dynamic feed-forward of
:mod:`.dynamic_block`: the Newton law adapting the excitation estimate that drives the internal
loop; and commissioned: the Newton law on the influence table that commissioning identified on
the machine first, :mod:`.commission`), the two combined, and -- where the config has them -- the
Sci. Rep. 2023 feed-forward and the balancer.

The commissioned variant commissions in-process before its run (harmonic control off, the
config's ``harmonic.commission`` settings), at the profile's constant speed or, over a run-up,
at the uncontrolled model's resonances and the top speed (:func:`commission_speeds`; the table
is interpolated between them and held ``influence.rel_step`` beyond its ends, harmonic control
is off below the first); it adapts the forces with that table and no declared model error. A
refused commissioning (margin below ``min_phase_margin_deg``, or a test stopped) is said with
its reason and the variant is not run (no adaptation).

Every strategy is a variant of one scenario (a config with a ``harmonic:`` section): feedback =
the config's ``controllers:``; harmonic = its ``harmonic:`` with the law replaced. Results from
order tracking of the recorded sensor signals (one phasor per revolution,
:func:`rotor_avc.analysis.order_tracking.phasor`), relative to the uncontrolled run's:

* steady 1x attenuation per sensor: the mean level of the last ``TAIL`` revolutions (dB);
* time to -20 dB: first revolution after the harmonic switch-on (``harmonic.start_s``) from which
  every sensor stays 20 dB below the uncontrolled level (seconds);
* peak actuator force (N) and peak foot displacement (m, the stroke's upper bound on a stiff
  foundation) over the run;
* over a run-up: the 1x peak reduction at each resonance of the uncontrolled model (peaks of
  its sampled-loop unbalance response at the sensors, :func:`rotor_avc.analysis.resonance_peaks.
  model_peaks`): the uncontrolled run's highest per-revolution level within ``PEAK_BAND_HZ`` of
  the resonance minus the strategy's there (dB);
* robustness at a constant speed (the nearest with a whole number of samples per revolution):
  the exact one-revolution loop's ``max |z|`` (:mod:`rotor_avc.harmonic.lti`), its
  gain margin (factor on the gain to ``max |z| = 1``) and the quasi-steady phase-error limit of
  the law (the dynamic feed-forward: its estimate loop's ``max |z|`` and gain margin).
"""
from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..analysis.order_tracking import phasor
from ..analysis.resonance_peaks import model_peaks
from ..analysis.sampled_loop import machine_sampled_loop
from ..errors import ModelError
from ..machine import models_supporting
from ..studies.progress import Progress
from .config import harmonic_section
from .dynamic_block import DynamicHarmonicController
from .laws import convergence_radius, update_matrices
from .lti import excitation_loop_poles, harmonic_poles, stable_gain_limit

TAIL = 5
PHASE_STEP_DEG = 5.0
PEAK_BAND_HZ = 1.0
LAWS = {"harmonic steepest descent": {"law": "steepest_descent"},
        "harmonic Newton": {"law": "newton", "effort_weight": 0.0},
        "harmonic WLS": {"law": "wls", "effort_weight": 1e-3}}
DYNAMIC = "harmonic dynamic feed-forward"
COMMISSIONED = "harmonic commissioned"
#: the commissioned variant: the Newton law adapting the forces (a measured table has no
#: disturbance model), its table added after commissioning
COMMISSIONED_HARMONIC = {**LAWS["harmonic Newton"], "adapt_in": "forces",
                         "feedforward": "quasi_static", "refresh_samples": 0}
#: resonances closer than this (relative) are commissioned once
SAME_SPEED = 0.01
#: the dynamic variant's block length where the config gives none (samples)
DYNAMIC_REFRESH = 25


@dataclass
class StrategyResult:
    name: str
    time_s: np.ndarray                    # revolution centres
    speed_hz: np.ndarray
    level_db: np.ndarray                  # (revolutions, sensors), re the uncontrolled run
    amplitude: np.ndarray                 # (revolutions, sensors), 1x magnitude (SI)
    attenuation_db: list[float]
    time_to_20db_s: float | None
    peak_force_n: float
    peak_foot_displacement_m: float
    robustness: dict = field(default_factory=dict)
    #: run-ups: ``(sensor, resonance Hz) -> 1x peak reduction (dB)``
    peak_reduction_db: dict = field(default_factory=dict)


def dynamic_variant(harmonic: dict, plant_outputs) -> dict | None:
    """The ``harmonic:`` changes of the dynamic feed-forward variant (``gain: auto``: its
    estimate loop, not the phasors', sets the gain), or None where it cannot run (harmonics
    other than 1x, sensors that are not plant outputs: no disturbance model; online
    identification)."""
    if [float(h) for h in harmonic.get("harmonics", [1])] != [1.0] or plant_outputs is None \
            or not set(harmonic.get("sensors", [])) <= set(plant_outputs) \
            or harmonic.get("identification") is not None:
        return None
    return {**LAWS["harmonic Newton"], "adapt_in": "excitations", "feedforward": "dynamic",
            "gain": "auto", "refresh_samples": int(harmonic.get("refresh_samples")
                                                   or DYNAMIC_REFRESH)}


def variants(data: dict, plant_outputs=None) -> dict[str, dict]:
    """The strategies' configs, derived from one merged scenario config; ``plant_outputs``:
    the machine's output names (the dynamic feed-forward needs its sensors among them)."""
    if "harmonic" not in data:
        raise ModelError("the strategy study needs a scenario with a `harmonic:` section "
                         "(e.g. include harmonic_bearings.yaml)")
    out = {}

    def make(name, controllers: bool, harmonic: dict | None, **sim):
        d = copy.deepcopy(data)
        if not controllers:
            d.pop("controllers", None)
        d["simulation"].update(harmonic=harmonic is not None, **sim)
        if harmonic is not None:
            d["harmonic"].update(harmonic)
        out[name] = d

    make("no control", False, None)
    if data.get("controllers"):
        make("feedback", True, None)
    for name, law in LAWS.items():
        make(name, False, law)
    dynamic = dynamic_variant(data["harmonic"], plant_outputs)
    if dynamic is not None:
        make(DYNAMIC, False, dynamic)
    make(COMMISSIONED, False, COMMISSIONED_HARMONIC)
    if data.get("controllers"):
        make("feedback + harmonic Newton", True, LAWS["harmonic Newton"])
    if data.get("model") in models_supporting("feedforward"):
        make("feed-forward (Sci. Rep. 2023)", False, None, feedforward={"type": "synchronous"})
    if data.get("balancer"):
        make("balancer", bool(data.get("controllers")), None, balancer=True)
    return out


def revolutions(ts, sensors) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """1x magnitudes per whole revolution: ``(time_s, speed_hz, |Y| (revs, sensors))``."""
    theta = ts.angle_rad
    marks = theta[0] + 2 * np.pi * np.arange(int((theta[-1] - theta[0]) / (2 * np.pi)) + 1)
    idx = np.searchsorted(theta, marks)
    y = np.stack([ts.channels[s] for s in sensors], axis=1)
    spans = [(a, b) for a, b in zip(idx[:-1], idx[1:]) if b > a + 2]
    if not spans:
        raise ModelError("the run covers less than one revolution")
    amps = np.array([np.abs(phasor(theta[a:b], y[a:b])) for a, b in spans])
    mid = np.array([(a + b) // 2 for a, b in spans])
    return ts.time_s[mid], ts.speed_rad_s[mid] / (2 * np.pi), amps


def robustness(scenario, block) -> dict:
    """At a constant speed (moved to the nearest whole number of samples per revolution, the
    exact analysis needs one): the one-revolution loop's ``max |z|``, gain margin and
    phase-error limits (module docstring)."""
    speeds = scenario.profile.speeds_rad_s
    if speeds.size != 1:
        return {}
    T = scenario.sample_period_s
    w = 2 * np.pi / (max(round(2 * np.pi / (float(speeds[0]) * T)), 3) * T)
    s = block.settings
    G = block.schedule.at(w)
    gain = block.gain_at(w)
    loop = machine_sampled_loop(scenario.machine, T)
    if isinstance(block, DynamicHarmonicController):
        return _dynamic_robustness(loop, w, block)
    lwi = loop.with_inputs(w, w, block.actuator_ids, block.sensors)

    def radius(g, est=G):
        return harmonic_poles(loop, w, w, block.actuator_ids, block.sensors, block.harmonics,
                              est, s.law, g, effort_weight=s.effort_weight, leakage=s.leakage,
                              sensor_weights=s.sensor_weights, lwi=lwi).max_abs_z

    def converges(phi, exact):
        est = G * np.exp(1j * np.deg2rad(phi))
        if exact:
            return radius(gain, est) < 1
        A_U, B = update_matrices(est[0], s.law, gain, effort_weight=s.effort_weight,
                                 leakage=s.leakage, sensor_weights=s.sensor_weights)
        return convergence_radius(A_U, B, G[0]) < 1

    r0 = radius(gain)
    margin = stable_gain_limit(radius, gain)
    limits = {}
    for exact in (False, True):
        limit = None
        for phi in np.arange(0.0, 181.0, PHASE_STEP_DEG):
            if not converges(phi, exact):
                break
            limit = float(phi)
        limits[exact] = limit
    return {"speed_hz": w / (2 * np.pi), "max_abs_z_per_rev": r0, "stable": r0 < 1.0,
            "gain_margin": margin, "phase_limit_deg": limits[False],
            "exact_phase_limit_deg": limits[True]}


def _dynamic_robustness(loop, w: float, block) -> dict:
    """The dynamic feed-forward's estimate loop (:func:`.lti.excitation_loop_poles`, which
    assumes the exact model): ``max |z|`` and gain margin; no phase-error limits."""
    s = block.settings
    H = block.schedule.disturbance_at(w)

    def radius(g):
        return excitation_loop_poles(loop, w, w, block.sensors, H, s.law, g,
                                     effort_weight=s.effort_weight, leakage=s.leakage,
                                     sensor_weights=s.sensor_weights).max_abs_z

    r0 = radius(block.gain_at(w))
    return {"speed_hz": w / (2 * np.pi), "max_abs_z_per_rev": r0, "stable": r0 < 1.0,
            "gain_margin": stable_gain_limit(radius, block.gain_at(w)),
            "phase_limit_deg": None, "exact_phase_limit_deg": None}


def model_resonances(scenario, sensors) -> list[tuple[str, float]]:
    """``(sensor, Hz)`` of the resonance peaks of the uncontrolled model over the profile's
    speeds (the scenario's own unbalance)."""
    prof = scenario.profile
    lo = max(prof.min_speed_rad_s, 2 * np.pi * 1.0)
    speeds = np.linspace(lo, prof.max_speed_rad_s, 3000)
    frf = machine_sampled_loop(scenario.machine, scenario.sample_period_s).unbalance_frf(speeds)
    out = []
    for name in sensors:
        resp = sum(frf.responses[f"{name}_{e}"] * a for e, a in scenario.amplitudes.items())
        out += [(name, p["freq_hz"]) for p in model_peaks(speeds / (2 * np.pi), resp)]
    return out


def peak_reductions(result, reference, sensors, resonances) -> dict:
    out = {}
    for name, f in resonances:
        i = sensors.index(name)
        band = np.abs(reference.speed_hz - f) <= PEAK_BAND_HZ
        if band.any():
            out[(name, f)] = float(20 * np.log10(reference.amplitude[band, i].max()
                                                 / result.amplitude[band, i].max()))
    return out


def commission_speeds(resonances, min_speed_hz: float, max_speed_hz: float) -> list[float]:
    """The speeds a run-up's commissioned variant is commissioned at (Hz): the resonances'
    within ``[min_speed_hz, max_speed_hz]``, one of those closer than ``SAME_SPEED``, and the
    top speed."""
    out: list[float] = []
    for f in sorted([f for _, f in resonances if min_speed_hz <= f <= max_speed_hz]
                    + [max_speed_hz]):
        if not out or f > out[-1] * (1 + SAME_SPEED):
            out.append(f)
    return out


def commissioned(cfg: dict, scenario_from_config, source: str, speeds_hz) -> str | None:
    """Commission the variant ``cfg`` at ``speeds_hz`` (None: its constant speed) and put the
    identified table into it; the refusal, or None."""
    from .commission import commission
    result = commission(cfg, source, scenario_from_config, None, speeds_hz)
    if result.refusal is not None:
        return result.refusal
    cfg["harmonic"]["influence"] = {**cfg["harmonic"].get("influence", {}),
                                    "phase_error_deg": 0.0, "magnitude_factor": 1.0,
                                    "table": result.table()}
    return None


def _say(bar: Progress, text: str) -> None:
    if bar.enabled:
        print(text, file=bar.stream, flush=True)


def strategy_study(data: dict, scenario_from_config, source: str = "", progress: bool = False,
                   stream=None) -> tuple[list[StrategyResult], list[str]]:
    """Run every strategy of a scenario config; ``(results, sensor names)``.
    ``scenario_from_config(data, source)`` builds each variant's scenario
    (:func:`rotor_avc.scenario.scenario_from_config`, the composition root above this room);
    ``progress``: one line per strategy started and finished, with the elapsed time and the
    time left (on ``stream``, default stderr)."""
    sensors = list(data["harmonic"].get("sensors", [])) if "harmonic" in data else []
    base = scenario_from_config(data, source) if sensors else None
    configs = variants(data, [o.name for o in base.machine.plant.outputs] if sensors else None)
    if not sensors:
        raise ModelError("harmonic.sensors is empty: nothing to rate the strategies on")
    start_s = float(data["harmonic"].get("start_s", 0.0))
    resonances, speeds = [], None
    if base.profile.speeds_rad_s.size > 1:
        resonances = model_resonances(scenario_from_config(configs["no control"], source), sensors)
        speeds = commission_speeds(resonances, harmonic_section(base.machine.config).min_speed_hz,
                                   base.profile.max_speed_rad_s / (2 * np.pi))
    results, reference = [], None
    bar = Progress(len(configs), enabled=progress, stream=stream, unit="strategies")
    for i, (name, cfg) in enumerate(configs.items()):
        _say(bar, f"{name}: started  {bar.line(i)}")
        started = time.perf_counter()
        if name == COMMISSIONED:
            refusal = commissioned(cfg, scenario_from_config, source, speeds)
            if refusal is not None:
                _say(bar, f"{name}: refused: {refusal}  {bar.line(i + 1)}")
                continue
        sc = scenario_from_config(cfg, source)
        block = sc.harmonic()
        ts = sc.run(harmonic=block, progress=False)
        t, f, amps = revolutions(ts, sensors)
        if reference is None:
            reference = amps
        n = min(len(amps), len(reference))
        with np.errstate(divide="ignore"):
            level = 20 * np.log10(amps[:n] / reference[:n])
        after = t[:n] >= start_s
        ok = np.all(level < -20.0, axis=1) & after
        stays = [i for i in np.flatnonzero(ok) if ok[i:].all()]
        forces = [v for k, v in ts.channels.items() if k.startswith("actuator_")]
        feet = [v for k, v in ts.channels.items()
                if k.startswith("foot_") and k.rsplit("_", 1)[-1].startswith("d")]
        results.append(StrategyResult(
            name, t[:n], f[:n], level, amps[:n], level[-TAIL:].mean(axis=0).tolist(),
            float(t[stays[0]] - start_s) if stays else None,
            float(max((np.abs(v).max() for v in forces), default=0.0)),
            float(max((np.abs(v).max() for v in feet), default=math.nan)),
            robustness(sc, block) if block is not None else {}))
        _say(bar, f"{name}: done in {time.perf_counter() - started:.0f} s  {bar.line(i + 1)}")
    if resonances:
        for r in results:
            r.peak_reduction_db = peak_reductions(r, results[0], sensors, resonances)
    return results, sensors
