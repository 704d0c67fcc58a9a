"""The run-up a machine balancer is tried on: constant acceleration with a known unbalance (the
quasi-steady run of :mod:`.quasi_steady` and the time-domain run of :mod:`.time_domain_runup`)."""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import ModelError


@dataclass(frozen=True)
class MachineRunup:
    """Constant-acceleration run-up ``speed0 -> stop`` of a machine with a known unbalance."""

    accel_rad_s2: float
    speed0_rad_s: float
    stop_rad_s: float
    sample_period_s: float
    unbalance: tuple[complex, complex]        # (u_e [kg m], u_alpha [kg m^2])
    noise_std: float = 0.0                    # on every balancer signal (channel units)
    seed: int = 0

    def __post_init__(self):
        if not (self.accel_rad_s2 > 0 and self.sample_period_s > 0 and self.noise_std >= 0):
            raise ModelError("run-up acceleration and sample period must be > 0, noise >= 0")
        if not 0 <= self.speed0_rad_s < self.stop_rad_s:
            raise ModelError("run-up needs 0 <= start speed < stop speed")

    @property
    def duration_s(self) -> float:
        return (self.stop_rad_s - self.speed0_rad_s) / self.accel_rad_s2
