"""A recording of any machine as a :class:`~rotor_avc.compare.recorded_run.RecordedRun`: the
scenario from a machine configuration, the signals from a bag through a mapping file
(:mod:`.recording_map`), resampled onto one uniform grid (:mod:`rotor_avc.analysis.resampling`).

* the scenario: ``--config`` (a scenario config: machine, controllers, ``simulation:`` with the
  sample rate, unbalance, damping rule and test signal), its ``simulation.unbalance`` replaced by
  the mapping's ``unbalance`` when given;
* the grid: the configuration's sample period (the controllers' rate, which the sampled-loop
  model and the FRF estimate use), over the time every channel covers, aligned to the stamps of
  the fastest channel; every channel linearly interpolated onto it, grid points in a gap of more
  than ``resample.max_missing_samples`` missing samples of any channel excluded;
* the shaft: a pulse topic (``shaft_from_pulses``), an encoder angle or a JointState position
  (the angle interpolated, the speed and its dwells from the angle's whole-revolution crossings);
* ``notes``: what was found per channel (rate, jitter, dropped samples, longest gap), the shaft
  (pulses, missing pulses, dwells), the resampling method and its loss, and the 1x points whose
  noise (:mod:`rotor_avc.analysis.one_x_noise`, over the dwell's second half: a short dwell has
  few samples) is too large for a verdict. :func:`compare_mapped` adds per output the coherence of the broadband estimate
  and the fraction of H1 inside its +-2 sigma band around the sampled-loop model.
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from ..analysis import resampling as R
from ..analysis.frf_estimate import h1_random_error
from ..analysis.one_x_noise import decidable, one_x_random_error
from ..bag import BagError
from ..bag.rosbag2 import open_bag
from ..config import find_config, load_yaml
from ..errors import ConfigError
from ..scenario import scenario_from_config
from .checks import MIN_COHERENCE, TOL_OFF_RESONANCE_DB
from .comparison import Comparison, compare_run
from .recorded_run import RecordedRun
from .recording_map import DEFAULT_ANGLE_FIELD, read_map

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


def _read_field(bag, sig, where: str, source: str) -> tuple[np.ndarray, np.ndarray]:
    """(stamps ns, SI values) of one mapped field."""
    if sig.topic not in bag.topics:
        raise ConfigError(f"{where}.topic", f"no topic {sig.topic} in {bag.path}",
                          fix="use one of " + ", ".join(sorted(bag.topics)), source=source)
    series = bag.series(sig.topic)
    try:
        values = np.asarray(series[sig.field], dtype=float)
    except BagError as exc:
        raise ConfigError(f"{where}.field", f"{sig.field!r} is not a numeric field of "
                          f"{sig.topic}", fix=exc.fix, source=source) from None
    if values.ndim != 1:
        raise ConfigError(f"{where}.field", f"{sig.field!r} of {sig.topic} is an array",
                          fix=f"pick one element, e.g. {sig.field}[0]", source=source)
    return _stamps_ns(series, sig.stamp, where, source), sig.sign * sig.scale * values


def _read_shaft(bag, shaft, source: str) -> tuple[np.ndarray, np.ndarray | None]:
    """(stamps ns, angle rad or None for pulses)."""
    if shaft.topic not in bag.topics:
        raise ConfigError("shaft.topic", f"no topic {shaft.topic} in {bag.path}",
                          fix="use one of " + ", ".join(sorted(bag.topics)), source=source)
    series = bag.series(shaft.topic)
    stamps = _stamps_ns(series, shaft.stamp, "shaft", source)
    if shaft.source == "pulse":
        return stamps, None
    name = shaft.field or DEFAULT_ANGLE_FIELD[shaft.source]
    try:
        return stamps, np.asarray(series[name], dtype=float)
    except BagError as exc:
        raise ConfigError("shaft.field", f"{name!r} is not a field of {shaft.topic}",
                          fix=exc.fix, source=source) from None


def load_machine_and_map(config, map_path):
    """``(config data, scenario, map, channel name -> SignalMap)``: the scenario with the map's
    unbalance reference when it gives one."""
    config_path = find_config(config)
    data = load_yaml(config_path)
    scenario = scenario_from_config(data, str(config_path))
    rmap, signals = read_map(map_path, model_signals(scenario.machine.plant))
    if rmap.unbalance is not None:
        data = copy.deepcopy(data)
        data.setdefault("simulation", {})["unbalance"] = rmap.unbalance
        scenario = scenario_from_config(data, f"{config_path} with the unbalance of {map_path}")
    if rmap.test_force is not None and scenario.test_force is None:
        raise ConfigError("test_force", "the configuration has no simulation.test_signal (its "
                          "actuator and band)", fix=f"add simulation.test_signal to "
                          f"{config_path} or drop test_force", source=str(map_path))
    return data, scenario, rmap, signals


def read_mapped_run(bag_path, config, map_path) -> RecordedRun:
    """The recording at ``bag_path`` (.mcap or rosbag2 directory) as a RecordedRun of the
    machine ``config`` through the mapping ``map_path`` (see the module docstring)."""
    data, scenario, rmap, signals = load_machine_and_map(config, map_path)
    source = str(map_path)
    mapped = {name: (sig, f"channels.{name}") for name, sig in signals.items()}
    if rmap.test_force is not None:
        mapped[TEST_FORCE] = (rmap.test_force, "test_force")
    with open_bag(bag_path, require_messages=True, integrity=True) as bag:
        raw = {name: _read_field(bag, sig, where, source) for name, (sig, where) in mapped.items()}
        shaft_ns, shaft_angle = _read_shaft(bag, rmap.shaft, source)
    origin_ns = min(min(int(t.min()) for t, _ in raw.values()), int(shaft_ns.min()))
    notes, clean = [], {}
    for name, (stamps, values) in raw.items():
        t, y, fixed = R.clean_stamps((stamps - origin_ns) * 1e-9, values)
        quality = R.stamp_quality(f"{name} ({mapped[name][0].topic})", t, fixed)
        clean[name] = (t, y, quality)
        notes.append(quality.describe())
    grid = _grid(clean, scenario.sample_period_s)
    valid = np.ones(grid.size, bool)
    channels = {}
    for name, (t, y, _) in clean.items():
        channels[name], ok = R.resample(t, y, grid, rmap.resample.max_missing_samples)
        valid &= ok
    shaft, shaft_note = _shaft(rmap.shaft, (shaft_ns - origin_ns) * 1e-9, shaft_angle, grid)
    valid &= shaft.valid
    top_hz = float(shaft.speed_rad_s.max() / (2 * np.pi))
    if TEST_FORCE in clean:
        top_hz = max(top_hz, scenario.test_force.band_hz[1])
    losses = [f"{name} {R.interpolation_loss_db(t, grid, top_hz):.2g} dB"
              for name, (t, _, _) in clean.items()]
    notes.append(shaft_note)
    notes.append(f"resampling: linear interpolation onto the configuration's "
                 f"{1 / scenario.sample_period_s:g} Hz grid aligned to the fastest channel's "
                 f"stamps; {int((~valid).sum())} of {grid.size} grid points excluded (in gaps of "
                 f"more than {rmap.resample.max_missing_samples} missing samples, outside a "
                 f"channel's record); interpolation loss at {top_hz:.4g} Hz: " + ", ".join(losses))
    keep = np.flatnonzero(valid)
    if keep.size < 3:
        raise BagError(bag_path, "fewer than 3 grid points are covered by every mapped channel "
                       "and the shaft", fix="check the mapping's topics and stamps")
    test = channels.pop(TEST_FORCE, None)
    channels = {n: v[keep] for n, v in channels.items()}
    if test is None:
        notes += _noisy_points(grid[keep], shaft.angle_rad[keep], channels, shaft.dwells)
    return RecordedRun(Path(bag_path), scenario, data, "", grid[keep],
                       shaft.angle_rad[keep], shaft.speed_rad_s[keep], channels,
                       None if test is None else test[keep],
                       "" if test is None else f"recorded ({rmap.test_force.topic})", notes)


def _grid(clean: dict, period_s: float) -> np.ndarray:
    """The uniform grid every channel covers, aligned to the fastest channel's stamps."""
    start = max(t[0] for t, _, _ in clean.values())
    stop = min(t[-1] for t, _, _ in clean.values())
    if stop <= start:
        raise ConfigError("channels", "the mapped channels do not overlap in time",
                          fix="map topics recorded at the same time")
    fastest = max(clean.values(), key=lambda c: c[2].rate_hz)[0]
    anchor = fastest[np.searchsorted(fastest, start)]
    return anchor + period_s * np.arange(int(np.floor((stop - anchor) / period_s)) + 1)


