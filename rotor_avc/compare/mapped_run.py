"""A recording of any machine as a :class:`~rotor_avc.compare.recorded_run.RecordedRun`: the
scenario from a machine configuration, the signals from a bag through a mapping file
(:mod:`.recording_map`), resampled onto one uniform grid (:mod:`rotor_avc.analysis.resampling`).

* the scenario: ``--config``, a machine configuration; a ``simulation:`` section is optional
  (:mod:`.recording_scenario`): the speed profile, duration and initial state come from the
  recording, the sample rate from the configuration's controllers or else the fastest channel,
  the unbalance from the mapping (or ``simulation.unbalance``); what was assumed is
  ``RecordedRun.assumptions`` (printed, and in ``metrics.json``);
* the grid: that sample period over the time every channel covers, aligned to the stamps of
  the fastest channel (its size checked against the memory limit before it is built); every
  channel linearly interpolated onto it, grid points in a gap of more than
  ``resample.max_missing_samples`` missing samples of any channel excluded;
* per channel, samples that are not finite or overflow are excluded and counted (like dropped
  samples), and a step of the sensor clock against the recorder's is refused, naming the channel,
  the time and the step (``rotor_avc.analysis.resampling.clock_steps``);
* the shaft: a pulse topic (``shaft_from_pulses``: revolutions counted from the intervals,
  duplicate pulses dropped), an encoder angle or a JointState position (revolutions counted
  across gaps, ``count_revolutions``; the speed and its dwells from its whole-revolution
  crossings); the angle is continuous, so order tracking over samples kept on both sides of a
  gap keeps every revolution;
* ``notes``: what was found per channel (rate, jitter, dropped samples, longest gap, excluded
  values), the shaft (pulses, missing and duplicate pulses, dwells), the resampling method and
  its loss, and the 1x points whose
  noise (:mod:`rotor_avc.analysis.one_x_noise`, over the dwell's second half: a short dwell has
  few samples) is too large for a verdict. :func:`band_notes` adds per output the coherence of
  the broadband estimate and the fraction of H1 inside its +-2 sigma band around the
  sampled-loop model.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis import resampling as R
from ..analysis.frf_estimate import h1_random_error
from ..analysis.order_tracking import ShaftAngle
from ..analysis.window_tracking import dwell_windows, revolution_windows, track_windows
from ..analysis.one_x_noise import decidable
from ..bag import BagError
from ..bag.rosbag2 import open_bag
from ..config import find_config, load_yaml
from ..errors import ConfigError, ModelError, did_you_mean
from ..machine import machine_from_config
from ..resources import FLOAT_BYTES, check_memory
from .checks import MIN_COHERENCE, TOL_OFF_RESONANCE_DB
from .comparison import Comparison
from .recorded_run import RecordedRun
from .recording_map import DEFAULT_ANGLE_FIELD, read_map
from .recording_scenario import describe_assumptions, recording_scenario

#: the test force's name among the resampled channels
TEST_FORCE = "test force"


def model_signals(plant) -> list[str]:
    """Every model signal a mapping may name: outputs, foot signals, actuator forces."""
    return ([o.name for o in plant.outputs] + [f"foot_{a.id}_a{a.axis}" for a in plant.actuators]
            + [f"actuator_{a.id}_f{a.axis}" for a in plant.actuators])


def _stamps_ns(series, stamp: str, where: str, source: str) -> np.ndarray:
    if stamp == "log":
        return series.time_ns.astype(np.int64)
    for prefix in ("header.stamp", "stamp"):
        if f"{prefix}.sec" in series.fields:
            return (series.fields[f"{prefix}.sec"].astype(np.int64) * 1_000_000_000
                    + series.fields[f"{prefix}.nanosec"].astype(np.int64))
    raise ConfigError(f"{where}.stamp", f"topic {series.topic} has no header stamp",
                      fix="set `stamp: log` to use the bag's log times", source=source)


def clock_error(topic: str, where: str, source: str, step, count: int,
                start_s: float) -> ConfigError:
    """The refusal of a sensor clock that steps against the recorder's (module docstring):
    ``step`` the first ``(log time s, step s)``, ``count`` the steps found."""
    log_s, step_s = step
    return ConfigError(f"{where}.stamp", f"the header stamps of {topic} step by {step_s:+.6g} s "
                       f"against the bag's log time at {log_s - start_s:.6g} s into the "
                       f"recording ({count} clock step(s): NTP, a clock reset); samples on "
                       "both sides cannot share one time base",
                       fix=f"set `stamp: log` for this channel, or cut the recording at "
                           f"{log_s - start_s:.6g} s", source=source)


def _check_clock(series, stamps_ns, where: str, source: str) -> None:
    steps = R.clock_steps(stamps_ns * 1e-9, series.time_ns * 1e-9)
    if steps:
        raise clock_error(series.topic, where, source, steps[0], len(steps),
                          float(series.time_ns.min()) * 1e-9)


def field_values(series, sig, where: str, source: str) -> tuple[np.ndarray, np.ndarray]:
    """(stamps ns, values as recorded) of one mapped field of a topic's series."""
    try:
        values = np.asarray(series[sig.field], dtype=float)
    except BagError as exc:
        raise ConfigError(f"{where}.field", f"{sig.field!r} is not a numeric field of "
                          f"{sig.topic}", fix=exc.fix, source=source) from None
    if values.ndim != 1:
        raise ConfigError(f"{where}.field", f"{sig.field!r} of {sig.topic} is an array",
                          fix=f"pick one element, e.g. {sig.field}[0]", source=source)
    return _stamps_ns(series, sig.stamp, where, source), values


