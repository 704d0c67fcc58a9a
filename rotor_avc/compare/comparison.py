"""Offline comparison of a recorded run with the analytical models (DESIGN.md section 5).

Everything comes from the bag (:func:`rotor_avc.compare.recorded_run.read_run`): the scenario is
rebuilt from the bag's configuration, so both models use the simulator's plant, controllers,
sample rate, unbalance and damping rule (``w_F = max(Omega, floor)`` updated with the speed, or
frozen at ``whirl_rad_s``).

**1x response.** Order tracking on the recorded shaft angle
(:mod:`rotor_avc.analysis.order_tracking`): one phasor per constant-speed dwell over the whole
revolutions of its second half (after the transient), or, for a run without dwells, per window
of :data:`RUNUP_REVOLUTIONS` revolutions (quasi-stationary). Channels: the plant's outputs
(bearing-housing and foundation velocities), the foot accelerations and the controllers' forces.
With several excitations the measured 1x is their superposition, compared with
``sum_j G_j(Omega) u_j`` (the run's complex amplitudes ``u_j``); with one, both are divided by
it (response per unit unbalance, as the papers plot). A run with the adaptive harmonic
controller (channels ``harmonic_<id>_f<axis>``, its forces added to the feedback forces) is
compared with ``sum_j G_j u_j + sum_a T_a(Omega) F_a``: its forces' measured 1x ``F_a`` drive
the closed-loop transfer ``T_a`` from actuator ``a`` (:mod:`rotor_avc.analysis.transfer`, the
same force path as a test force); the forces themselves are inputs, reported, not rated.
Models at the measured speeds: the continuous loop
(:func:`rotor_avc.closed_loop.frf.unbalance_frf`, Werner 2021 eqs. 41-42) and the sampled loop
(:meth:`rotor_avc.analysis.sampled_loop.SampledLoop.unbalance_frf`, what a lockstep run
reproduces), the foot accelerations added as outputs of the plant.

**Broadband FRFs.** When the run had a test force (``simulation.test_signal``), H1, H2 and
coherence (:func:`rotor_avc.analysis.frf_estimate.estimate_frf`: Hann window, 50 % overlap,
power-of-two segments giving about 16 averages) from the force to the foot accelerations and
bearing-housing velocities, per dwell of at least :data:`MIN_BROADBAND_SAMPLES` samples, against
:mod:`rotor_avc.analysis.transfer` at the dwell's speed with ``w_F`` frozen as the run had it.

**Checks** against the sampled-loop model (the acceptance of a recording: a lockstep bag agrees within
0.5 dB and 5 degrees away from resonances and 2 dB and 15 degrees at them, resonance frequencies
within 1 %), each the worst case over channels and speeds. The complex response is rated, so a
sign error (180 degrees) or a delay fails even where the magnitude agrees:

* 1x magnitude error away from resonances (0.5 dB) and at them (2 dB);
* 1x phase error ``angle(measured / model)`` away from resonances (5 deg) and at them (15 deg);
* the RMS over speed of a channel's 1x error in dB (0.5 dB);
* resonance frequency (1 %) and peak level (2 dB);
* per broadband dwell, over the bins of the test band with coherence >= :data:`MIN_COHERENCE`,
  the RMS of H1's error in dB (0.5 dB) and in phase (5 deg);
* dead channels: a recorded channel with no response (1x more than :data:`DEAD_DB` below the model
  at every checked point, or an H1 of zero over the test band) where the model has one (0).

Why these tolerances: a lockstep bag of Werner 2021 case 3 (5 kHz) meets the sampled loop within
0.07 dB and 0.5 degrees (1x) and 0.09 dB / 0.9 degrees RMS (broadband, 3 s at 20 Hz); the
phase tolerances match the magnitude ones (0.5 dB is a 6 % vector error, 3.4 degrees; at a
resonance a 1 % frequency error moves the phase by about 0.01 / zeta rad, 10 degrees at 5 %
damping), and they are tight enough for a commissioning check: a sign error (180 degrees), a
swapped channel or a delay of one sample at 5 kHz above 70 Hz (5 degrees) fails. A real
machine's sensor and amplifier phase lag must be in the model (or the run's configuration)
before its bag can pass.

The continuous model's values are reported beside them without a verdict, and so are the 1x
checks of a run with a test force (its response at the rotational frequency is noise to the
order tracking). Points more than :data:`FLOOR_DB` below a channel's model peak (notches,
channels that barely respond) are not checked.

**No verdict.** A comparison in which no check could be rated -- every 1x point unsettled or
below the floor, every signal zero, the channels the models describe missing from the bag, no
unbalance and no test force -- is neither PASS nor FAIL: :attr:`Comparison.verdict` is
``NO VERDICT`` with the reason (exit status :data:`EXIT_NO_VERDICT` of ``rotor-avc compare``).
A dead channel fails the comparison when anything else is rated, and is the reason of a no
verdict when nothing is.
Resonances (:mod:`rotor_avc.analysis.resonance_peaks`) are the model's peaks of at least 3 dB
prominence inside the measured speeds; a point lies "at" one within its half-power (-3 dB) band,
and its measured frequency and level come from the parabola through the highest measured point
of that band and its neighbours, when they resolve it.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from dataclasses import dataclass

import numpy as np

from ..control.block import build_digital_controllers
from ..errors import ModelError
from ..models.plant import Output
from ..analysis import order_tracking
from ..closed_loop.loop import ClosedLoop
from ..analysis.frf_estimate import (MIN_AVERAGES, MIN_SEGMENT, FrfEstimate, contiguous_runs,
                                     estimate_frf, estimate_frf_gapped, gapped_segment_length)
from ..analysis.poles import closed_loop_poles
from .bag_source import BagSource
from .recorded_run import MAX_DWELL_SAMPLES, read_run
from .run_source import RunSource
from ..analysis.sampled_loop import SampledLoop
from ..analysis.loop_responses import force_response, unbalance_response
from .checks import (DEAD_DB, HARMONIC, MIN_BROADBAND_SAMPLES, MIN_COHERENCE, Broadband, Check, OneX,
                     _broadband_checks, _db, _dead_channels, _no_verdict_reason, _one_x_checks,
                     _one_x_metrics)

RUNUP_REVOLUTIONS = 8
DENSE_POINTS = {"continuous": 1500, "sampled": 400}


@dataclass
class Comparison:
    run: RunSource
    one_x: OneX | None
    broadband: list[Broadband]
    poles: list[dict]
    checks: list[Check]
    reference_metrics: list[Check]
    notes: list[str]
    #: why nothing could be rated (empty when something was)
    no_verdict_reason: str = ""

    @property
    def passed(self) -> bool:
        done = [c.passed for c in self.checks if c.passed is not None]
        return bool(done) and all(done)

    @property
    def verdict(self) -> str:
        """``PASS``, ``FAIL`` or ``NO VERDICT`` (no check rated)."""
        if not any(c.passed is not None for c in self.checks):
            return "NO VERDICT"
        return "PASS" if self.passed else "FAIL"


# -- models ---------------------------------------------------------------------------------------
def _with_foot_accelerations(plant):
    """The plant with ``foot_<id>_a<axis>`` (the controllers' sensor rows) added as outputs."""
    have = {o.name for o in plant.outputs}
    extra = tuple(Output(f"foot_{a.id}_a{a.axis}", a.sensor_row, 2, "m/s^2")
                  for a in plant.actuators if f"foot_{a.id}_a{a.axis}" not in have)
    return dataclasses.replace(plant, outputs=plant.outputs + extra)


def model_loops(machine, T: float, kinds=("continuous", "sampled")) -> dict:
    """The machine's continuous and sampled (period ``T``) closed loops, the foot accelerations
    as outputs."""
    plant = _with_foot_accelerations(machine.plant)
    build = {"continuous": lambda: ClosedLoop(plant, machine.controllers),
             "sampled": lambda: SampledLoop.from_blocks(
                 plant, build_digital_controllers(machine, T), T)}
    return {kind: build[kind]() for kind in kinds}


def unbalance_models(scenario, loops, speeds, u_ref, channels) -> dict[str, dict[str, np.ndarray]]:
    """Superposed 1x response ``sum_j G_j u_j / u_ref`` of each channel, per model."""
    w_F = scenario.damping.w_F(scenario.machine.plant, speeds)
    amps = {k: v for k, v in scenario.amplitudes.items() if v != 0}
    out = {}
    for name, loop in loops.items():
        frf = unbalance_response(loop, speeds, list(amps), w_F)
        out[name] = {ch: sum(frf.responses[f"{ch}_{e}"] * u for e, u in amps.items()) / u_ref
                     for ch in channels}
    return out


# -- 1x -------------------------------------------------------------------------------------------
def one_x_channels(run: RunSource) -> list[str]:
    """The responses the models describe, then the harmonic controller's forces (inputs)."""
    plant = run.machine.plant
    names = [o.name for o in plant.outputs] + [f"foot_{a.id}_a{a.axis}" for a in plant.actuators]
    names += [f"actuator_{a.id}_f{a.axis}" for a in plant.actuators]
    names += [f"{HARMONIC}{a.id}_f{a.axis}" for a in plant.actuators]
    return [n for n in names if n in run.channel_names]


def _harmonic_models(run, loops, speeds, inputs: dict, channels) -> dict:
    """``sum_a T_a(Omega) F_a`` per model and channel: the response to the harmonic controller's
    forces (``inputs``: channel -> measured 1x per speed, per unit ``u_ref``)."""
    w_F = np.broadcast_to(run.scenario.damping.w_F(run.machine.plant, speeds), speeds.shape)
    out = {}
    for name, loop in loops.items():
        out[name] = {ch: np.zeros(speeds.shape, complex) for ch in channels}
        for k, speed in enumerate(speeds):
            for ch, force in inputs.items():
                act = ch[len(HARMONIC):].rsplit("_f", 1)[0]
                frf = force_response(loop, float(speed), speed / (2 * np.pi), act, channels,
                                     float(w_F[k]))
                for c in channels:
                    out[name][c][k] += frf.responses[c][0] * force[k]
    return out


def measured_one_x(run: RunSource, u_ref: complex = 1.0):
    """Order tracking of :func:`one_x_channels`: ``(OrderTrack, method, settings)``."""
    names = one_x_channels(run)
    if run.tracking is not None:
        return run.tracking(names, u_ref, RUNUP_REVOLUTIONS)
    tracks = []
    for d in run.dwells():                     # from the start of each dwell's second half
        cut = slice(d.settle_start, None)
        try:
            tracks.append(order_tracking.stepped_speed(
                d.time_s[cut], d.angle_rad[cut], d.speed_rad_s[cut],
                {n: d.channels[n][cut] for n in names}, u_ref, settle_fraction=0.0))
        except ModelError:
            continue
    if tracks:
        return order_tracking.concatenate(tracks), "stepped-speed dwells", {
            "settle_fraction": 0.5, "min_revolutions": 4,
            "window": "rectangular, whole revolutions",
            "max_samples_per_dwell": MAX_DWELL_SAMPLES}
    track = order_tracking.run_up_stream(run.blocks(), names, u_ref,
                                         revolutions=RUNUP_REVOLUTIONS)
    return track, "run-up windows (quasi-stationary)", {
        "revolutions_per_window": RUNUP_REVOLUTIONS, "window": "rectangular, whole revolutions"}


def _dense_speeds(run, speeds, model) -> np.ndarray:
    """The measured range widened by 10 % of its top speed on both sides (a peak's prominence
    needs its flanks), below the Nyquist frequency."""
    lo, hi = float(speeds.min()), float(speeds.max())
    pad = max(0.05 * (hi - lo), 0.1 * hi)
    top = min(hi + pad, 0.98 * np.pi / run.sample_period_s)
    return np.linspace(max(lo - pad, 1e-3 * hi), top, DENSE_POINTS[model])


def compare_one_x(run: RunSource, loops: dict) -> OneX | None:
    amps = {k: v for k, v in run.scenario.amplitudes.items() if v != 0}
    if not amps:
        return None
    u_ref = next(iter(amps.values())) if len(amps) == 1 else 1.0
    plant = run.machine.plant
    units_exc = {e.name: e.unit for e in plant.excitations}
    track, method, settings = measured_one_x(run, u_ref)
    channels = list(track.phasors)
    per = f"/({units_exc[next(iter(amps))]})" if len(amps) == 1 else ""
    reference = (f"per unit {next(iter(amps))} unbalance ({units_exc[next(iter(amps))]})"
                 if len(amps) == 1 else "response to the run's superposed unbalance "
                 + ", ".join(f"{k} = {abs(v):g} {units_exc[k]} at {np.degrees(np.angle(v)):.1f} deg"
                             for k, v in amps.items()))
    unit = {o.name: o.unit for o in _with_foot_accelerations(plant).outputs}
    units = {ch: unit.get(ch, "N") + per for ch in channels}
    order = np.argsort(track.speed_rad_s)
    speeds = track.speed_rad_s[order]
    measured = {ch: track.phasors[ch][order] for ch in channels}
    drift = ({ch: track.drift[ch][order] for ch in channels} if method == "stepped-speed dwells"
             else {})
    sigma = {ch: track.sigma[ch][order] for ch in channels if ch in track.sigma}
    inputs = {ch: measured[ch] for ch in channels if ch.startswith(HARMONIC)}
    outputs = [ch for ch in channels if ch not in inputs]
    model = unbalance_models(run.scenario, loops, speeds, u_ref, outputs)
    dense_speeds = {m: _dense_speeds(run, speeds, m) for m in loops}
    dense = {m: unbalance_models(run.scenario, {m: loops[m]}, dense_speeds[m], u_ref, outputs)[m]
             for m in loops}
    if inputs:
        driven = _harmonic_models(run, loops, speeds, inputs, outputs)
        for m in loops:
            for ch in outputs:
                model[m][ch] = model[m][ch] + driven[m][ch]
            model[m].update(inputs)
            dense[m].update({ch: np.interp(dense_speeds[m], speeds, v.real)
                             + 1j * np.interp(dense_speeds[m], speeds, v.imag)
                             for ch, v in inputs.items()})
    one = OneX(method, settings, reference, units, speeds, measured, model, dense_speeds, dense,
               drift=drift, sigma=sigma)
    _one_x_metrics(one)
    return one


def broadband_outputs(run: RunSource) -> list[str]:
    plant = run.machine.plant
    names = [f"foot_{a.id}_a{a.axis}" for a in plant.actuators]
    names += [o.name for o in plant.outputs if o.name.startswith("bearing_")]
    return [n for n in names if n in run.channel_names]


def measured_broadband(run: RunSource) -> list[tuple[float, FrfEstimate]]:
    """``(speed_rad_s, H1/H2 estimate)`` per constant-speed dwell long enough, from the test force
    to :func:`broadband_outputs`. A dwell with gaps (a recording's dropped samples) is averaged
    over the Welch segments between its gaps (:func:`estimate_frf_gapped`); a dwell whose gaps
    leave too little for that is left out with the reason in the run's notes."""
    if not run.has_test_force:
        return []
    outputs = broadband_outputs(run)
    T = run.sample_period_s
    out = []
    for d in run.dwells():
        t = d.time_s
        if t.size < MIN_BROADBAND_SAMPLES:
            continue
        Y = np.column_stack([d.channels[n] for n in outputs])
        runs = contiguous_runs(t, T)
        if len(runs) == 1:
            out.append((float(d.speed_rad_s[0]), estimate_frf(d.test_force, Y, 1 / T)))
            continue
        lengths = [b - a for a, b in runs]
        nperseg = gapped_segment_length(lengths)
        if nperseg is None:
            run.notes.append(
                f"broadband dwell at {d.speed_rad_s[0] / (2 * np.pi):.4g} Hz ({t[0]:.3f}-"
                f"{t[-1]:.3f} s) left out: its {len(runs) - 1} gaps leave contiguous runs of at "
                f"most {max(lengths)} samples, too short for {MIN_AVERAGES} Welch segments of "
                f"{MIN_SEGMENT}")
            continue
        est = estimate_frf_gapped(d.test_force, Y, 1 / T, runs, nperseg)
        run.notes.append(
            f"broadband dwell at {d.speed_rad_s[0] / (2 * np.pi):.4g} Hz: {len(runs) - 1} gaps; "
            f"averaged over the {est.averages} Welch segments of {nperseg} samples that fit "
            "between them")
        out.append((float(d.speed_rad_s[0]), est))
    if run.interpolation is not None and out:
        out = [(speed, _deinterpolated(run, est, outputs)) for speed, est in out]
    return out


def _deinterpolated(run: RunSource, est: FrfEstimate, outputs) -> FrfEstimate:
    """H1 and H2 divided by the resampling's gain on them (``run.interpolation``), noted."""
    gain = run.interpolation(outputs, est.freq_hz)
    worst = np.abs(20 * np.log10(np.abs(gain)))
    k, i = np.unravel_index(np.argmax(worst), worst.shape)
    run.notes.append(f"broadband: H1 and H2 divided by the gain of the resampling (linear "
                     "interpolation of each output over the test force's, from their stamps "
                     f"onto the grid): at most {worst[k, i]:.2g} dB ({outputs[i]} at "
                     f"{est.freq_hz[k]:.4g} Hz)")
    return dataclasses.replace(est, h1=est.h1 / gain, h2=est.h2 / gain)


def compare_broadband(run: RunSource, loops: dict) -> list[Broadband]:
    test = run.scenario.test_force
    results = []
    for speed, est in measured_broadband(run):
        outputs = broadband_outputs(run)
        lo, hi = test.band_hz
        sel = (est.freq_hz >= max(lo, est.resolution_hz)) & (est.freq_hz <= hi)
        f = est.freq_hz[sel]
        w_F = float(run.scenario.damping.w_F(run.machine.plant, np.array(speed)))
        models = {m: force_response(loop, speed, f, test.actuator, outputs, w_F)
                  for m, loop in loops.items()}
        bb = Broadband(speed, w_F, est, outputs, (lo, hi), models)
        for m, model in models.items():
            bb.channels[m] = {}
            for i, name in enumerate(outputs):
                h1, coh = est.h1[sel, i], est.coherence[sel, i]
                ok = coh >= MIN_COHERENCE
                resp = model.responses[name]
                dead = bool(np.any(resp)) and bool(np.all(np.abs(h1) <= np.abs(resp)
                                                             * 10 ** (-DEAD_DB / 20)))
                with np.errstate(divide="ignore", invalid="ignore"):
                    err = _db(h1) - _db(model.responses[name])
                    phase = np.degrees(np.angle(h1 / model.responses[name]))
                bb.channels[m][name] = {
                    "coherent_bins": int(ok.sum()), "bins": int(ok.size), "dead": dead,
                    "band_rms_db": float(np.sqrt(np.mean(err[ok] ** 2))) if ok.any() else None,
                    "max_error_db": float(np.abs(err[ok]).max()) if ok.any() else None,
                    "phase_rms_deg": float(np.sqrt(np.mean(phase[ok] ** 2))) if ok.any() else None}
        results.append(bb)
    return results


def run_poles(run: RunSource, speeds_rad_s) -> list[dict]:
    """Continuous and sampled-loop poles (``s``, 1/s) at each speed with the run's ``w_F``."""
    loops = model_loops(run.machine, run.sample_period_s)
    out = []
    for speed in speeds_rad_s:
        w_F = float(run.scenario.damping.w_F(run.machine.plant, np.array(speed)))
        samp = loops["sampled"].poles(float(speed), w_F)
        out.append({"speed_hz": float(speed / (2 * np.pi)), "w_F": w_F,
                    "continuous": closed_loop_poles(loops["continuous"], float(speed), w_F),
                    "sampled": samp.s[np.isfinite(samp.s)], "sampled_max_abs_z": samp.max_abs_z})
    return out


# -- all of it ------------------------------------------------------------------------------------
def compare_run(run: RunSource) -> Comparison:
    """The comparison of a recorded run (see the module docstring): ``run`` any
    :class:`~rotor_avc.compare.run_source.RunSource`."""
    if run.scenario.use_balancer:
        raise ModelError(f"{run.path}: the run had an active balancer, whose changing correction "
                         "the fixed-unbalance models do not describe; compare a run without it")
    loops = model_loops(run.machine, run.sample_period_s)
    one = compare_one_x(run, loops) if one_x_channels(run) else None
    bbs = compare_broadband(run, loops)
    notes = list(run.notes)                   # after the passes over the run (a streamed bag)
    if not one_x_channels(run):
        notes.append("no channel the models describe (plant outputs, foot accelerations, "
                     "actuator forces) is in the recording: no 1x response to compare")
    elif one is None:
        notes.append("the run has no unbalance: no 1x response to compare")
    elif any(ch.startswith(HARMONIC) for ch in one.measured):
        notes.append("the harmonic controller's forces (harmonic/forces) drive the models with "
                     "their measured 1x; no resonance check (the models over speed are the "
                     "feedback loop alone)")
    if run.has_test_force and not bbs:
        notes.append(f"the run's test force has no constant-speed dwell of "
                     f"{MIN_BROADBAND_SAMPLES} samples: no broadband FRF")
    elif run.has_test_force:
        notes.append(f"test force: {run.test_source}")
    rate_one_x = not run.has_test_force
    if one is not None and not rate_one_x:
        notes.append("1x checks not rated: the broadband test force's response at the rotational "
                     "frequency adds to the 1x phasors (compare a run without a test force)")
    checks, reference = [], []
    for m, target in (("sampled", checks), ("continuous", reference)):
        one_checks = _one_x_checks(one, m) if one else []
        bb_checks = _broadband_checks(bbs, m)
        if m == "continuous" or not rate_one_x:
            for c in one_checks + (bb_checks if m == "continuous" else []):
                c.passed = None
        target += one_checks + bb_checks
    dead = _dead_channels(one, bbs, "sampled")
    reason = ""
    if not any(c.passed is not None for c in checks):
        reason = _no_verdict_reason(run, one, bbs, dead)
        notes.append(f"no verdict: {reason}")
    elif dead is not None:
        checks.append(dead)
    speeds = (np.unique(one.speed_rad_s) if one else np.array([bb.speed_rad_s for bb in bbs]))
    if speeds.size > 6:
        speeds = speeds[np.linspace(0, speeds.size - 1, 6).round().astype(int)]
    poles = run_poles(run, speeds) if speeds.size else []
    return Comparison(run, one, bbs, poles, checks, reference, notes, reason)


def compare_bag(path, in_memory: bool = False, machine=None, progress=None) -> Comparison:
    """Compare a bag, a .mcap file streamed (:class:`~rotor_avc.compare.bag_source.BagSource`)
    or, with ``in_memory`` and for a rosbag2 directory, read into memory first
    (:func:`read_run`); with ``machine``, the models are that machine's in the recorded scenario
    (sample rate, speeds, unbalance, damping rule and test force as the run had them).
    ``progress``: the streamed passes' ``(seconds read, seconds)`` (None: quiet)."""
    streamed = not in_memory and not Path(path).is_dir()
    run = BagSource(path, progress) if streamed else read_run(path)
    if machine is not None:
        run.scenario = dataclasses.replace(run.scenario, machine=machine)
        run.notes.append(f"models: the machine of {machine.config.source}, in the recorded "
                         "scenario")
    return compare_run(run)
