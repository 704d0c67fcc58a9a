"""The adaptive harmonic controller's settings (:class:`HarmonicSettings`, the config keys of
:mod:`rotor_avc.harmonic.config`), checked in one place; the block that runs them is
:mod:`rotor_avc.harmonic.block`."""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ModelError
from .laws import check_law
from .supervisor import SupervisorSettings

FALLBACKS = ("freeze", "fade")
ADAPT_IN = ("forces", "excitations")


@dataclass(frozen=True)
class HarmonicSettings:
    """The controller's settings (the config keys of :mod:`rotor_avc.harmonic.config`)."""

    law: str = "newton"
    gain: float = 0.5
    adapt_in: str = "forces"
    refresh_samples: int = 0
    #: optional gain schedule: the gain of the nearest (log-speed) node replaces ``gain``
    gain_speeds_rad_s: tuple[float, ...] = ()
    gain_values: tuple[float, ...] = ()
    effort_weight: float = 0.0
    leakage: float = 0.0
    sensor_weights: tuple[float, ...] | None = None
    update_every_samples: int = 0                 # 0: once per revolution
    force_limit_n: float = math.inf
    rate_limit_n_per_s: float = math.inf
    min_speed_hz: float = 2.0
    start_s: float = 0.0
    identify: bool = False
    forgetting: float = 0.98
    dither_n: float = 0.0
    min_change_n: float = 1e-3
    min_rel_change: float = 0.1
    seed: int = 0
    fallback: str = "fade"
    divergence_factor: float = 100.0
    poor_residual: float = math.inf
    patience: int = 3
    fade_updates: int = 10
    supervisor: SupervisorSettings = SupervisorSettings()

    def check(self) -> None:
        """ModelError naming the first setting out of range."""
        check_law(self.law, self.gain, self.effort_weight, self.leakage)
        if len(self.gain_speeds_rad_s) != len(self.gain_values) or any(
                not (v > 0 and math.isfinite(v))
                for v in self.gain_speeds_rad_s + self.gain_values):
            raise ModelError("the gain schedule needs as many speeds as gains, all > 0")
        if self.adapt_in not in ADAPT_IN:
            raise ModelError(f"unknown adapt_in {self.adapt_in!r}; use one of {ADAPT_IN}")
        if self.fallback not in FALLBACKS:
            raise ModelError(f"unknown fallback {self.fallback!r}; use one of {FALLBACKS}")
        for name in ("force_limit_n", "rate_limit_n_per_s", "divergence_factor", "min_change_n",
                     "poor_residual"):
            if not getattr(self, name) > 0:
                raise ModelError(f"{name} must be > 0 (got {getattr(self, name)})")
        if not (self.min_speed_hz > 0 and self.start_s >= 0 and self.dither_n >= 0):
            raise ModelError("min_speed_hz must be > 0, start_s and dither_n >= 0")
        if not 0 <= self.min_rel_change < 1:
            raise ModelError(f"min_rel_change must lie in [0, 1) (got {self.min_rel_change})")
        if not 0 < self.forgetting <= 1:
            raise ModelError(f"forgetting must lie in (0, 1] (got {self.forgetting})")
        for name in ("update_every_samples", "refresh_samples", "patience", "fade_updates",
                     "seed"):
            v = getattr(self, name)
            low = 1 if name in ("patience", "fade_updates") else 0
            if isinstance(v, bool) or not isinstance(v, int) or v < low:
                raise ModelError(f"{name} must be an integer >= {low} (got {v!r})")
