"""Order tracking: the 1x (synchronous) phasor of recorded signals from the shaft angle.

A channel of a linear machine under unbalance responds in steady state as
``y(t) = Re{Y e^{j theta(t)}}`` (plant convention: force ``Re{F u e^{j theta}}``,
``rotor_avc.models.plant``), with ``theta`` the integrated shaft angle. Over the samples of an
integer number ``n`` of revolutions (seed 000 section 10, "Phasors")::

    Y_hat = (2/N) sum_k y[k] e^{-j theta[k]},     Y_hat / u  ->  the response per unit unbalance

where ``u`` is the run's complex unbalance amplitude (e.g. ``m e e^{j phi}`` in kg m), so the
result compares directly with :func:`rotor_avc.closed_loop.frf.unbalance_frf`. The window
``[k0, k1)`` is chosen with ``theta[k1] - theta[k0]`` as close to ``2 pi n`` as the sampling
allows; at constant speed the ``e^{-2 j theta}`` image then cancels up to the fraction of a
sample by which the span misses ``2 pi n`` (relative error below ``1 / samples_per_window``),
and the window mean is subtracted first so that an offset cannot leak in the same way.

* :func:`stepped_speed` -- one phasor per constant-speed dwell (found from the recorded speed),
  over the whole revolutions at the end of the dwell, after a settling time;
* :func:`run_up` -- one phasor per window of a few revolutions of a run-up/run-down; the result
  is quasi-stationary: exact only as far as the response follows the sweep;
* :func:`concatenate` -- the tracks of several records (dwells read one at a time) as one.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from ..errors import ModelError

TWO_PI = 2.0 * np.pi


@dataclass
class OrderTrack:
    """1x phasors per window, divided by the run's unbalance ``unbalance``."""

    speed_rad_s: np.ndarray
    time_s: np.ndarray                  # window centre
    phasors: dict[str, np.ndarray]
    revolutions: np.ndarray             # whole revolutions per window
    samples: np.ndarray                 # samples per window
    unbalance: complex
    #: per channel and window: |Y(second half) - Y(first half)| / |Y| over the window's whole
    #: revolutions split in two -- how far a dwell still is from steady state (NaN: < 2 revs)
    drift: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def speed_hz(self) -> np.ndarray:
        return self.speed_rad_s / TWO_PI

    def db(self, name: str) -> np.ndarray:
        """Magnitude in dB re 1 SI unit per unit unbalance."""
        with np.errstate(divide="ignore"):
            return 20 * np.log10(np.abs(self.phasors[name]))


def phasor(angle_rad, values) -> np.ndarray:
    """``(2/N) sum (y - mean y) e^{-j theta}`` over the given samples (``values`` (N,) or
    (N, m)); removing the window mean keeps a constant offset from leaking in when the span
    misses whole revolutions by a fraction of a sample."""
    theta = np.asarray(angle_rad, dtype=float)
    y = np.asarray(values, dtype=float)
    return 2.0 / theta.size * (np.exp(-1j * theta) @ (y - y.mean(axis=0)))


def _inputs(time_s, angle_rad, signals: Mapping, unbalance):
    t = np.asarray(time_s, dtype=float)
    if t.ndim != 1 or t.size < 3 or not np.all(np.diff(t) > 0):
        raise ModelError("order tracking: time_s must be a strictly increasing 1-D array "
                         "of at least 3 samples")
    theta = np.unwrap(np.asarray(angle_rad, dtype=float))
    if theta.shape != t.shape or not np.all(np.isfinite(theta)):
        raise ModelError(f"order tracking: angle_rad has shape {np.shape(angle_rad)}, "
                         f"time_s {t.shape}; both need one finite value per sample")
    if not signals:
        raise ModelError("order tracking: no signals given")
    ys = {}
    for name, values in signals.items():
        y = np.asarray(values, dtype=float)
        if y.shape != t.shape or not np.all(np.isfinite(y)):
            raise ModelError(f"order tracking: signal {name!r} has shape {y.shape}, need "
                             f"{t.shape} finite values (one per sample of the angle)")
        ys[name] = y
    u = complex(unbalance)
    if u == 0 or not np.isfinite(u):
        raise ModelError(f"order tracking: the run's unbalance amplitude is {u}; "
                         "give the (non-zero) complex unbalance the run was excited with")
    return t, theta, ys, u


def _window_before(theta: np.ndarray, first: int, last: int) -> tuple[int, int, int]:
    """Whole revolutions ending at sample ``last``, starting at or after ``first``:
    (k0, k1, n) with theta[k1] - theta[k0] ~ 2 pi n, k1 = last."""
    if last <= first:
        return last, last, 0
    span = theta[last] - theta[first]
    n = int(np.floor((span + 0.5 * span / (last - first)) / TWO_PI))   # within half a sample
    if n < 1:
        return last, last, 0
    target = theta[last] - TWO_PI * n
    k0 = int(np.searchsorted(theta[first:last + 1], target)) + first
    if k0 > first and abs(theta[k0 - 1] - target) < abs(theta[k0] - target):
        k0 -= 1
    return k0, last, n


