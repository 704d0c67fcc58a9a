"""Influence coefficients of a machine model: 1x responses per unit unbalance over speed.

For the balancer on a LinearPlant: the synchronous response of a channel ``c`` at speed
``Omega`` and angular acceleration ``Omega'`` is, quasi-steadily,
``y_c = Re{sum_k A_ck(Omega, Omega') u_k e^{j theta}}`` with the closed-loop responses of
:func:`rotor_avc.closed_loop.frf.unbalance_frf` (``Omega'`` enters through the tangential ``-j Omega'``
part of the excitation phasor, so ``A = A0 + Omega' A1`` exactly). Both are tabulated once on a
speed grid and interpolated linearly (rotor_avc.closed_loop.speed_table; the grid step is chosen
well below the half-power bandwidth of the lightest-damped mode).

Channels are named like the plant's outputs; an actuator id (``DL``) stands for the vertical
acceleration of that machine foot (its sensor row, second derivative), the signal the balancer
node receives (``foot/<id>/acceleration``).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..closed_loop.loop import ClosedLoop
from ..closed_loop.frf import unbalance_frf
from ..closed_loop.speed_table import SpeedTable
from ..errors import ModelError
from ..models.plant import Output

EXCITATIONS = ("static", "moment")


def channel_outputs(loop: ClosedLoop, channels) -> tuple[Output, ...]:
    """The plant outputs behind channel names (actuator ids -> foot accelerations)."""
    plant = loop.plant
    ids = [a.id for a in plant.actuators]
    outs = []
    for name in channels:
        if name in ids:
            outs.append(Output(f"foot_{name}_az", plant.actuator(name).sensor_row, 2, "m/s^2"))
        else:
            try:
                outs.append(plant.output(name))
            except ModelError:
                raise ModelError(
                    f"unknown signal {name!r}: use a foot with an actuator ({', '.join(ids) or 'none'}) "
                    "or one of the plant outputs (" + ", ".join(o.name for o in plant.outputs)
                    + ")") from None
    if not outs:
        raise ModelError("the balancer needs at least one signal")
    return tuple(outs)


@dataclass(frozen=True)
class InfluenceTable:
    """``A(Omega, Omega') = base + Omega' * tangential`` on a speed grid; shape (N, C, 2)."""

    speeds_rad_s: np.ndarray
    channels: tuple[str, ...]
    units: tuple[str, ...]
    base: np.ndarray
    tangential: np.ndarray

    def __post_init__(self):
        s = self.speeds_rad_s
        if s.ndim != 1 or s.size < 2:
            raise ModelError("the influence table needs a speed grid of >= 2 speeds")
        object.__setattr__(self, "_table", SpeedTable(s, np.stack([self.base, self.tangential])
                                                      .swapaxes(0, 1)))

    def at(self, speed_rad_s: float, accel_rad_s2: float = 0.0) -> np.ndarray:
        """``(C, 2)`` coefficients (columns static, moment) at one speed; outside the grid an
        error (the balancer holds below the grid, see the estimator)."""
        A0, A1 = self._table.at(speed_rad_s)
        return A0 + accel_rad_s2 * A1

    def covers(self, speed_rad_s: float) -> bool:
        return self._table.covers(speed_rad_s)


def influence_table(loop: ClosedLoop, channels, speeds_rad_s) -> InfluenceTable:
    """Tabulate the channels' responses to static and moment unbalance (batched FRF)."""
    outs = channel_outputs(loop, channels)
    for exc in EXCITATIONS:
        loop.plant.excitation(exc)
    plant = dataclasses.replace(loop.plant, outputs=outs)
    sub = ClosedLoop(plant, loop.controllers)
    speeds = np.asarray(speeds_rad_s, dtype=float)
    r0 = unbalance_frf(sub, speeds, EXCITATIONS)
    r1 = unbalance_frf(sub, speeds, EXCITATIONS, accel_rad_s2=1.0)
    base = np.stack([np.stack([r0.responses[f"{o.name}_{e}"] for e in EXCITATIONS], -1)
                     for o in outs], 1)
    with_accel = np.stack([np.stack([r1.responses[f"{o.name}_{e}"] for e in EXCITATIONS], -1)
                           for o in outs], 1)
    return InfluenceTable(speeds, tuple(channels), tuple(o.unit for o in outs), base,
                          with_accel - base)
