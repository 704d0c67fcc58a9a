"""Sensor runout: a harmonic disturbance that only the harmonic controller's sensors see.

A proximity probe reads the shaft's surface, not its centre: an out-of-round or scratched
journal adds ``Re{R_h e^{j h theta}}`` to the signal at orders ``h`` of the shaft angle
``theta`` (mechanical and electrical runout, API 670), typically 1x and 2x. In simulation it
stands for any harmonic disturbance at the sensors (a misalignment-like 2x seen at the bearing
housings): :class:`WithRunout` adds it to the signals before the controller block, so the
block must cancel it through the plant (``E_h = R_h + G(h Omega) U_h``; converged,
``U_h = -pinv(G) R_h`` for Newton from zero). The recorded plant channels stay free of it.

In the ``harmonic:`` section::

    runout:                                # optional, one entry per sensor and order
      - {sensor: bearing_D_vz, order: 2, magnitude: 1.0e-4, phase_deg: 30.0}   # sensor's unit
"""
from __future__ import annotations

import math

from ..errors import ModelError

RUNOUT_KEYS = ("sensor", "order", "magnitude", "phase_deg")


class WithRunout:
    """A harmonic controller block whose sensor signals carry runout ``terms``: tuples
    ``(sensor index, order, complex amplitude)``; every other attribute is the block's."""

    def __init__(self, block, terms):
        for i, h, amp in terms:
            if not (0 <= i < len(block.sensors) and h >= 1 and math.isfinite(abs(amp))):
                raise ModelError(f"runout term ({i}, {h}, {amp}) does not fit the block's "
                                 f"{len(block.sensors)} sensors")
        self.block = block
        self.terms = tuple((i, h, complex(amp).real, complex(amp).imag) for i, h, amp in terms)

    def __getattr__(self, name):
        if name == "block":                      # not yet set (copying): no recursion
            raise AttributeError(name)
        return getattr(self.block, name)

    def runout(self, angle: float) -> list[float]:
        """The runout of each sensor at the shaft angle (rad)."""
        out = [0.0] * len(self.block.sensors)
        for i, h, re, im in self.terms:
            out[i] += re * math.cos(h * angle) - im * math.sin(h * angle)
        return out

    def step(self, signals, angle: float, speed: float) -> list[float]:
        seen = [v + r for v, r in zip(signals, self.runout(angle))]
        return self.block.step(seen, angle, speed)

    def describe(self) -> str:
        orders = sorted({h for _, h, _, _ in self.terms})
        return (f"{self.block.describe()}; sensor runout at orders "
                f"{', '.join(f'{h}x' for h in orders)}")


def runout_terms(sec, sensors) -> list[tuple[int, int, complex]]:
    """The ``runout:`` list of a ``harmonic:`` section (ConfigError naming the field)."""
    items = sec.raw("runout", [])
    if not isinstance(items, list):
        raise sec.error("runout", f"must be a list of entries (got {items!r})",
                        fix="write - {sensor: NAME, order: 2, magnitude: 1.0e-4, phase_deg: 0}")
    terms = []
    for n, item in enumerate(items):
        if not isinstance(item, dict):
            raise sec.error(f"runout[{n}]", f"must be a mapping (got {item!r})",
                            fix="give sensor, order, magnitude and phase_deg")
        unknown = sorted(set(item) - set(RUNOUT_KEYS))
        if unknown or "sensor" not in item or "magnitude" not in item:
            raise sec.error(f"runout[{n}]", f"unknown keys {unknown} or sensor/magnitude missing",
                            fix="use the keys " + ", ".join(RUNOUT_KEYS))
        sensor, order = item["sensor"], item.get("order", 1)
        mag, phase = item["magnitude"], item.get("phase_deg", 0.0)
        if sensor not in sensors:
            raise sec.error(f"runout[{n}].sensor", f"{sensor!r} is not a harmonic sensor",
                            fix="use one of: " + ", ".join(sensors))
        if isinstance(order, bool) or not isinstance(order, int) or order < 1:
            raise sec.error(f"runout[{n}].order", f"must be an integer >= 1 (got {order!r})")
        for key, v in (("magnitude", mag), ("phase_deg", phase)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or (key == "magnitude" and v < 0):
                raise sec.error(f"runout[{n}].{key}", f"must be a finite number"
                                f"{' >= 0' if key == 'magnitude' else ''} (got {v!r})")
        terms.append((list(sensors).index(sensor), order,
                      mag * complex(math.cos(math.radians(phase)), math.sin(math.radians(phase)))))
    return terms