def require_topic(bag, topic: str, where: str, source: str) -> None:
    if topic not in bag.topics:
        raise ConfigError(f"{where}.topic", f"no topic {topic} in {bag.path}"
                          + did_you_mean(topic, bag.topics),
                          fix="use one of " + ", ".join(sorted(bag.topics)), source=source)


def too_few(sig, where: str, source: str, finite: int, total: int) -> ConfigError:
    return ConfigError(f"{where}.field", f"{sig.field!r} of {sig.topic} has {finite} finite "
                       f"values of {total}", fix="map a field that the sensor fills",
                       source=source)


def _read_field(bag, sig, where: str, source: str):
    """(stamps ns, SI values, samples excluded as non-finite or overflowing) of one mapped
    field."""
    require_topic(bag, sig.topic, where, source)
    series = bag.series(sig.topic)
    stamps, values = field_values(series, sig, where, source)
    if sig.stamp != "log":
        _check_clock(series, stamps, where, source)
    ok, excluded = R.usable_samples(values)
    if ok.sum() < 3:
        raise too_few(sig, where, source, int(ok.sum()), ok.size)
    return stamps[ok], sig.sign * sig.scale * values[ok], excluded


def read_shaft(bag, shaft, source: str) -> tuple[np.ndarray, np.ndarray | None]:
    """(stamps ns, angle rad or None for pulses)."""
    require_topic(bag, shaft.topic, "shaft", source)
    series = bag.series(shaft.topic)
    stamps = _stamps_ns(series, shaft.stamp, "shaft", source)
    if shaft.stamp != "log":
        _check_clock(series, stamps, "shaft", source)
    if shaft.source == "pulse":
        return stamps, None
    name = shaft.field or DEFAULT_ANGLE_FIELD[shaft.source]
    try:
        angle = np.asarray(series[name], dtype=float)
    except BagError as exc:
        raise ConfigError("shaft.field", f"{name!r} is not a field of {shaft.topic}",
                          fix=exc.fix, source=source) from None
    ok, _ = R.usable_samples(angle)
    return stamps[ok], angle[ok]


def load_machine_and_map(config, map_path):
    """``(config path, config data, machine, map, channel name -> SignalMap)``."""
    config_path = find_config(config)
    data = load_yaml(config_path)
    machine = machine_from_config(data, str(config_path))
    rmap, signals = read_map(map_path, model_signals(machine.plant))
    return config_path, data, machine, rmap, signals


