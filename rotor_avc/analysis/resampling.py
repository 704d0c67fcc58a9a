"""Imperfect recordings onto one uniform time grid: what each channel's stamps look like, linear
resampling with gaps excluded, and the shaft angle and speed from a once-per-revolution pulse.

A real recording has per-sensor rates, stamp jitter, dropped samples and an encoder or tacho
instead of the simulator's exact angle. The method:

* :func:`stamp_quality` -- per channel: rate (1 / median stamp interval ``p``), jitter (std of
  the intervals shorter than ``1.5 p``), dropouts (intervals ``d >= 1.5 p`` count
  ``round(d / p) - 1`` missing samples each) and the longest gap;
* :func:`resample` -- linear interpolation of every channel onto the grid; a grid point inside a
  gap of more than ``max_missing`` missing samples (or outside the channel's record) is
  excluded. Linear interpolation of a channel sampled every
  ``p`` s is the filter ``(1 - a) e^{-j w a p} + a e^{j w (1 - a) p}`` for a grid point a
  fraction ``a`` past a sample (``cos(pi f p)`` at mid-interval); :func:`interpolation_loss_db`
  averages it over the grid (``sinc^2(f p)`` for a channel at another rate, 1 for one sampled on
  the grid), which the report states at the highest frequency compared; an FRF between resampled
  channels is divided by the ratio of their :func:`interpolation_gain` (output over input);
* :func:`shaft_from_pulses` -- revolution ``k`` at pulse time ``t_k``: the angle is
  ``2 pi k + angle_at_pulse`` interpolated linearly between pulses, the speed
  ``2 pi n_k / (t_{k+1} - t_k)`` per interval. The revolutions are counted from the intervals
  (:func:`clean_pulses`): an interval about ``n`` times the median of its neighbours spans ``n``
  revolutions (missing pulses, a burst of dropped tacho messages), and a pulse less than half
  a revolution after the one before is a duplicate (contact bounce, a repeated message) and is
  dropped; both are counted. The angle is continuous by construction, whatever gaps the other
  channels have, and is never unwrapped from samples. Runs of intervals whose speed stays within
  ``dwell_tol`` (relative) of the run's mean for at least ``min_revolutions`` revolutions are
  constant-speed dwells and get their mean speed (whole revolutions over their duration), so
  that the order tracking finds them (:func:`rotor_avc.analysis.order_tracking.dwells`);
  between dwells the speed is interpolated linearly between interval midpoints.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .order_tracking import ShaftAngle

TWO_PI = 2.0 * np.pi
#: an interval at least this many median periods long is a gap (samples dropped)
GAP_RATIO = 1.5
#: a recorded value of larger magnitude is an overflow, not a measurement (its square and any
#: power sum over a record would leave the floating-point range)
OVERFLOW = 1e100
#: a sensor clock that moves against the recorder's clock by more than this is a clock step
CLOCK_STEP_S = 0.1
#: samples on each side of a candidate clock step over which the shift must persist
CLOCK_STEP_PERSISTENCE = 25


def usable_samples(values) -> tuple[np.ndarray, int]:
    """``(mask, excluded)``: the samples that are finite and below :data:`OVERFLOW` in
    magnitude; the others are excluded from the channel (and counted), like dropped samples."""
    y = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(y) & (np.abs(y) < OVERFLOW)
    return ok, int(ok.size - ok.sum())


def clock_steps(stamps_s, log_s, start: int = 0, stop: int | None = None
                ) -> list[tuple[float, float]]:
    """Steps of a sensor clock against the recorder's, ``[(log time s, step s)]``, from the
    stamps and log times in arrival order: where the offset ``stamp - log`` changes by more than
    :data:`CLOCK_STEP_S` between the medians of the :data:`CLOCK_STEP_PERSISTENCE` samples
    before and after (a transport latency spike or a short recorder stall moves single samples
    and does not persist; an NTP step, a clock reset or a time-zone jump does). Only steps at
    samples ``start`` to ``stop`` (in arrival order) are looked for."""
    order = np.argsort(np.asarray(log_s, dtype=float), kind="stable")
    log = np.asarray(log_s, dtype=float)[order]
    offset = np.asarray(stamps_s, dtype=float)[order] - log
    jumps = np.flatnonzero(np.abs(np.diff(offset)) > CLOCK_STEP_S) + 1
    jumps = jumps[(jumps >= start) & (jumps < (log.size if stop is None else stop))]
    steps, n, last = [], CLOCK_STEP_PERSISTENCE, -CLOCK_STEP_PERSISTENCE
    for k in jumps:
        before = np.median(offset[max(last, k - n, 0):k])
        after = np.median(offset[k:k + n])
        if abs(after - before) > CLOCK_STEP_S:
            steps.append((float(log[k]), float(after - before)))
            last = k
    return steps


@dataclass(frozen=True)
class StampQuality:
    """What a channel's stamps show (times in s)."""

    name: str
    samples: int
    rate_hz: float
    jitter_s: float
    dropouts: int
    longest_gap_s: float
    reordered: int            # stamps out of order or repeated (sorted / counted once)

    def describe(self) -> str:
        text = (f"{self.name}: {self.samples} samples at {self.rate_hz:.6g} Hz, jitter "
                f"{self.jitter_s * 1e6:.3g} us (std of stamp intervals), {self.dropouts} "
                f"dropped samples")
        if self.dropouts:
            text += f" (longest gap {self.longest_gap_s * 1e3:.3g} ms)"
        if self.reordered:
            text += f", {self.reordered} stamps out of order (arrival) or repeated"
        return text


