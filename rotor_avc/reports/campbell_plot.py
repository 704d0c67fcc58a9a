"""Campbell diagram as a PNG: mode frequencies over speed coloured by damping and drawn by whirl
direction at the reference speed (forward solid, backward dashed, none dotted), the excitation
lines ``f = k n`` (clipped to the frequency axis), critical speeds and the onsets of
instability. The frequency axis covers the modes of interest (:func:`frequency_top`)."""
from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from ..analysis.campbell import CampbellDiagram
from ..output_files import save_figure

#: ``--colour`` -> (axis label, ``CampbellDiagram -> (speeds, modes)`` values)
COLOUR_BY = {
    "damping-ratio": ("damping ratio zeta [-]", lambda cd: cd.damping_ratio),
    "log-decrement": ("logarithmic decrement [-]", lambda cd: cd.log_decrement),
}


#: whirl at the reference speed -> (matplotlib line style, plotly dash)
WHIRL_STYLE = {"forward": ("solid", "solid"), "backward": ("dashed", "dash"),
               "none": ("dotted", "dot")}


def frequency_top(cd: CampbellDiagram, max_freq_hz: float | None = None) -> float:
    """Top of the frequency axis in Hz: ``max_freq_hz`` if given, else 1.2 x the highest
    frequency of the modes that lie in the speed range somewhere (frequency <= the highest
    rotor speed: the modes the 1x line can meet), else 1.1 x the highest speed. The order lines
    are clipped to it instead of stretching it."""
    if max_freq_hz is not None:
        return float(max_freq_hz)
    f = cd.freq_hz
    s_max = float(cd.speed_hz[-1])
    inside = (f.min(axis=0) <= s_max) & (f.max(axis=0) > 0)
    return 1.2 * float(f[:, inside].max()) if inside.any() else 1.1 * max(s_max, 1e-9)


def order_line(cd: CampbellDiagram, order: int, top_hz: float) -> tuple[list[float], list[float]]:
    """``(speed_hz, freq_hz)`` end points of the line ``f = order x s`` clipped at ``top_hz``."""
    s0, s1 = float(cd.speed_hz[0]), min(float(cd.speed_hz[-1]), top_hz / order)
    return ([s0, s1], [order * s0, order * s1]) if s1 > s0 else ([], [])


def speed_axis(unit: str) -> tuple[float, str]:
    """``rpm`` or ``hz`` -> (factor from Hz, axis label)."""
    return (60.0, "rotor speed [rpm]") if unit == "rpm" else (1.0, "rotor speed [Hz]")


def plot_campbell(cd: CampbellDiagram, path: Path, title: str, colour: str = "damping-ratio",
                  orders=(1, 2), max_freq_hz: float | None = None, speed_unit: str = "hz",
                  reference_speed_hz: float | None = None) -> Path:
    """The PNG; mode legend labels ``mode 3, 15.96 Hz, FW`` (whirl at the grid speed nearest
    ``reference_speed_hz``, default the highest)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    factor, xlabel = speed_axis(speed_unit)
    label, values = COLOUR_BY[colour]
    x = cd.speed_hz * factor
    f, c = cd.freq_hz, values(cd)
    top = frequency_top(cd, max_freq_hz)
    finite = c[np.isfinite(c) & (f > 0) & (f <= top)]
    lo, hi = (float(np.min(finite)), float(np.max(finite))) if finite.size else (0.0, 1.0)
    norm = plt.Normalize(min(lo, 0.0), max(hi, 1e-6))
    fig, ax = plt.subplots(figsize=(10, 5.5))
    ref = cd.reference_index(reference_speed_hz)
    whirl = cd.whirl(ref)
    for k in range(f.shape[1]):
        pts = np.column_stack([x, f[:, k]])
        shown = 0 < f[:, k].min() <= top
        seg = LineCollection(np.stack([pts[:-1], pts[1:]], axis=1), cmap="viridis", norm=norm,
                             lw=2, linestyles=WHIRL_STYLE[whirl[k]][0],
                             label=cd.caption(k, ref) if shown else None)
        seg.set_array(np.nan_to_num(0.5 * (c[:-1, k] + c[1:, k]), posinf=norm.vmax))
        ax.add_collection(seg)
    for order in orders:
        xs, ys = order_line(cd, order, top)
        ax.plot(np.array(xs) * factor, ys, "k--" if order == 1 else "k:", lw=0.9,
                label=f"{order}x")
    crit = [r for r in cd.critical_speeds(orders) if r["order"] * r["speed_hz"] <= top]
    ax.plot([r["speed_hz"] * factor for r in crit], [r["order"] * r["speed_hz"] for r in crit],
            "o", mfc="none", mec="tab:red", ms=7, label="critical speeds")
    for r in cd.instability_onsets():
        ax.axvline(r["speed_hz"] * factor, color="tab:red", lw=1.2,
                   label=f"onset of instability ({r['mode']}, {r['speed_hz'] * factor:.4g})")
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap="viridis"), ax=ax, label=label)
    ax.set_xlim(x[0], x[-1])
    ax.set_ylim(0, top)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("damped natural frequency [Hz]")
    ax.set_title(textwrap.fill(title, 90), fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.22, 1.0), borderaxespad=0)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
