"""The stamps of one measurement stream: in order, not jumping, and the samples that went missing.

A controller steps its filter once per sample ``t_k = k T``; :class:`StampScreen` decides, from
the stamp alone, whether a measurement is the next sample (``ok``), the same sample again
(``repeated``: answer from the cache, do not step twice), an old one (``stale``) or one
stamped more than ``max_jump_s`` after the last accepted one (``future``: a corrupted or
foreign stamp such as 2^31-1 s). A rejected stamp does not move the reference, so the next
good sample is taken at once (one bad stamp costs one sample).

A stream that really restarted or jumped (a plant restarted, a sensor clock re-set) sends
stamps that agree with each other but not with the old reference: after ``resync_samples``
consecutive rejected stamps each within ``max_jump_s`` after the one before, the screen takes the
newest as its reference (``resync``; the caller resets its filter: the state belonged to the
old stream). Nothing latches: the worst a bad stamp does is cost ``resync_samples`` samples.

Samples that never arrived (dropped by the transport, or overwritten in a full queue while
the controller was busy) or were rejected by the caller show as a gap in the accepted stamps: a gap of ``n`` periods counts
``n - 1`` ``dropped`` samples, ``n`` rounded (stamps that jitter by less than a quarter period
count right; a gap below 1.5 periods counts none; a gap beyond ``max_stamp_jump_s`` is a jump,
answered by a resync, not counted).
"""
from __future__ import annotations

import math

from ..errors import ModelError

#: the counters of :attr:`StampScreen.counts`
STAMP_EVENTS = ("repeated", "stale", "future", "resync", "dropped")


class StampScreen:
    """Classifies stamps (ns) of one stream: ``ok``, ``repeated``, ``stale``, ``future`` or
    ``resync`` (module docstring); counts each kind and the dropped samples."""

    __slots__ = ("period_ns", "max_jump_ns", "resync_samples", "last_ns", "counts",
                 "_gap_ns", "_pending", "_pending_ns")

    def __init__(self, sample_period_s: float, max_jump_s: float = 1.0, resync_samples: int = 10):
        if not (math.isfinite(sample_period_s) and sample_period_s > 0):
            raise ModelError(f"sample period must be finite and > 0 (got {sample_period_s})")
        if not (math.isfinite(max_jump_s) and max_jump_s >= sample_period_s):
            raise ModelError(f"max_jump_s must be at least one sample period "
                             f"({sample_period_s:g} s; got {max_jump_s})")
        if isinstance(resync_samples, bool) or not isinstance(resync_samples, int) \
                or resync_samples < 1:
            raise ModelError(f"resync_samples must be an integer >= 1 (got {resync_samples!r})")
        self.period_ns = max(1, round(sample_period_s * 1e9))
        self.max_jump_ns = round(max_jump_s * 1e9)
        self.resync_samples = resync_samples
        self.counts = dict.fromkeys(STAMP_EVENTS, 0)
        self._gap_ns = self.period_ns + self.period_ns // 2
        self.last_ns = -1
        self._pending = 0
        self._pending_ns = 0

    def classify(self, stamp_ns: int) -> str:
        """The verdict on the next measurement's stamp (module docstring)."""
        last = self.last_ns
        if last < 0 or last < stamp_ns <= last + self.max_jump_ns:
            if last >= 0 and stamp_ns - last > self._gap_ns:
                self.counts["dropped"] += (stamp_ns - last + self.period_ns // 2) // self.period_ns - 1
            self.last_ns = stamp_ns
            self._pending = 0
            return "ok"
        if stamp_ns == last:
            self.counts["repeated"] += 1
            return "repeated"
        kind = "stale" if stamp_ns < last else "future"
        self.counts[kind] += 1
        p = self._pending_ns
        self._pending = self._pending + 1 if self._pending and p < stamp_ns <= p + self.max_jump_ns else 1
        self._pending_ns = stamp_ns
        if self._pending >= self.resync_samples:
            self.last_ns = stamp_ns
            self._pending = 0
            self.counts["resync"] += 1
            return "resync"
        return kind
