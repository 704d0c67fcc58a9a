"""Balancer actuator: a correction that moves linearly, rate-limited, towards its target.

The paper's balancer moves "as a linear function" over 0.2 s (Zhou & Shi 2001 section 3). A new target
starts a straight move from the current position; its duration is the longer of the configured
move time and ``distance / max_rate``. The position is a complex number in the balancer's own
coordinates (``w_x + i w_z`` [m] for the Zhou & Shi 2001 rotor, mass-radius [kg m] for Werner 2021); a
target beyond ``max_radius`` is scaled back onto it (saturation is reported). The move's own
inertial forces (``w'``, ``w''``) are neglected, as in the paper ("slow movement").
"""
from __future__ import annotations

import math

from ..errors import ModelError


class BalancerActuator:
    """Block with explicit state: ``reset()``, ``command(target, t)``, ``position(t)``."""

    def __init__(self, move_time_s: float = 0.0, max_rate: float | None = None,
                 max_radius: float | None = None, initial: complex = 0j):
        if not (math.isfinite(move_time_s) and move_time_s >= 0):
            raise ModelError(f"balancer move time must be >= 0 s (got {move_time_s})")
        if max_rate is not None and not (math.isfinite(max_rate) and max_rate > 0):
            raise ModelError(f"balancer max rate must be > 0 (got {max_rate})")
        if max_radius is not None and not (math.isfinite(max_radius) and max_radius > 0):
            raise ModelError(f"balancer max radius must be > 0 (got {max_radius})")
        if move_time_s == 0 and max_rate is None:
            raise ModelError("the balancer needs a move time or a max rate (it cannot jump)")
        self.move_time_s = float(move_time_s)
        self.max_rate = max_rate
        self.max_radius = max_radius
        self.initial = complex(initial)
        self.reset()

    def reset(self) -> None:
        self._start = self._end = self.clip(self.initial)[0]
        self._t0 = 0.0
        self._duration = 0.0
        self.saturated = False

    def clip(self, target: complex) -> tuple[complex, bool]:
        if self.max_radius is not None and abs(target) > self.max_radius:
            return target * (self.max_radius / abs(target)), True
        return target, False

    @property
    def target(self) -> complex:
        return self._end

    def command(self, target: complex, t: float) -> None:
        """Start a straight move from the position at ``t`` to ``target``."""
        target = complex(target)
        if not (math.isfinite(target.real) and math.isfinite(target.imag)):
            raise ModelError(f"balancer target must be finite (got {target})")
        target, self.saturated = self.clip(target)
        if target == self._end:
            return
        start = self.position(t)
        dist = abs(target - start)
        duration = self.move_time_s
        if self.max_rate is not None:
            duration = max(duration, dist / self.max_rate)
        self._start, self._end, self._t0, self._duration = start, target, float(t), duration

    def position(self, t: float) -> complex:
        if self._duration <= 0 or t >= self._t0 + self._duration:
            return self._end
        if t <= self._t0:
            return self._start
        frac = (t - self._t0) / self._duration
        return self._start + frac * (self._end - self._start)

    def moving(self, t: float) -> bool:
        return self._t0 <= t < self._t0 + self._duration
