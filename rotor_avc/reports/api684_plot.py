"""``api684.png`` of `rotor-avc api684`: the API 684 picture of a model's unbalance response.

One panel per response: the amplitude over speed (log scale), the operating speed range shaded,
each critical speed marked with its amplification factor, its half-power band ``N_1 .. N_2``
shaded, and the band the required separation margin keeps free of it (API 617 8th ed.
6.8.2.10, API RP 684 SP6.8.2.10: ``N_min (1 - SM_req)`` .. ``N_min`` below the range,
``N_mc`` .. ``N_mc (1 + SM_req)`` above it). A last panel is the separation-margin chart:
the required margin over ``AF`` (below and above the range), the ``AF = 2.5`` line (critically
damped to its left) and every critical speed's actual margin.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis.api684 import CRITICALLY_DAMPED_AF, required_margin_pct
from .panel_grid import panel_grid, save_panels

VERDICT_COLOURS = {"pass": "tab:green", "critically damped": "tab:blue", "fail": "tab:red",
                   "undetermined": "tab:grey"}


def _response_panel(ax, speed_hz, amplitude, checks, unit: str, name: str, operating_hz) -> None:
    lo, hi = operating_hz
    ax.semilogy(speed_hz, amplitude, color="k", lw=0.9)
    ax.axvspan(lo, hi, color="tab:orange", alpha=0.25, lw=0)
    for c in checks:
        colour = VERDICT_COLOURS[c.verdict]
        if c.n1_hz is not None and c.n2_hz is not None:
            ax.axvspan(c.n1_hz, c.n2_hz, color=colour, alpha=0.2, lw=0)
        if c.required_margin_pct and c.position in ("below", "above"):
            band = ((lo * (1 - c.required_margin_pct / 100), lo) if c.position == "below"
                    else (hi, hi * (1 + c.required_margin_pct / 100)))
            ax.axvspan(*band, facecolor="none", edgecolor=colour, alpha=0.5, hatch="//", lw=0)
        ax.plot(c.speed_hz, c.peak, "o", color=colour, ms=4)
        af = "AF -" if c.amplification_factor is None else f"AF {c.amplification_factor:.2g}"
        ax.annotate(af, (c.speed_hz, c.peak), textcoords="offset points", xytext=(3, 3),
                    fontsize=7, color=colour)
    ax.set_title(name, fontsize=8)
    ax.set_xlabel("speed [Hz]", fontsize=7)
    ax.set_ylabel(f"amplitude [{unit}]", fontsize=7)
    ax.tick_params(labelsize=7)
    ax.grid(True, which="both", alpha=0.2)


def _margin_chart(ax, checks: dict) -> None:
    afs = [c.amplification_factor for rows in checks.values() for c in rows
           if c.amplification_factor is not None]
    af = np.linspace(1.0, max([12.0] + [1.2 * a for a in afs]), 400)
    for position, style in (("below", "-"), ("above", "--")):
        ax.plot(af, [required_margin_pct(a, position) for a in af], "k", ls=style, lw=1,
                label=f"required, critical {position} the range")
    ax.axvline(CRITICALLY_DAMPED_AF, color="tab:blue", lw=1, label="AF = 2.5")
    margins = [40.0]
    for rows in checks.values():
        for c in rows:
            if c.amplification_factor is not None and c.separation_margin_pct is not None:
                ax.plot(c.amplification_factor, c.separation_margin_pct, "o" if
                        c.position == "below" else "s", color=VERDICT_COLOURS[c.verdict], ms=4)
                margins.append(c.separation_margin_pct)
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=30.0)
    ax.set_ylim(-1.0, 1.5 * max(margins))
    ax.set_xlabel("amplification factor AF", fontsize=7)
    ax.set_ylabel("separation margin [%]", fontsize=7)
    ax.set_title("separation margin: actual (o below, s above) vs required", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=6)
    ax.grid(True, which="both", alpha=0.2)


def plot_api684(path: Path, speed_hz, amplitudes: dict, units: dict, checks: dict,
                operating_hz, title: str) -> Path:
    """The picture of the module docstring; ``amplitudes``/``units``/``checks`` keyed by
    response name."""
    names = list(checks)
    fig, axes = panel_grid(len(names) + 1, 3, (4.2, 3.0))
    for ax, name in zip(axes, names):
        _response_panel(ax, speed_hz, amplitudes[name], checks[name], units[name], name,
                        operating_hz)
    _margin_chart(axes[-1], checks)
    return save_panels(fig, f"{title}; shaded: operating range (orange), half-power bands, "
                            "hatched: required separation margin", path, fontsize=9)