def _track(t, theta, ys, u, windows) -> OrderTrack:
    speeds, times, revs, samples = [], [], [], []
    phasors = {name: [] for name in ys}
    drift = {name: [] for name in ys}
    for k0, k1, n in windows:
        speeds.append((theta[k1] - theta[k0]) / (t[k1] - t[k0]))
        times.append(0.5 * (t[k0] + t[k1]))
        revs.append(n)
        samples.append(k1 - k0)
        half = n // 2
        km = int(np.searchsorted(theta[k0:k1], theta[k0] + TWO_PI * half)) + k0
        k2 = int(np.searchsorted(theta[k0:k1], theta[k1] - TWO_PI * half)) + k0
        for name, y in ys.items():
            whole = phasor(theta[k0:k1], y[k0:k1])
            phasors[name].append(whole / u)
            if half < 1 or abs(whole) == 0:
                drift[name].append(np.nan)
                continue
            first, last = phasor(theta[k0:km], y[k0:km]), phasor(theta[k2:k1], y[k2:k1])
            drift[name].append(abs(last - first) / abs(whole))
    return OrderTrack(np.array(speeds), np.array(times),
                      {name: np.array(v, complex) for name, v in phasors.items()},
                      np.array(revs, int), np.array(samples, int), u,
                      {name: np.array(v, float) for name, v in drift.items()})


def concatenate(tracks: list[OrderTrack]) -> OrderTrack:
    """One track of the windows of several (of the same channels and unbalance), in order."""
    first = tracks[0]
    return OrderTrack(
        np.concatenate([t.speed_rad_s for t in tracks]), np.concatenate([t.time_s for t in tracks]),
        {n: np.concatenate([t.phasors[n] for t in tracks]) for n in first.phasors},
        np.concatenate([t.revolutions for t in tracks]),
        np.concatenate([t.samples for t in tracks]),
        first.unbalance, {n: np.concatenate([t.drift[n] for t in tracks]) for n in first.drift})


def dwells(speed_rad_s, rel_tol: float = 1e-6) -> list[tuple[int, int]]:
    """Sample ranges ``[a, b)`` over which the recorded speed stays constant: consecutive
    samples differ by at most ``rel_tol * max(|speed|, 1e-3 rad/s)``."""
    w = np.asarray(speed_rad_s, dtype=float)
    jumps = np.abs(np.diff(w)) > rel_tol * np.maximum(np.abs(w[1:]), 1e-3)
    cuts = np.concatenate([[0], np.flatnonzero(jumps) + 1, [w.size]])
    return [(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:]) if b - a > 1]


def stepped_speed(time_s, angle_rad, speed_rad_s, signals: Mapping, unbalance=1.0, *,
                  settle_s: float | None = None, settle_fraction: float = 0.5,
                  min_revolutions: int = 4, rel_tol: float = 1e-6) -> OrderTrack:
    """1x phasors per constant-speed dwell of a stepped-speed run.

    Each dwell (:func:`dwells` of the recorded speed) contributes the whole revolutions at its
    end, after ``settle_s`` seconds (default: the first ``settle_fraction`` of the dwell), when
    they are at least ``min_revolutions``; dwells at zero or negative speed are skipped.
    """
    t, theta, ys, u = _inputs(time_s, angle_rad, signals, unbalance)
    w = np.asarray(speed_rad_s, dtype=float)
    if w.shape != t.shape:
        raise ModelError(f"order tracking: speed_rad_s has shape {w.shape}, need {t.shape}")
    if not 0 <= settle_fraction < 1 or (settle_s is not None and settle_s < 0):
        raise ModelError("order tracking: settle_s >= 0 and 0 <= settle_fraction < 1 needed")
    windows = []
    for a, b in dwells(w, rel_tol):
        if np.mean(w[a:b]) <= 0:
            continue
        first = (int(np.searchsorted(t, t[a] + settle_s)) if settle_s is not None
                 else a + int(settle_fraction * (b - a)))
        if first >= b - 1:
            continue
        k0, k1, n = _window_before(theta, first, b - 1)
        if n >= min_revolutions:
            windows.append((k0, k1, n))
    if not windows:
        raise ModelError(f"order tracking: no constant-speed dwell with {min_revolutions} whole "
                         "revolutions after settling; record longer dwells or lower settle_s / "
                         "min_revolutions")
    return _track(t, theta, ys, u, windows)


def run_up(time_s, angle_rad, signals: Mapping, unbalance=1.0, *,
           revolutions: int = 8) -> OrderTrack:
    """1x phasors over consecutive windows of ``revolutions`` whole revolutions (run-up or
    run-down at positive speed); speed = mean speed of the window."""
    t, theta, ys, u = _inputs(time_s, angle_rad, signals, unbalance)
    if revolutions < 1:
        raise ModelError("order tracking: revolutions per window must be >= 1")
    if not np.all(np.diff(theta) > 0):
        raise ModelError("order tracking: the shaft angle must increase (positive speed) over "
                         "the whole run-up; cut the record to the rotating part")
    marks = theta[0] + TWO_PI * revolutions * np.arange(
        int((theta[-1] - theta[0]) / (TWO_PI * revolutions)) + 1)
    idx = np.clip(np.searchsorted(theta, marks), 1, theta.size - 1)
    idx -= (np.abs(theta[idx - 1] - marks) < np.abs(theta[idx] - marks)).astype(int)
    windows = [(int(a), int(b), revolutions) for a, b in zip(idx[:-1], idx[1:]) if b > a + 2]
    if not windows:
        raise ModelError(f"order tracking: the record covers fewer than {revolutions} "
                         "revolutions; use fewer revolutions per window")
    return _track(t, theta, ys, u, windows)