def clean_stamps(stamps_s, values) -> tuple[np.ndarray, np.ndarray, int]:
    """Stamps sorted and repeated stamps counted once: ``(stamps, values, how many fixed)``."""
    t = np.asarray(stamps_s, dtype=float)
    y = np.asarray(values, dtype=float)
    order = np.argsort(t, kind="stable")
    t, y = t[order], y[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    fixed = int(np.count_nonzero(order != np.arange(t.size)) + np.count_nonzero(~keep))
    return t[keep], y[keep], fixed


def median_period_s(stamps_s: np.ndarray) -> float:
    return float(np.median(np.diff(stamps_s)))


def stamp_quality(name: str, stamps_s, reordered: int = 0) -> StampQuality:
    """Rate, jitter, dropouts and longest gap of sorted, distinct stamps (see module)."""
    t = np.asarray(stamps_s, dtype=float)
    if t.size < 3:
        raise ModelError(f"{name}: {t.size} samples; a channel needs at least 3")
    d = np.diff(t)
    p = median_period_s(t)
    gaps = d >= GAP_RATIO * p
    regular = d[~gaps]
    return StampQuality(name, int(t.size), 1.0 / p, float(np.std(regular)) if regular.size else 0.0,
                        int(np.sum(np.round(d[gaps] / p) - 1)),
                        float(d[gaps].max()) if gaps.any() else 0.0, reordered)


def resample(stamps_s, values, grid_s, max_missing: int) -> tuple[np.ndarray, np.ndarray]:
    """Linear interpolation onto ``grid_s``: ``(values, valid)``; ``valid`` is False at grid
    points outside the record or inside a gap of more than ``max_missing`` missing samples (an
    interval longer than ``max_missing + 1.5`` median periods)."""
    t = np.asarray(stamps_s, dtype=float)
    grid = np.asarray(grid_s, dtype=float)
    out = np.interp(grid, t, values)
    right = np.clip(np.searchsorted(t, grid, side="left"), 1, t.size - 1)
    span = t[right] - t[right - 1]
    valid = (grid >= t[0]) & (grid <= t[-1]) & (span <= (max_missing + GAP_RATIO) * median_period_s(t))
    return out, valid


def interpolation_gain(stamps_s, grid_s, freq_hz, max_points: int = 4096) -> np.ndarray:
    """Complex gain at each of ``freq_hz`` of linear interpolation from ``stamps_s`` onto
    ``grid_s``: ``mean_i((1 - a_i) e^{-j w a_i d_i} + a_i e^{j w (1 - a_i) d_i})`` over the grid
    points (the interpolated ``e^{j w t}`` over the true one), with ``a_i`` the fraction of its
    interval ``d_i`` a point lies past the sample before it (1 for a channel sampled on the grid;
    ``sinc^2(f p)`` for one at another rate). At most ``max_points`` grid points, evenly spread,
    enter the mean."""
    t = np.asarray(stamps_s, dtype=float)
    grid = np.asarray(grid_s, dtype=float)
    if grid.size > max_points:
        grid = grid[np.linspace(0, grid.size - 1, max_points).round().astype(int)]
    right = np.clip(np.searchsorted(t, grid, side="right"), 1, t.size - 1)
    d = t[right] - t[right - 1]
    a = np.clip((grid - t[right - 1]) / d, 0.0, 1.0)
    w = 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, dtype=float))[:, None]
    return np.mean((1 - a) * np.exp(-1j * w * a * d) + a * np.exp(1j * w * (1 - a) * d), axis=1)