def read_mapped_run(bag_path, config, map_path, loaded=None) -> RecordedRun:
    """The recording at ``bag_path`` (.mcap or rosbag2 directory) as a RecordedRun of the
    machine ``config`` through the mapping ``map_path`` (see the module docstring);
    ``loaded``: what :func:`load_machine_and_map` gave for them, if read already."""
    config_path, data, machine, rmap, signals = loaded or load_machine_and_map(config, map_path)
    source = str(map_path)
    mapped = {name: (sig, f"channels.{name}") for name, sig in signals.items()}
    if rmap.test_force is not None:
        mapped[TEST_FORCE] = (rmap.test_force, "test_force")
    with open_bag(bag_path, require_messages=True, integrity=True) as bag:
        raw = {name: _read_field(bag, sig, where, source) for name, (sig, where) in mapped.items()}
        shaft_ns, shaft_angle = read_shaft(bag, rmap.shaft, source)
    origin_ns = min(min(int(t.min()) for t, _, _ in raw.values()), int(shaft_ns.min()))
    notes, clean = [], {}
    for name, (stamps, values, excluded) in raw.items():
        t, y, fixed = R.clean_stamps((stamps - origin_ns) * 1e-9, values)
        quality = R.stamp_quality(f"{name} ({mapped[name][0].topic})", t, fixed)
        clean[name] = (t, y, quality)
        notes.append(quality.describe() + (f", {excluded} values not finite or beyond "
                                           f"{R.OVERFLOW:g} excluded" if excluded else ""))
    shaft_s = (shaft_ns - origin_ns) * 1e-9
    scenario, assumptions = recording_scenario(
        data, str(config_path), rmap, machine, _recorded_rates(clean),
        _span_s(clean), top_speed_hz(rmap.shaft, shaft_s, shaft_angle))
    if rmap.test_force is not None and scenario.test_force is None:
        raise ConfigError("test_force", "the configuration has no simulation.test_signal (its "
                          "actuator and band)", fix=f"add simulation.test_signal to "
                          f"{config_path} or drop test_force", source=source)
    grid = _grid(clean, scenario.sample_period_s)
    valid = np.ones(grid.size, bool)
    channels = {}
    for name, (t, y, _) in clean.items():
        channels[name], ok = R.resample(t, y, grid, rmap.resample.max_missing_samples)
        valid &= ok
    shaft, shaft_note = shaft_of(rmap.shaft, shaft_s, shaft_angle, grid)
    valid &= shaft.valid
    top_hz = float(shaft.speed_rad_s.max() / (2 * np.pi))
    if TEST_FORCE in clean:
        top_hz = max(top_hz, scenario.test_force.band_hz[1])
    losses = [f"{name} {R.interpolation_loss_db(t, grid, top_hz):.2g} dB"
              for name, (t, _, _) in clean.items()]
    notes.append(shaft_note)
    notes.append(f"resampling: linear interpolation onto the "
                 f"{1 / scenario.sample_period_s:g} Hz grid ({assumptions['sample_rate_hz']['from']}"
                 f") aligned to the fastest channel's stamps; {int((~valid).sum())} of {grid.size} "
                 f"grid points excluded (in gaps of more than {rmap.resample.max_missing_samples} "
                 f"missing samples, outside a channel's record); interpolation loss at "
                 f"{top_hz:.4g} Hz: " + ", ".join(losses))
    notes.append("assumed: " + describe_assumptions(assumptions))
    keep = np.flatnonzero(valid)
    if keep.size < 3:
        raise BagError(bag_path, "fewer than 3 grid points are covered by every mapped channel "
                       "and the shaft", fix="check the mapping's topics and stamps")
    test = channels.pop(TEST_FORCE, None)
    channels = {n: v[keep] for n, v in channels.items()}
    run = RecordedRun(Path(bag_path), scenario, data, "", grid[keep],
                      shaft.angle_rad[keep], shaft.speed_rad_s[keep], channels,
                      None if test is None else test[keep],
                      "" if test is None else f"recorded ({rmap.test_force.topic})", notes,
                      assumptions)
    run.tracking = ShaftTracking(run, shaft, {n: (t, y) for n, (t, y, _) in clean.items()
                                              if n != TEST_FORCE})
    if TEST_FORCE in clean:
        run.interpolation = FrfInterpolation({n: t for n, (t, _, _) in clean.items()},
                                             grid[keep])
    return run


class FrfInterpolation:
    """The resampling's gain on an FRF from the test force to each output: the ratio of their
    linear interpolations' gains onto the grid (rotor_avc.analysis.resampling)."""

    def __init__(self, stamps: dict, grid):
        self.stamps, self.grid = stamps, grid

    def __call__(self, outputs, freq_hz) -> np.ndarray:
        force = R.interpolation_gain(self.stamps[TEST_FORCE], self.grid, freq_hz)
        return np.column_stack([R.interpolation_gain(self.stamps[n], self.grid, freq_hz) / force
                                for n in outputs])


