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
  the grid), which the report states at the highest frequency compared;
* :func:`shaft_from_pulses` -- revolution ``k`` at pulse time ``t_k``: the angle is
  ``2 pi k + angle_at_pulse`` interpolated linearly between pulses (a missing pulse is an
  interval about twice its neighbours' median: it counts the revolutions it spans), the speed
  ``2 pi n_k / (t_{k+1} - t_k)`` per interval. Runs of intervals whose speed stays within
  ``dwell_tol`` (relative) of the run's mean for at least ``min_revolutions`` revolutions are
  constant-speed dwells and get their mean speed (whole revolutions over their duration), so
  that the order tracking finds them (:func:`rotor_avc.analysis.order_tracking.dwells`);
  between dwells the speed is interpolated linearly between interval midpoints.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

TWO_PI = 2.0 * np.pi
#: an interval at least this many median periods long is a gap (samples dropped)
GAP_RATIO = 1.5


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


def interpolation_loss_db(stamps_s, grid_s, freq_hz: float) -> float:
    """Magnitude loss (dB, >= 0) at ``freq_hz`` of linear interpolation from ``stamps_s`` onto
    ``grid_s``: ``-20 log10 |mean_i((1 - a_i) e^{-j w a_i d_i} + a_i e^{j w (1 - a_i) d_i})|``
    over the grid points (the interpolated ``e^{j w t}`` over the true one), with ``a_i`` the
    fraction of its interval ``d_i`` a point lies past the sample before it (no loss for a
    channel sampled on the grid; ``-20 log10 sinc^2(f p)`` for one at another rate)."""
    t = np.asarray(stamps_s, dtype=float)
    grid = np.asarray(grid_s, dtype=float)
    right = np.clip(np.searchsorted(t, grid, side="right"), 1, t.size - 1)
    d = t[right] - t[right - 1]
    a = np.clip((grid - t[right - 1]) / d, 0.0, 1.0)
    w = 2 * np.pi * freq_hz
    gain = np.mean((1 - a) * np.exp(-1j * w * a * d) + a * np.exp(1j * w * (1 - a) * d))
    return float(-20.0 * np.log10(abs(gain)))


@dataclass
class Shaft:
    """Angle and speed on the grid, from pulses; ``dwells_hz`` the dwells found."""

    angle_rad: np.ndarray
    speed_rad_s: np.ndarray
    valid: np.ndarray
    pulses: int
    missing_pulses: int
    dwells: list[tuple[float, float, float]]       # (start s, end s, speed Hz)


def revolutions_per_interval(intervals_s: np.ndarray) -> np.ndarray:
    """Whole revolutions each pulse interval spans (1, or more where pulses are missing):
    the interval over the median of it and its four neighbours, rounded."""
    d = np.asarray(intervals_s, dtype=float)
    pad = np.pad(d, 2, mode="edge")
    ref = np.median(np.lib.stride_tricks.sliding_window_view(pad, 5), axis=1)
    return np.maximum(1, np.round(d / ref)).astype(int)


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
    d = np.diff(p)
    revs = revolutions_per_interval(d)
    angle_at = angle_at_pulse_rad + TWO_PI * np.concatenate([[0], np.cumsum(revs)])
    speeds = TWO_PI * revs / d
    grid = np.asarray(grid_s, dtype=float)
    angle = np.interp(grid, p, angle_at)
    speed = np.interp(grid, 0.5 * (p[1:] + p[:-1]), speeds)
    dwells = []
    for i, j in find_dwells(speeds, revs, dwell_tol, min_revolutions):
        w = TWO_PI * revs[i:j].sum() / (p[j] - p[i])
        speed[(grid >= p[i]) & (grid <= p[j])] = w
        dwells.append((float(p[i]), float(p[j]), float(w / TWO_PI)))
    return Shaft(angle, speed, (grid >= p[0]) & (grid <= p[-1]), int(p.size),
                 int(revs.sum() - revs.size), dwells)


def angle_crossings(stamps_s, angle_rad) -> np.ndarray:
    """Times at which an unwrapped, increasing angle passes whole revolutions (pulses of an
    encoder angle), interpolated linearly between samples."""
    theta = np.unwrap(np.asarray(angle_rad, dtype=float))
    t = np.asarray(stamps_s, dtype=float)
    turns = np.arange(np.ceil(theta[0] / TWO_PI), np.floor(theta[-1] / TWO_PI) + 1) * TWO_PI
    if not np.all(np.diff(theta) >= 0):
        raise ModelError("shaft angle: the angle must not decrease (positive speed); cut the "
                         "record to the turning part")
    return np.interp(turns, theta, t)