def interpolation_loss_db(stamps_s, grid_s, freq_hz: float) -> float:
    """Magnitude loss (dB, >= 0) at ``freq_hz`` of :func:`interpolation_gain` over every grid
    point."""
    gain = interpolation_gain(stamps_s, grid_s, freq_hz, max_points=np.asarray(grid_s).size)
    return float(-20.0 * np.log10(abs(gain[0])))


@dataclass
class Shaft:
    """Angle and speed on the grid, from pulses; ``dwells_hz`` the dwells found."""

    angle_rad: np.ndarray
    speed_rad_s: np.ndarray
    valid: np.ndarray
    pulses: int
    missing_pulses: int
    dwells: list[tuple[float, float, float]]       # (start s, end s, speed Hz)
    #: the continuous angle at any time (pulses at 2 pi k, or the counted encoder angle)
    knots: ShaftAngle
    report: "PulseReport | None" = None
    #: pulse intervals of more than two revolutions ``(start s, end s, revolutions)``: the
    #: angle there is interpolated at the mean speed, exact only while the speed is held
    pulse_gaps: list = dataclasses.field(default_factory=list)


#: pulse intervals on each side whose median is a pulse interval's reference revolution
PULSE_NEIGHBOURS = 4


def _reference_interval(d: np.ndarray) -> np.ndarray:
    """Per interval, the median of it and its :data:`PULSE_NEIGHBOURS` neighbours on each side
    (fewer at the ends: the local duration of one revolution while fewer than half of them span
    a gap or are cut short by a duplicate pulse)."""
    pad = np.pad(np.asarray(d, dtype=float), PULSE_NEIGHBOURS, constant_values=np.nan)
    return np.nanmedian(np.lib.stride_tricks.sliding_window_view(pad, 2 * PULSE_NEIGHBOURS + 1),
                        axis=1)


def revolutions_per_interval(intervals_s: np.ndarray) -> np.ndarray:
    """Whole revolutions each pulse interval spans (1, or more where pulses are missing):
    the interval over its :func:`_reference_interval`, rounded."""
    d = np.asarray(intervals_s, dtype=float)
    return np.maximum(1, np.round(d / _reference_interval(d))).astype(int)


def _gap_revolutions(d: np.ndarray, revs: np.ndarray) -> np.ndarray:
    """The revolutions of each gap (an interval of more than one), from the speeds of the
    nearest one-revolution intervals on both sides, ``round(d (f_before + f_after) / 2)``
    (exact for a speed changing linearly across the gap, where the ratio to the local median
    miscounts a long gap in a run-up)."""
    out = revs.copy()
    single = np.flatnonzero(revs == 1)
    if single.size == 0:
        return out
    for i in np.flatnonzero(revs > 1):
        k = np.searchsorted(single, i)
        sides = [single[k - 1]] if k > 0 else []
        sides += [single[k]] if k < single.size else []
        f = np.mean([1.0 / d[j] for j in sides])
        out[i] = max(2, int(np.round(d[i] * f)))
    return out


@dataclass(frozen=True)
class PulseReport:
    """What the tacho's pulse intervals showed."""

    pulses: int                   # pulses used
    duplicates: int               # pulses dropped as duplicates (< half a revolution apart)
    missing: int                  # revolutions without a pulse
    gaps: int                     # intervals spanning more than one revolution
    longest_gap_revolutions: int
    jitter_s: float = 0.0         # pulse timing jitter (std)
    dwell_span: int = 1           # revolutions averaged per speed in the dwell search
    dwell_tol: float = 0.0        # relative speed spread within a dwell, as searched

    def describe(self) -> str:
        text = (f"{self.pulses} pulses, {self.missing} missing (counted from the intervals"
                + (f": {self.gaps} gaps, the longest {self.longest_gap_revolutions} revolutions"
                   if self.gaps else "") + ")")
        if self.duplicates:
            text += f", {self.duplicates} duplicate pulses dropped (< half a revolution apart)"
        return text + (f", pulse times scatter {self.jitter_s * 1e6:.3g} us (std); dwells "
                       f"searched over "
                       f"{self.dwell_span}-revolution speeds with spread <= {self.dwell_tol:.3g}")