class ShaftTracking:
    """The 1x order tracking of a mapped recording: windows of whole revolutions defined by the
    shaft (:func:`shaft_windows`), each channel fitted over its own samples at their own stamps
    (no resampling, no grid points lost to another channel's gap;
    rotor_avc.analysis.window_tracking). Windows left out for want of samples, and the 1x
    points too noisy for a verdict (:func:`noise_notes`), are added to the run's notes."""

    def __init__(self, run: RecordedRun, shaft: R.Shaft, raw: dict):
        self.run, self.shaft, self.raw = run, shaft, raw

    def __call__(self, names, u_ref, runup_revolutions: int):
        channels = {n: self.raw[n] for n in names}
        windows, gapped, method, settings = shaft_windows(self.shaft, runup_revolutions)
        if not self.shaft.dwells:
            windows, gapped = within_channels(
                windows, gapped, max(t[0] for t, _ in channels.values()),
                min(t[-1] for t, _ in channels.values()))
        track, notes = track_windows(self.shaft.knots, windows, channels, u_ref)
        self.run.notes += gap_notes(gapped) + notes + noise_notes(track, method)
        settings["windows_left_out"] = len(gapped) + len(notes)
        return track, method, settings


#: how each channel is fitted in a shaft window
_WINDOW = "whole revolutions from the shaft, each channel at its own stamps"


def shaft_windows(shaft: R.Shaft, runup_revolutions: int):
    """``(windows, gapped, method, settings)``: the second halves of the shaft's dwells, or
    (a run-up) consecutive windows of ``runup_revolutions`` over the shaft's record that
    overlap no tacho gap of more than two revolutions (``gapped``: the others, ``(t0, t1,
    pulses missed)``)."""
    if shaft.dwells:
        return (dwell_windows(shaft.knots, [(a, b) for a, b, _ in shaft.dwells]), [],
                "stepped-speed dwells", {"settle_fraction": 0.5, "min_revolutions": 4,
                                         "window": _WINDOW})
    kept, gapped = [], []
    knots = shaft.knots.knots_s
    for t0, t1, n in revolution_windows(shaft.knots, knots[0], knots[-1], runup_revolutions):
        # where the tacho missed pulses the speed changes unseen: the angle interpolated
        # across the gap is not the shaft's
        missed = [g[2] - 1 for g in shaft.pulse_gaps if g[0] < t1 and g[1] > t0]
        if missed:
            gapped.append((t0, t1, max(missed)))
        else:
            kept.append((t0, t1, n))
    return kept, gapped, "run-up windows (quasi-stationary)", {
        "revolutions_per_window": runup_revolutions, "window": _WINDOW}


def within_channels(windows, gapped, start_s: float, stop_s: float):
    """The run-up windows (and gapped ones) inside the time every channel covers."""
    return ([w for w in windows if w[0] >= start_s and w[1] <= stop_s],
            [g for g in gapped if g[0] >= start_s and g[1] <= stop_s])


def gap_notes(gapped) -> list[str]:
    """A note per run-up window left out for a tacho gap (:func:`shaft_windows`)."""
    return [f"1x window {t0:.4g}-{t1:.4g} s left out: the tacho missed {missed} pulses there "
            "(the speed changes)" for t0, t1, missed in gapped]


def noise_notes(track, method: str) -> list[str]:
    """Per dwell and channel, the 2-sigma random error of the 1x magnitude from its fit's
    residual (rotor_avc.analysis.one_x_noise); points it makes undecidable at
    TOL_OFF_RESONANCE_DB are named, the worst one is stated (dwells only: a run-up's windows
    are rated as a curve)."""
    if method != "stepped-speed dwells":
        return []
    out, worst = [], (0.0, "")
    for name, phasors in track.phasors.items():
        for hz, y, sigma in zip(track.speed_hz, phasors, track.sigma[name]):
            with np.errstate(divide="ignore", invalid="ignore"):
                ok, width = decidable(float(sigma / abs(y)), TOL_OFF_RESONANCE_DB)
            worst = max(worst, (width, f"{name} at {hz:.4g} Hz"))
            if not ok:
                out.append(f"1x of {name} at {hz:.4g} Hz: noise allows +-{width:.2g} dB "
                           f"(2 sigma), too poor for a {TOL_OFF_RESONANCE_DB:g} dB verdict")
    if worst[1]:
        out.append(f"1x random error from the noise (2 sigma, dwells' second halves): largest "
                   f"+-{worst[0]:.2g} dB ({worst[1]})")
    return out


def _recorded_rates(clean: dict) -> dict[str, float]:
    return {name: quality.rate_hz for name, (_, _, quality) in clean.items()}


def _span_s(clean: dict) -> float:
    return (min(t[-1] for t, _, _ in clean.values())
            - max(t[0] for t, _, _ in clean.values()))


