"""1x order tracking over windows that the shaft defines, of channels each sampled at its own
stamps (a recording of a real machine: per-sensor rates, gaps), read whole or chunk by chunk.

A window ``(t0, t1, n)`` holds ``n`` whole revolutions of the shaft angle
(:class:`~rotor_avc.analysis.order_tracking.ShaftAngle`: tacho pulses with their revolutions
counted, or an encoder): the second half of a constant-speed dwell (:func:`dwell_windows`) or
one of consecutive windows of a run-up (:func:`revolution_windows`). Each channel's samples
inside it are fitted at the shaft angle of their own stamps
(:func:`~rotor_avc.analysis.order_tracking.window_fit`: least squares on the samples actually
there, so gaps cost samples, never revolutions); the speed is ``2 pi n / (t1 - t0)``.

:class:`WindowFits` takes one channel's samples chunk by chunk, in stamp order, and fits each
window as soon as a sample at or after its end arrives, keeping only the samples of the window
under way: memory of one window and one chunk, whatever the recording's length.
:func:`track_windows` is the same for channels held whole.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from ..errors import ModelError
from .order_tracking import (TWO_PI, OrderTrack, ShaftAngle, check_unbalance, track_from_rows,
                             window_fit)

#: fewer samples than this per revolution (of a channel, in a window): the window is left out
MIN_SAMPLES_PER_REVOLUTION = 4.0


def dwell_windows(shaft: ShaftAngle, dwells_s, settle_fraction: float = 0.5,
                  min_revolutions: int = 4) -> list[tuple[float, float, int]]:
    """``(t0, t1, n)`` per constant-speed dwell ``(start s, end s)``: the whole revolutions
    ending at the dwell's end, after its first ``settle_fraction``, when at least
    ``min_revolutions``."""
    out = []
    for a, b in dwells_s:
        first = a + settle_fraction * (b - a)
        end = float(shaft.angle(b))
        n = int(np.floor((end - float(shaft.angle(first))) / TWO_PI + 1e-9))
        if n >= min_revolutions:
            out.append((float(shaft.time(end - TWO_PI * n)), float(b), n))
    return out


def revolution_windows(shaft: ShaftAngle, start_s: float, stop_s: float,
                       revolutions: int) -> list[tuple[float, float, int]]:
    """Consecutive windows of ``revolutions`` whole revolutions from ``start_s`` to ``stop_s``
    (a run-up or run-down at positive speed)."""
    if revolutions < 1:
        raise ModelError("order tracking: revolutions per window must be >= 1")
    a0, a1 = float(shaft.angle(start_s)), float(shaft.angle(stop_s))
    marks = a0 + TWO_PI * revolutions * np.arange(int((a1 - a0) / (TWO_PI * revolutions)) + 1)
    times = shaft.time(marks)
    return [(float(t0), float(t1), revolutions) for t0, t1 in zip(times[:-1], times[1:])]


class WindowFits:
    """One channel's 1x fits over ``windows`` (in time order, not overlapping), from its
    samples given chunk by chunk in increasing stamp order (:meth:`add`). After
    :meth:`close`, ``fits[i]`` is window ``i``'s ``(samples, phasor, sigma, drift)`` -- phasor,
    sigma and drift None when it has fewer than ``min_samples_per_revolution`` samples per
    revolution -- or None when the channel ended before the window did."""

    def __init__(self, shaft: ShaftAngle, windows,
                 min_samples_per_revolution: float = MIN_SAMPLES_PER_REVOLUTION):
        self.shaft, self.windows = shaft, list(windows)
        self.min_per_rev = min_samples_per_revolution
        self.fits: list = []
        self.t, self.y = np.zeros(0), np.zeros(0)

    def add(self, stamps_s, values) -> None:
        if len(self.fits) == len(self.windows) or not len(stamps_s):
            return
        self.t = np.concatenate([self.t, np.asarray(stamps_s, dtype=float)])
        self.y = np.concatenate([self.y, np.asarray(values, dtype=float)])
        while len(self.fits) < len(self.windows) and self.t[-1] >= self.windows[len(self.fits)][1]:
            t0, t1, n = self.windows[len(self.fits)]
            i, j = np.searchsorted(self.t, [t0, t1])
            if j - i >= self.min_per_rev * n:
                self.fits.append((int(j - i), *window_fit(self.shaft, self.t[i:j],
                                                          self.y[i:j], n)))
            else:
                self.fits.append((int(j - i), None, None, None))
        start = (self.windows[len(self.fits)][0] if len(self.fits) < len(self.windows)
                 else np.inf)
        keep = int(np.searchsorted(self.t, start))
        self.t, self.y = self.t[keep:], self.y[keep:]

    def close(self) -> list:
        self.fits += [None] * (len(self.windows) - len(self.fits))
        self.t, self.y = np.zeros(0), np.zeros(0)
        return self.fits


def assemble(windows, fits: Mapping, unbalance=1.0, *,
             min_samples_per_revolution: float = MIN_SAMPLES_PER_REVOLUTION
             ) -> tuple[OrderTrack, list[str]]:
    """The track of the windows every channel fitted (``fits``: name -> :attr:`WindowFits.fits`)
    and a note per window left out: ``(track, notes)``."""
    u = check_unbalance(unbalance)
    rows, notes = [], []
    for k, (t0, t1, n) in enumerate(windows):
        ended = [name for name, f in fits.items() if f[k] is None]
        short = [name for name, f in fits.items() if f[k] is not None and f[k][1] is None]
        if ended:
            notes.append(f"1x window {t0:.4g}-{t1:.4g} s left out: " + ", ".join(ended)
                         + " end before it does")
        elif short:
            notes.append(f"1x window {t0:.4g}-{t1:.4g} s left out: " + ", ".join(short)
                         + f" have fewer than {min_samples_per_revolution:g} samples per "
                         "revolution there")
        else:
            parts = [fits[name][k] for name in fits]
            rows.append((TWO_PI * n / (t1 - t0), 0.5 * (t0 + t1), n, min(p[0] for p in parts),
                         [p[1] for p in parts], [p[2] for p in parts], [p[3] for p in parts]))
    if not rows:
        raise ModelError("order tracking: no window has enough samples of every channel; "
                         "the recording's gaps cover the dwells")
    return track_from_rows(rows, list(fits), u), notes


def track_windows(shaft: ShaftAngle, windows, channels: Mapping, unbalance=1.0, *,
                  min_samples_per_revolution: float = MIN_SAMPLES_PER_REVOLUTION
                  ) -> tuple[OrderTrack, list[str]]:
    """1x phasors over ``windows`` of channels held whole (``channels``: name -> ``(stamps s,
    values)``, gaps allowed): :class:`WindowFits` per channel, :func:`assemble`."""
    fits = {}
    for name, (t, y) in channels.items():
        wf = WindowFits(shaft, windows, min_samples_per_revolution)
        wf.add(t, y)
        fits[name] = wf.close()
    return assemble(windows, fits, unbalance,
                    min_samples_per_revolution=min_samples_per_revolution)