def clean_pulses(pulse_s) -> tuple[np.ndarray, np.ndarray, PulseReport]:
    """Sorted distinct pulse times without duplicates: ``(pulses, revolutions per interval,
    report)``; a pulse closer than half a reference revolution to the pulse before it is a
    duplicate (dropped, counted), repeated until none is left."""
    p = np.asarray(pulse_s, dtype=float)
    duplicates = 0
    while p.size >= 3:
        d = np.diff(p)
        short = d < 0.5 * _reference_interval(d)
        if not short.any():
            break
        # the first of each run of short intervals: a drop changes the intervals after it
        first = np.flatnonzero(short & ~np.concatenate([[False], short[:-1]]))
        duplicates += first.size
        p = np.delete(p, first + 1)
    if p.size < 3:
        raise ModelError(f"shaft pulses: need at least 3 increasing pulse times (got {p.size}); "
                         "the shaft turned fewer than 2 revolutions or the stamps are not sorted")
    revs = _gap_revolutions(np.diff(p), revolutions_per_interval(np.diff(p)))
    gaps = revs > 1
    return p, revs, PulseReport(int(p.size), duplicates, int(np.sum(revs[gaps] - 1)),
                                int(gaps.sum()), int(revs.max()) if gaps.any() else 0)


def find_dwells(speeds, revs, dwell_tol: float, min_revolutions: int) -> list[tuple[int, int]]:
    """Runs ``[i, j)`` of pulse intervals whose speed stays within ``dwell_tol`` of the run's
    mean, of at least ``min_revolutions`` revolutions."""
    out, i = [], 0
    while i < speeds.size:
        j, total = i + 1, speeds[i]
        while j < speeds.size and abs(speeds[j] - total / (j - i)) <= dwell_tol * total / (j - i):
            total += speeds[j]
            j += 1
        if revs[i:j].sum() >= min_revolutions:
            out.append((i, j))
        i = j
    return out


def shaft_from_pulses(pulse_s, grid_s, *, angle_at_pulse_rad: float = 0.0,
                      dwell_tol: float = 0.002, min_revolutions: int = 8) -> Shaft:
    """Shaft angle and speed on ``grid_s`` from once-per-revolution pulse times (module)."""
    p = np.asarray(pulse_s, dtype=float)
    if p.size < 3 or not np.all(np.diff(p) > 0):
        raise ModelError(f"shaft pulses: need at least 3 increasing pulse times (got {p.size}); "
                         "the shaft turned fewer than 2 revolutions or the stamps are not sorted")
    p, revs, report = clean_pulses(p)
    d = np.diff(p)
    angle_at = angle_at_pulse_rad + TWO_PI * np.concatenate([[0], np.cumsum(revs)])
    speeds = TWO_PI * revs / d
    grid = np.asarray(grid_s, dtype=float)
    angle = np.interp(grid, p, angle_at)
    speed = np.interp(grid, 0.5 * (p[1:] + p[:-1]), speeds)
    span, tol = dwell_smoothing(p, revs, dwell_tol, min_revolutions)
    dwells = []
    candidates = find_dwells(span_speeds(p, revs, span), revs, tol, min_revolutions)
    cum = np.concatenate([[0], np.cumsum(revs)])
    jitter = pulse_jitter_s(p, revs)
    for i, j in (c for c in candidates if _steady(p[c[0]:c[1] + 1], cum[c[0]:c[1] + 1],
                                                  tol, jitter)):
        w = TWO_PI * revs[i:j].sum() / (p[j] - p[i])
        speed[(grid >= p[i]) & (grid <= p[j])] = w
        dwells.append((float(p[i]), float(p[j]), float(w / TWO_PI)))
    report = dataclasses.replace(report, jitter_s=pulse_jitter_s(p, revs), dwell_span=span,
                                 dwell_tol=tol)
    gaps = [(float(p[i]), float(p[i + 1]), int(revs[i])) for i in np.flatnonzero(revs > 2)]
    return Shaft(angle, speed, (grid >= p[0]) & (grid <= p[-1]), report.pulses,
                 report.missing, dwells, ShaftAngle(p, angle_at), report, gaps)


def _steady(pulses, turns, tol: float, jitter_s: float) -> bool:
    """Whether the speed over these pulses (at revolutions ``turns``) is steady: at least 4
    pulses (a trend needs them: one long interval over missing pulses is no dwell), and the
    speed change over them that a quadratic fit of pulse time against revolution gives,
    ``2 c N / b`` for ``t = a + b n + c n^2`` over ``N`` revolutions, within ``tol`` or, where
    the jitter makes that fit scatter more, within 3 times its scatter (a ramp whose speeds
    stay within ``tol`` of their running mean for a few revolutions is not a dwell)."""
    if pulses.size < 4:
        return False
    n = (turns - turns[0]).astype(float)
    N = n[-1]
    A = np.column_stack([np.ones_like(n), n, n * n])
    (_, b, c), *_ = np.linalg.lstsq(A, pulses - pulses[0], rcond=None)
    scatter = 2 * N * jitter_s * np.sqrt(np.linalg.inv(A.T @ A)[2, 2]) / b
    return abs(2 * c * N / b) <= max(tol, 3 * scatter)