def top_speed_hz(shaft_map, stamps_s, angle) -> float:
    """The highest rotational frequency of the recording (before the grid exists): from the
    shortest pulse interval (duplicates dropped) or the counted encoder angle."""
    if shaft_map.source == "pulse":
        p, revs, _ = R.clean_pulses(np.unique(stamps_s))
        return float(np.max(revs / np.diff(p)))
    t, a, _ = R.clean_stamps(stamps_s, angle)
    crossings = R.angle_crossings(t, R.count_revolutions(t, a))
    if crossings.size < 2:
        raise ModelError("shaft angle: the recording covers less than one revolution")
    return float(1.0 / np.min(np.diff(crossings)))


def _grid(clean: dict, period_s: float) -> np.ndarray:
    """The uniform grid every channel covers, aligned to the fastest channel's stamps (its
    memory, with the channels resampled onto it, checked against the limit first)."""
    start = max(t[0] for t, _, _ in clean.values())
    stop = min(t[-1] for t, _, _ in clean.values())
    if stop <= start:
        raise ConfigError("channels", "the mapped channels do not overlap in time",
                          fix="map topics recorded at the same time")
    n = int(np.floor((stop - start) / period_s)) + 1
    check_memory(n * FLOAT_BYTES * (len(clean) + 6), f"a {n}-point resampling grid "
                 f"({stop - start:.6g} s at {1 / period_s:g} Hz, {len(clean)} channels)",
                 fix="check the channels' stamps (a clock jump stretches the record), or "
                     "compare a shorter recording")
    fastest = max(clean.values(), key=lambda c: c[2].rate_hz)[0]
    anchor = fastest[np.searchsorted(fastest, start)]
    return anchor + period_s * np.arange(int(np.floor((stop - anchor) / period_s)) + 1)


def shaft_of(shaft_map, stamps_s, angle, grid) -> tuple[R.Shaft, str]:
    opts = dict(dwell_tol=shaft_map.dwell_tol, min_revolutions=shaft_map.min_dwell_revolutions)
    if shaft_map.source == "pulse":
        t, _, fixed = R.clean_stamps(stamps_s, np.zeros(stamps_s.size))
        shaft = R.shaft_from_pulses(t, grid, angle_at_pulse_rad=np.radians(
            shaft_map.pulse_angle_deg), **opts)
        what = shaft.report.describe() + (f", {fixed} out of order or repeated" if fixed else "")
    else:
        t, angle, fixed = R.clean_stamps(stamps_s, angle)
        theta = R.count_revolutions(t, angle)
        shaft = R.shaft_from_pulses(R.angle_crossings(t, theta), grid, **opts)
        shaft.angle_rad = np.interp(grid, t, theta)
        shaft.knots = ShaftAngle(t, theta)
        shaft.valid &= (grid >= t[0]) & (grid <= t[-1])
        what = (R.stamp_quality("angle", t, fixed).describe() + "; whole revolutions: "
                + shaft.report.describe())
    dwells = ", ".join(f"{hz:.6g} Hz ({a:.3g}-{b:.3g} s)" for a, b, hz in shaft.dwells)
    return shaft, (f"shaft ({shaft_map.source}, {shaft_map.topic}): {what}; constant-speed "
                   f"dwells: {dwells or 'none'}")


def band_notes(comp: Comparison, sigmas: float = 2.0) -> list[str]:
    """Per broadband output: coherence over the test band and the share of bins whose H1 lies
    within ``sigmas`` random errors of the sampled-loop model."""
    out = []
    for bb in comp.broadband:
        est = bb.estimate
        sel = np.isin(est.freq_hz, bb.models["sampled"].freq_hz)
        for i, name in enumerate(bb.outputs):
            coh = est.coherence[sel, i]
            eps = h1_random_error(coh, est.averages)
            model = np.abs(bb.models["sampled"].responses[name])
            inside = np.abs(np.abs(est.h1[sel, i]) - model) <= sigmas * eps * np.abs(est.h1[sel, i])
            out.append(f"{name} at {bb.speed_rad_s / (2 * np.pi):.4g} Hz: coherence median "
                       f"{np.median(coh):.4f}, min {coh.min():.4f} ({int((coh < MIN_COHERENCE).sum())}"
                       f" of {coh.size} bins below {MIN_COHERENCE}: not rated); H1 within "
                       f"+-{sigmas:g} sigma of the sampled-loop model in "
                       f"{100 * inside.mean():.1f} % of the bins ({est.averages} averages)")
    return out
