"""Loop timing statistics every node reports on ``/diagnostics`` (free of ROS).

Per window: the period between loop iterations (mean, standard deviation), the execution time of
an iteration (mean, 99th percentile, maximum) and the overruns (iterations whose period exceeded
the nominal period by more than ``overrun_tolerance``). Samples are kept in fixed-size ring
buffers, so the cost per iteration is two float stores.
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