def pulse_jitter_s(p: np.ndarray, revs: np.ndarray) -> float:
    """The pulses' timing jitter (std, s) from the second differences of consecutive
    single-revolution intervals (``e[k+2] - 2 e[k+1] + e[k]``: std ``sqrt(6)`` times the
    jitter), robustly (median absolute deviation, so that speed changes do not count)."""
    single = revs == 1
    dd = np.diff(np.diff(p))[single[1:] & single[:-1]]
    if dd.size < 8:
        return 0.0
    return float(1.4826 * np.median(np.abs(dd - np.median(dd))) / np.sqrt(6.0))


def dwell_smoothing(p, revs, dwell_tol: float, min_revolutions: int) -> tuple[int, float]:
    """``(span, tolerance)`` of the dwell search: the speed of one revolution scatters by
    ``sqrt(2) jitter / period`` (relative); over ``span`` revolutions by ``1 / span`` of that
    (the pulse times telescope). The span is the fewest revolutions (at most half the shortest
    dwell) that bring 4 times the scatter of the fastest revolutions below ``dwell_tol``; the
    tolerance is widened to that scatter where the span cannot (a jittery tacho at high speed:
    dwells are then told apart to that level, which the shaft note states)."""
    period = float(np.percentile(np.diff(p) / revs, 10))
    scatter = np.sqrt(2.0) * pulse_jitter_s(p, revs) / period
    span = int(np.clip(np.ceil(4 * scatter / dwell_tol), 1, max(1, min_revolutions // 2)))
    return span, max(dwell_tol, 4 * scatter / span)


def span_speeds(p, revs, span: int) -> np.ndarray:
    """Per pulse interval, the mean speed over the ``span`` intervals centred on it (fewer at
    the ends)."""
    cum = np.concatenate([[0], np.cumsum(revs)])
    k = np.arange(revs.size)
    lo = np.clip(k - (span - 1) // 2, 0, revs.size - 1)
    hi = np.clip(lo + span, 1, revs.size)
    return TWO_PI * (cum[hi] - cum[lo]) / (p[hi] - p[lo])


def count_revolutions(stamps_s, angle_rad) -> np.ndarray:
    """The continuous angle of a wrapped encoder angle (or one already continuous) sampled at
    ``stamps_s``, with its revolutions counted across gaps: within a run of samples no further
    apart than :data:`GAP_RATIO` median periods the angle is unwrapped (it moves less than half
    a revolution per sample below half the sample rate); across a longer gap the whole
    revolutions are those that make the angle's advance match the speed on both sides of the
    gap (``(w_before + w_after) / 2`` times the gap), so a gap of any length keeps its turns."""
    t = np.asarray(stamps_s, dtype=float)
    a = np.asarray(angle_rad, dtype=float)
    if t.size < 3:
        raise ModelError(f"shaft angle: {t.size} samples; need at least 3")
    d = np.diff(t)
    cuts = np.flatnonzero(d >= GAP_RATIO * median_period_s(t)) + 1
    pieces = [np.unwrap(x) for x in np.split(a, cuts)]
    times = np.split(t, cuts)
    out = [pieces[0]]
    for k in range(1, len(pieces)):
        before, after = out[-1], pieces[k]
        slopes = [_end_slope(times[k - 1][-2:], before[-2:]),
                  _end_slope(times[k][:2], after[:2])]
        known = [w for w in slopes if w is not None]
        if not known:
            raise ModelError("shaft angle: isolated single samples between gaps; the speed "
                             "across the gaps cannot be told -- record the angle more densely "
                             "or use tacho pulses")
        advance = np.mean(known) * (times[k][0] - times[k - 1][-1])
        turns = np.round((before[-1] + advance - after[0]) / TWO_PI)
        out.append(after + TWO_PI * turns)
    return np.concatenate(out)


def _end_slope(t, a):
    return None if t.size < 2 else float((a[-1] - a[0]) / (t[-1] - t[0]))


def angle_crossings(stamps_s, angle_rad) -> np.ndarray:
    """Times at which a continuous, increasing angle (:func:`count_revolutions`) passes whole
    revolutions (pulses of an encoder angle), interpolated linearly between samples."""
    theta = np.asarray(angle_rad, dtype=float)
    t = np.asarray(stamps_s, dtype=float)
    if not np.all(np.diff(theta) >= 0):
        raise ModelError("shaft angle: the angle must not decrease (positive speed); cut the "
                         "record to the turning part")
    turns = np.arange(np.ceil(theta[0] / TWO_PI), np.floor(theta[-1] / TWO_PI) + 1) * TWO_PI
    return np.interp(turns, theta, t)
