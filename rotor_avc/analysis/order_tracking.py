"""Order tracking: the 1x (synchronous) phasor of recorded signals from the shaft angle.

A channel of a linear machine under unbalance responds in steady state as
``y(t) = Re{Y e^{j theta(t)}}`` (plant convention: force ``Re{F u e^{j theta}}``,
``rotor_avc.models.plant``), with ``theta`` the integrated shaft angle. Over the samples of an
integer number ``n`` of revolutions::

    Y_hat = (2/N) sum_k y[k] e^{-j theta[k]},     Y_hat / u  ->  the response per unit unbalance

where ``u`` is the run's complex unbalance amplitude (e.g. ``m e e^{j phi}`` in kg m), so the
result compares directly with :func:`rotor_avc.closed_loop.frf.unbalance_frf`. The window
``[k0, k1)`` is chosen with ``theta[k1] - theta[k0]`` as close to ``2 pi n`` as the sampling
allows. The phasor is the least-squares fit of ``y = Re{Y e^{j theta}} + c`` over the samples
the window holds, at their own angles (:func:`fit`): on uniform samples of whole revolutions
it is the sum above (the basis is orthogonal there), and on a recording with dropped samples
it stays unbiased where the sum would leak the ``e^{-2 j theta}`` image and the offset.

The angle is taken as given: a continuous shaft angle with its revolutions counted (the
simulator's integrated angle, or :mod:`rotor_avc.analysis.resampling`'s angle from tacho
pulses or an encoder). It is never unwrapped here: across a gap of more than half a revolution
between kept samples, unwrapping would drop revolutions and the speed with them.

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
    #: per channel and window: standard error of each quadrature component of the phasor
    #: (from the fit's residual, divided by ``|unbalance|`` as the phasors are)
    sigma: dict[str, np.ndarray] = field(default_factory=dict)
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


def fit(angle_rad, values) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares ``y = Re{Y e^{j theta}} + c`` over the given samples (``values`` (N,) or
    (N, m)): ``(Y, sigma)``, ``sigma`` the standard error of each quadrature component of ``Y``
    from the residual (white-noise estimate, ``N - 3`` degrees of freedom)."""
    theta = np.asarray(angle_rad, dtype=float)
    y = np.asarray(values, dtype=float)
    basis = np.column_stack([np.cos(theta), np.sin(theta), np.ones_like(theta)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    resid = y - basis @ coef
    s = np.sqrt(np.sum(resid * resid, axis=0) / max(theta.size - 3, 1))
    return coef[0] - 1j * coef[1], s * np.sqrt(2.0 / max(theta.size, 1))


def phasor(angle_rad, values) -> np.ndarray:
    """The 1x phasor ``Y`` of :func:`fit`."""
    return fit(angle_rad, values)[0]


def _inputs(time_s, angle_rad, signals: Mapping, unbalance):
    t = np.asarray(time_s, dtype=float)
    if t.ndim != 1 or t.size < 3 or not np.all(np.diff(t) > 0):
        raise ModelError("order tracking: time_s must be a strictly increasing 1-D array "
                         "of at least 3 samples")
    theta = np.asarray(angle_rad, dtype=float)
    if theta.shape != t.shape or not np.all(np.isfinite(theta)):
        raise ModelError(f"order tracking: angle_rad has shape {np.shape(angle_rad)}, "
                         f"time_s {t.shape}; both need one finite value per sample")
    step = np.diff(theta)
    if np.any(step < -np.pi) and np.median(step) > 0:
        raise ModelError("order tracking: angle_rad jumps back by more than pi while the shaft "
                         "turns forward: it is a wrapped angle; give the continuous angle with "
                         "its revolutions counted (rotor_avc.analysis.resampling)")
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
    names = list(ys)
    y = np.column_stack([ys[name] for name in names])
    phasors, sigma, drift = [], [], []
    for k0, k1, n in windows:
        speeds.append((theta[k1] - theta[k0]) / (t[k1] - t[k0]))
        times.append(0.5 * (t[k0] + t[k1]))
        revs.append(n)
        samples.append(k1 - k0)
        whole, err = fit(theta[k0:k1], y[k0:k1])
        phasors.append(whole / u)
        sigma.append(err / abs(u))
        half = n // 2
        if half < 1:
            drift.append(np.full(len(names), np.nan))
            continue
        km = int(np.searchsorted(theta[k0:k1], theta[k0] + TWO_PI * half)) + k0
        k2 = int(np.searchsorted(theta[k0:k1], theta[k1] - TWO_PI * half)) + k0
        first, last = fit(theta[k0:km], y[k0:km])[0], fit(theta[k2:k1], y[k2:k1])[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            drift.append(np.where(whole != 0, np.abs(last - first) / np.abs(whole), np.nan))
    phasors, sigma, drift = (np.array(a).reshape(len(windows), len(names))
                             for a in (phasors, sigma, drift))
    return OrderTrack(np.array(speeds), np.array(times),
                      {name: phasors[:, i].astype(complex) for i, name in enumerate(names)},
                      np.array(revs, int), np.array(samples, int), u,
                      sigma={name: sigma[:, i].astype(float) for i, name in enumerate(names)},
                      drift={name: drift[:, i].astype(float) for i, name in enumerate(names)})


def concatenate(tracks: list[OrderTrack]) -> OrderTrack:
    """One track of the windows of several (of the same channels and unbalance), in order."""
    first = tracks[0]
    return OrderTrack(
        np.concatenate([t.speed_rad_s for t in tracks]), np.concatenate([t.time_s for t in tracks]),
        {n: np.concatenate([t.phasors[n] for t in tracks]) for n in first.phasors},
        np.concatenate([t.revolutions for t in tracks]),
        np.concatenate([t.samples for t in tracks]),
        first.unbalance,
        sigma={n: np.concatenate([t.sigma[n] for t in tracks]) for n in first.sigma},
        drift={n: np.concatenate([t.drift[n] for t in tracks]) for n in first.drift})


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


@dataclass(frozen=True)
class ShaftAngle:
    """A continuous shaft angle with its revolutions counted, as knots ``(time s, angle rad)``
    increasing in both (tacho pulses at ``2 pi k``, or an encoder's samples), linear between
    them: the angle at any time, and the time of any angle."""

    knots_s: np.ndarray
    knots_rad: np.ndarray

    def angle(self, time_s) -> np.ndarray:
        return np.interp(time_s, self.knots_s, self.knots_rad)

    def time(self, angle_rad) -> np.ndarray:
        return np.interp(angle_rad, self.knots_rad, self.knots_s)


def check_unbalance(unbalance) -> complex:
    """The run's complex unbalance amplitude, refused when zero or not finite."""
    u = complex(unbalance)
    if u == 0 or not np.isfinite(u):
        raise ModelError(f"order tracking: the run's unbalance amplitude is {u}; "
                         "give the (non-zero) complex unbalance the run was excited with")
    return u


def window_fit(shaft: ShaftAngle, t, y, n: int) -> tuple[complex, float, float]:
    """``(phasor, sigma, drift)`` of one channel's samples ``(t, y)`` over a window of ``n``
    whole revolutions, at the shaft angle of their own stamps (:func:`fit`, :func:`_drift`;
    not yet divided by the unbalance)."""
    theta = shaft.angle(t)
    whole, err = fit(theta, y)
    return complex(whole), float(err), _drift(theta, y, whole, n // 2)


def _window_row(shaft: ShaftAngle, t0: float, t1: float, n: int, channels: Mapping):
    """One window's ``(speed, time, n, samples, phasors, sigmas, drifts)`` of channels on
    one time base (:func:`track_from_rows`)."""
    cuts = {name: np.searchsorted(t, [t0, t1]) for name, (t, _) in channels.items()}
    fits = [window_fit(shaft, channels[name][0][i:j], channels[name][1][i:j], n)
            for name, (i, j) in cuts.items()]
    phasors, sigmas, drifts = (list(c) for c in zip(*fits))
    return (TWO_PI * n / (t1 - t0), 0.5 * (t0 + t1), n, min(j - i for i, j in cuts.values()),
            phasors, sigmas, drifts)


def track_from_rows(rows, names, u: complex) -> OrderTrack:
    """The track of window rows ``(speed, time, n, samples, phasors, sigmas, drifts)``."""
    speed, time, revs, samples, phasors, sigmas, drifts = (list(c) for c in zip(*rows))
    phasors = np.array(phasors, complex) / u
    sigmas = np.array(sigmas, float) / abs(u)
    drifts = np.array(drifts, float)
    return OrderTrack(np.array(speed), np.array(time),
                      {name: phasors[:, i] for i, name in enumerate(names)},
                      np.array(revs, int), np.array(samples, int), u,
                      sigma={name: sigmas[:, i] for i, name in enumerate(names)},
                      drift={name: drifts[:, i] for i, name in enumerate(names)})


def _drift(theta, y, whole, half: int) -> float:
    """|Y(last ``half`` revolutions) - Y(first ``half``)| / |Y| (NaN below 2 revolutions)."""
    if half < 1 or whole == 0:
        return float("nan")
    first = theta < theta[0] + TWO_PI * half
    last = theta >= theta[-1] - TWO_PI * half
    if first.sum() < 4 or last.sum() < 4:
        return float("nan")
    return float(abs(fit(theta[last], y[last])[0] - fit(theta[first], y[first])[0]) / abs(whole))


def run_up_stream(blocks, names, unbalance=1.0, *, revolutions: int = 8) -> OrderTrack:
    """1x phasors of a run-up or run-down over consecutive windows of ``revolutions`` whole
    revolutions, from blocks of samples as they come (``(time_s, angle_rad, speed_rad_s,
    channels, ...)`` each; samples at zero or negative speed are skipped): a window is fitted
    (:func:`window_fit`) as soon as the angle passes its end, and only the samples of the
    window under way are kept, so the memory is one window and one block whatever the run's
    length. The first window starts at the first turning sample."""
    if revolutions < 1:
        raise ModelError("order tracking: revolutions per window must be >= 1")
    span = TWO_PI * revolutions
    u = check_unbalance(unbalance)
    buf_t, buf_theta, buf_y = np.zeros(0), np.zeros(0), np.zeros((0, len(names)))
    mark, rows = None, []
    for block in blocks:
        t, theta, w, channels = block[:4]
        turning = np.asarray(w) > 0
        if not turning.any():
            continue
        buf_t = np.concatenate([buf_t, np.asarray(t)[turning]])
        buf_theta = np.concatenate([buf_theta, np.asarray(theta)[turning]])
        buf_y = np.concatenate([buf_y, np.column_stack([np.asarray(channels[n])[turning]
                                                         for n in names])])
        if not np.all(np.diff(buf_theta) > 0):
            raise ModelError("order tracking: the shaft angle must increase (positive speed) "
                             "over the whole run-up; cut the record to the rotating part")
        mark = buf_theta[0] if mark is None else mark
        while buf_theta[-1] >= mark + span:
            shaft = ShaftAngle(buf_t, buf_theta)
            t0, t1 = float(shaft.time(mark)), float(shaft.time(mark + span))
            rows.append(_window_row(shaft, t0, t1, revolutions,
                                    {n: (buf_t, buf_y[:, i]) for i, n in enumerate(names)}))
            keep = max(int(np.searchsorted(buf_t, t1)) - 1, 0)   # the sample before t1 too
            buf_t, buf_theta, buf_y = buf_t[keep:], buf_theta[keep:], buf_y[keep:]
            mark += span
    if not rows:
        raise ModelError(f"order tracking: the record covers fewer than {revolutions} "
                         "revolutions; use fewer revolutions per window")
    return track_from_rows(rows, list(names), u)
