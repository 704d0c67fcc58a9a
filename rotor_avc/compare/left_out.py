"""The points a comparison left out of its checks, counted and grouped by reason, for the verdict
line and the notes of its report (``PASS, 64 of 126 1x points left out: ...``).

A 1x point is one channel at one measured speed; against the sampled-loop model (the rated one,
:mod:`rotor_avc.compare.checks`) it is left out when its channel is not compared (an input, or a
model response of zero), when the channel recorded nothing where the model responds (dead),
when the 1x phasor still changed within its dwell (not in steady state), when the model lies
more than ``FLOOR_DB`` below the channel's peak there, or when a test force's response adds to
the 1x (a run with a test force rates the broadband FRFs only). A broadband bin of the test band
is left out below the coherence ``MIN_COHERENCE``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .checks import FLOOR_DB, MIN_COHERENCE, SETTLE_TOL

#: rated model
MODEL = "sampled"


@dataclass
class LeftOut:
    """1x points and broadband bins: how many there are, and those left out by reason (reason ->
    ``"channel at f Hz"`` of each 1x point, or ``("channel at f Hz", bins)`` of each dwell)."""

    points: int = 0
    points_left_out: dict[str, list[str]] = field(default_factory=dict)
    bins: int = 0
    bins_left_out: dict[str, list[tuple[str, int]]] = field(default_factory=dict)

    @property
    def n_points(self) -> int:
        return sum(len(v) for v in self.points_left_out.values())

    @property
    def n_bins(self) -> int:
        return sum(n for v in self.bins_left_out.values() for _, n in v)

    def summary(self) -> str:
        """``"64 of 126 1x points left out (40 ..., 24 ...)"`` (empty when none was)."""
        parts = []
        if self.n_points:
            why = ", ".join(f"{len(v)} {r}" for r, v in self.points_left_out.items())
            parts.append(f"{self.n_points} of {self.points} 1x points left out ({why})")
        if self.n_bins:
            why = ", ".join(f"{sum(n for _, n in v)} {r}" for r, v in self.bins_left_out.items())
            parts.append(f"{self.n_bins} of {self.bins} broadband bins left out ({why})")
        return "; ".join(parts)

    def notes(self) -> list[str]:
        """One note per reason, naming the points (by channel, with their speeds)."""
        out = []
        for reason, items in self.points_left_out.items():
            by_channel: dict[str, list[str]] = {}
            for where in items:
                ch, _, at = where.partition(" at ")
                by_channel.setdefault(ch, []).append(at.removesuffix(" Hz"))
            listed = "; ".join(f"{ch} at {', '.join(v)} Hz" for ch, v in by_channel.items())
            n = len(items)
            out.append(f"left out of the 1x checks, {reason} ({n} point{'' if n == 1 else 's'}): "
                       f"{listed}")
        for reason, items in self.bins_left_out.items():
            out.append(f"left out of the broadband checks, {reason}: "
                       + "; ".join(f"{where}: {n} bins" for where, n in items))
        return out


def _one_x(comp, out: LeftOut) -> None:
    one = comp.one_x
    f = one.speed_rad_s / (2 * np.pi)
    out.points = len(one.measured) * f.size
    groups = out.points_left_out
    for ch, c in one.channels[MODEL].items():
        where = [f"{ch} at {v:.4g} Hz" for v in f]
        if "skipped" in c:
            groups.setdefault(f"channel not compared: {c['skipped']}", []).extend(where)
            continue
        if comp.run.has_test_force:
            groups.setdefault("not rated: the test force's response adds to the 1x", []).extend(where)
            continue
        if c["dead"]:
            groups.setdefault("dead channel: no response recorded where the model has one",
                              []).extend(where)
            continue
        for k in range(f.size):
            if c["unsettled"][k]:
                groups.setdefault(f"not in steady state (the 1x phasor changed by more than "
                                  f"{100 * SETTLE_TOL:g} % within its dwell)", []).append(where[k])
            elif np.isnan(c["error_db"][k]):
                groups.setdefault(f"more than {FLOOR_DB:g} dB below the channel's model peak",
                                  []).append(where[k])


def left_out_points(comp) -> LeftOut:
    """The points ``comp`` (a :class:`~rotor_avc.compare.comparison.Comparison`) left out."""
    out = LeftOut()
    if comp.one_x is not None and MODEL in comp.one_x.channels:
        _one_x(comp, out)
    for bb in comp.broadband:
        at = f"{bb.speed_rad_s / (2 * np.pi):.4g} Hz"
        for ch, c in bb.channels[MODEL].items():
            out.bins += c["bins"]
            low = c["bins"] - c["coherent_bins"]
            if low:
                out.bins_left_out.setdefault(f"coherence below {MIN_COHERENCE:g}", []).append(
                    (f"{ch} at {at}", low))
    return out
