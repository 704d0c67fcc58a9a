"""Loop timing statistics every node reports on ``/diagnostics`` (free of ROS).

Per window: the period between loop iterations (mean, standard deviation), the execution time of
an iteration (mean, 99th percentile, maximum) and the overruns (iterations whose period exceeded
the nominal period by more than ``overrun_tolerance``). Samples are kept in fixed-size ring
buffers, so the cost per iteration is two float stores. :class:`Schedule` is the real-time
plant's absolute schedule and its lateness statistics.
"""
from __future__ import annotations

import time

import numpy as np


class LoopTiming:
    """Collects ``start()``/``stop()`` pairs of a periodic loop (wall clock)."""

    def __init__(self, nominal_period_s: float | None, window: int = 20000,
                 overrun_tolerance: float = 0.5):
        self.nominal = nominal_period_s
        self.tolerance = overrun_tolerance
        self._period = np.zeros(window)
        self._exec = np.zeros(window)
        self._n = 0
        self._np = 0
        self._last_start = None
        self._t0 = 0.0
        self.overruns = 0
        self.iterations = 0

    def start(self) -> None:
        now = time.perf_counter()
        if self._last_start is not None:
            period = now - self._last_start
            self._period[self._np % self._period.size] = period
            self._np += 1
            if self.nominal and period > self.nominal * (1 + self.tolerance):
                self.overruns += 1
        self._last_start = now
        self._t0 = now

    def stop(self) -> None:
        self._exec[self._n % self._exec.size] = time.perf_counter() - self._t0
        self._n += 1
        self.iterations += 1

    def summary(self) -> dict[str, float]:
        """Statistics over the last window (seconds)."""
        n = min(self._n, self._exec.size)
        if n == 0:
            return {"iterations": 0}
        ex = self._exec[:n]
        out = {"iterations": self.iterations, "exec_mean_s": float(ex.mean()),
               "exec_p99_s": float(np.percentile(ex, 99)), "exec_max_s": float(ex.max()),
               "overruns": self.overruns}
        m = min(self._np, self._period.size)
        if m:
            per = self._period[:m]
            out["period_mean_s"] = float(per.mean())
            out["period_std_s"] = float(per.std())
        if self.nominal:
            out["period_nominal_s"] = self.nominal
        return out


class Schedule:
    """An absolute sampling schedule: sample ``k`` is due at ``t0 + k T`` (wall clock), so no
    error accumulates however late single ticks are -- a late sample is taken at once (the
    samples after it catch up), never skipped and never shifting the later ones.

    Per sample it records the lateness (time taken - time due); an *overrun* is a sample taken
    more than one period late. :meth:`summary` gives the lateness percentiles, the overruns
    per 10,000 samples and the mean period between the first and the last sample taken."""

    def __init__(self, period_s: float, window: int = 100_000):
        self.period = period_s
        self._late = np.zeros(window)
        self.n = 0
        self.overruns = 0
        self.t0 = None
        self.first = self.last = None

    def begin(self, now: float) -> None:
        self.t0 = now

    def due(self, k: int) -> float:
        return self.t0 + k * self.period

    def record(self, k: int, now: float) -> None:
        late = now - self.due(k)
        self._late[self.n % self._late.size] = late
        self.n += 1
        if late > self.period:
            self.overruns += 1
        if self.first is None:
            self.first = (k, now)
        self.last = (k, now)

    def mean_period(self) -> float | None:
        if self.first is None or self.last[0] == self.first[0]:
            return None
        return (self.last[1] - self.first[1]) / (self.last[0] - self.first[0])

    def summary(self) -> dict[str, float]:
        m = min(self.n, self._late.size)
        if m == 0:
            return {"samples": 0}
        late = self._late[:m]
        p50, p99 = np.percentile(late, [50, 99])
        out = {"samples": self.n, "late_p50_s": float(p50), "late_p99_s": float(p99),
               "late_max_s": float(late.max()), "overruns": self.overruns,
               "overruns_per_10k": 1e4 * self.overruns / self.n,
               "period_nominal_s": self.period}
        mean = self.mean_period()
        if mean is not None:
            out["period_mean_s"] = mean
            out["period_error"] = mean / self.period - 1.0
        return out
