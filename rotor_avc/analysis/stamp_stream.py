"""A channel's stamps checked, cleaned and described chunk by chunk (a recording read in pieces):
what :func:`~rotor_avc.analysis.resampling.usable_samples`,
:func:`~rotor_avc.analysis.resampling.clock_steps`,
:func:`~rotor_avc.analysis.resampling.clean_stamps` and
:func:`~rotor_avc.analysis.resampling.stamp_quality` do for a channel held whole, in the memory
of one chunk.

* values that are not finite or overflow are excluded and counted;
* a clock step is looked for over each chunk with the last
  ``2 CLOCK_STEP_PERSISTENCE`` samples of the one before (a step needs that many samples after
  it, so the candidates near a chunk's end are judged with the next chunk);
* stamps are sorted within a chunk; a stamp at or before the last one kept (repeated, or out of
  order across a chunk boundary) is dropped and counted;
* the median period ``p`` (the rate) is that of the first :data:`MEDIAN_INTERVALS` intervals;
  jitter, dropouts and the longest gap then follow the definitions of ``stamp_quality`` with
  that ``p``.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .resampling import (CLOCK_STEP_PERSISTENCE, GAP_RATIO, StampQuality, clock_steps,
                         usable_samples)

#: stamp intervals whose median is the channel's period
MEDIAN_INTERVALS = 4096


class StampStream:
    """One channel (``name``), chunk by chunk: :meth:`add` returns the chunk's usable samples
    in increasing stamp order; :attr:`excluded`, :attr:`reordered`, :attr:`clock_step` (the
    first ``(log time s, step s)`` found, or None) and :meth:`quality` describe what was
    seen."""

    def __init__(self, name: str):
        self.name = name
        self.excluded = self.reordered = self.samples = 0
        self.clock_step = None
        self.first_s = self.last_s = None
        self._carry = (np.zeros(0), np.zeros(0))        # the last stamps and log times
        self._intervals = []                             # until the period is known
        self.period_s = None
        self._regular = [0, 0.0, 0.0]                    # count, sum, sum of squares (d - p)
        self.dropouts, self.longest_gap_s = 0, 0.0

    def add(self, stamps_s, values, log_s=None) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(stamps_s, dtype=float)
        y = np.asarray(values, dtype=float)
        if log_s is not None and self.clock_step is None:
            self._check_clock(t, np.asarray(log_s, dtype=float))
        ok, excluded = usable_samples(y)
        self.excluded += excluded
        t, y = t[ok], y[ok]
        order = np.argsort(t, kind="stable")
        self.reordered += int(np.count_nonzero(order != np.arange(t.size)))
        t, y = t[order], y[order]
        keep = np.concatenate([[True], np.diff(t) > 0]) if t.size else np.zeros(0, bool)
        if self.last_s is not None:
            keep &= t > self.last_s
        self.reordered += int(np.count_nonzero(~keep))
        t, y = t[keep], y[keep]
        if t.size:
            self._intervals_of(np.diff(t) if self.last_s is None
                               else np.diff(np.concatenate([[self.last_s], t])))
            self.first_s = t[0] if self.first_s is None else self.first_s
            self.last_s = t[-1]
            self.samples += t.size
        return t, y

    def _check_clock(self, t, log) -> None:
        n = CLOCK_STEP_PERSISTENCE
        old_t, old_log = self._carry
        both_t, both_log = np.concatenate([old_t, t]), np.concatenate([old_log, log])
        judged = max(old_t.size - n, 0)      # the carry's last n were waiting for samples after
        for log_s, step_s in clock_steps(both_t, both_log, start=judged,
                                         stop=max(both_t.size - n, judged)):
            self.clock_step = (log_s, step_s)
            break
        self._carry = (both_t[-2 * n:], both_log[-2 * n:])

    def finish_clock(self) -> None:
        """Judge the last samples' candidates (at the end of the channel)."""
        if self.clock_step is None and self._carry[0].size:
            t, log = self._carry
            steps = clock_steps(t, log, start=max(t.size - CLOCK_STEP_PERSISTENCE, 0))
            self.clock_step = steps[0] if steps else None

    def _intervals_of(self, d: np.ndarray) -> None:
        if self.period_s is None:
            self._intervals.append(d)
            pending = np.concatenate(self._intervals)
            if pending.size < MEDIAN_INTERVALS:
                return
            self.period_s = float(np.median(pending[:MEDIAN_INTERVALS]))
            self._intervals, d = [], pending
        p = self.period_s
        gaps = d >= GAP_RATIO * p
        regular = d[~gaps] - p
        self._regular[0] += regular.size
        self._regular[1] += float(regular.sum())
        self._regular[2] += float(np.dot(regular, regular))
        self.dropouts += int(np.sum(np.round(d[gaps] / p) - 1))
        if gaps.any():
            self.longest_gap_s = max(self.longest_gap_s, float(d[gaps].max()))

    def quality(self) -> StampQuality:
        if self.samples < 3:
            raise ModelError(f"{self.name}: {self.samples} samples; a channel needs at least 3")
        if self.period_s is None:                 # fewer intervals than MEDIAN_INTERVALS
            pending = np.concatenate(self._intervals)
            self.period_s = float(np.median(pending))
            self._intervals = []
            self._intervals_of(pending)
        n, total, squares = self._regular
        jitter = float(np.sqrt(max(squares / n - (total / n) ** 2, 0.0))) if n else 0.0
        return StampQuality(self.name, self.samples, 1.0 / self.period_s, jitter,
                            self.dropouts, self.longest_gap_s, self.reordered)