def _shaft(shaft_map, stamps_s, angle, grid) -> tuple[R.Shaft, str]:
    opts = dict(dwell_tol=shaft_map.dwell_tol, min_revolutions=shaft_map.min_dwell_revolutions)
    if shaft_map.source == "pulse":
        t, _, fixed = R.clean_stamps(stamps_s, np.zeros(stamps_s.size))
        shaft = R.shaft_from_pulses(t, grid, angle_at_pulse_rad=np.radians(
            shaft_map.pulse_angle_deg), **opts)
        what = (f"{shaft.pulses} pulses, {shaft.missing_pulses} missing (counted from the "
                f"intervals)" + (f", {fixed} out of order or repeated" if fixed else ""))
    else:
        t, angle, fixed = R.clean_stamps(stamps_s, angle)
        theta = np.unwrap(angle)
        shaft = R.shaft_from_pulses(R.angle_crossings(t, theta), grid, **opts)
        shaft.angle_rad = np.interp(grid, t, theta)
        shaft.valid &= (grid >= t[0]) & (grid <= t[-1])
        what = R.stamp_quality("angle", t, fixed).describe()
    dwells = ", ".join(f"{hz:.4g} Hz ({a:.3g}-{b:.3g} s)" for a, b, hz in shaft.dwells)
    return shaft, (f"shaft ({shaft_map.source}, {shaft_map.topic}): {what}; constant-speed "
                   f"dwells (speed spread <= {shaft_map.dwell_tol:g}): {dwells or 'none'}")


