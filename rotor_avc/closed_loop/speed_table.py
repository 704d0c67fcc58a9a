"""Quantities tabulated over shaft speed and read between the speeds by linear interpolation:
the influence coefficients of the balancer (responses per unit unbalance,
rotor_avc.balancing.influence), the influence matrices and disturbance model of the harmonic
controller (responses per unit actuator force, rotor_avc.harmonic.influence) and the steady maps
of its internal model -- one table, one interpolation.

``table[s]`` belongs to ``speeds_rad_s[s]`` (ascending); between two speeds the value is
``table[k] + w (table[k + 1] - table[k])``, ``w`` the speed's fraction of the interval. Outside
the speeds a table either refuses (the balancer's, whose estimator holds below its grid) or
returns the value at the nearer end (``clamp``: the harmonic controller's schedule).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError


def interpolate(speeds_rad_s: np.ndarray, table: np.ndarray, speed_rad_s: float) -> np.ndarray:
    """``table`` (first axis over ``speeds_rad_s``, ascending) at one speed, linearly,
    clamped to the ends."""
    sp = speeds_rad_s
    if speed_rad_s <= sp[0]:
        return table[0]
    if speed_rad_s >= sp[-1]:
        return table[-1]
    k = min(int(np.searchsorted(sp, speed_rad_s, side="right")) - 1, sp.size - 2)
    w = (speed_rad_s - sp[k]) / (sp[k + 1] - sp[k])
    return table[k] + w * (table[k + 1] - table[k])


@dataclass(frozen=True, eq=False)
class SpeedTable:
    """``values[s]`` at ``speeds_rad_s[s]`` (ascending, > 0), read at any speed inside (and,
    with ``clamp``, outside: the nearer end's value)."""

    speeds_rad_s: np.ndarray
    values: np.ndarray
    clamp: bool = False

    def __post_init__(self):
        sp = np.asarray(self.speeds_rad_s, dtype=float)
        if sp.ndim != 1 or sp.size < 1 or not np.all(np.isfinite(sp)) or np.any(np.diff(sp) <= 0):
            raise ModelError("a table over speed needs finite speeds in ascending order")
        if self.values.shape[:1] != sp.shape or not np.all(np.isfinite(self.values)):
            raise ModelError(f"a table over {sp.size} speeds needs finite values with that first "
                             f"dimension (got shape {self.values.shape})")
        object.__setattr__(self, "speeds_rad_s", sp)

    def covers(self, speed_rad_s: float) -> bool:
        return bool(self.speeds_rad_s[0] <= speed_rad_s <= self.speeds_rad_s[-1])

    def at(self, speed_rad_s: float) -> np.ndarray:
        if not self.clamp and not self.covers(speed_rad_s):
            s = self.speeds_rad_s
            raise ModelError(f"speed {speed_rad_s:.4g} rad/s is outside the table's "
                             f"[{s[0]:.4g}, {s[-1]:.4g}] rad/s")
        return interpolate(self.speeds_rad_s, self.values, speed_rad_s)