def _noisy_points(time_s, angle_rad, channels, dwells) -> list[str]:
    """Per dwell and channel, the 2-sigma random error of the 1x magnitude over the dwell's
    second half (where the order tracking takes it); points it makes undecidable at
    TOL_OFF_RESONANCE_DB are named, the worst one is stated."""
    out, worst = [], (0.0, "")
    for a, b, hz in dwells:
        sel = (time_s >= 0.5 * (a + b)) & (time_s <= b)
        if sel.sum() < 8:
            continue
        for name, y in channels.items():
            _, eps = one_x_random_error(angle_rad[sel], y[sel])
            ok, width = decidable(eps, TOL_OFF_RESONANCE_DB)
            worst = max(worst, (width, f"{name} at {hz:.4g} Hz"))
            if not ok:
                out.append(f"1x of {name} at {hz:.4g} Hz: noise allows +-{width:.2g} dB "
                           f"(2 sigma), too poor for a {TOL_OFF_RESONANCE_DB:g} dB verdict")
    if worst[1]:
        out.append(f"1x random error from the noise (2 sigma, dwells' second halves): largest "
                   f"+-{worst[0]:.2g} dB ({worst[1]})")
    return out


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


def compare_mapped(bag_path, config, map_path) -> Comparison:
    """:func:`read_mapped_run` compared (:func:`~.comparison.compare_run`), with
    :func:`band_notes`."""
    comp = compare_run(read_mapped_run(bag_path, config, map_path))
    comp.notes += band_notes(comp)
    return comp
