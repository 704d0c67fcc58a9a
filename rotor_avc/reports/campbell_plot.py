"""Campbell diagram as a PNG: mode frequencies over speed coloured by damping, the excitation
lines ``f = k n``, critical speeds and the onsets of instability."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis.campbell import CampbellDiagram
from ..output_files import save_figure

#: ``--colour`` -> (axis label, ``CampbellDiagram -> (speeds, modes)`` values)
COLOUR_BY = {
    "damping-ratio": ("damping ratio zeta [-]", lambda cd: cd.damping_ratio),
    "log-decrement": ("logarithmic decrement [-]", lambda cd: cd.log_decrement),
}


def speed_axis(unit: str) -> tuple[float, str]:
    """``rpm`` or ``hz`` -> (factor from Hz, axis label)."""
    return (60.0, "rotor speed [rpm]") if unit == "rpm" else (1.0, "rotor speed [Hz]")


def plot_campbell(cd: CampbellDiagram, path: Path, title: str, colour: str = "damping-ratio",
                  orders=(1, 2), max_freq_hz: float | None = None, speed_unit: str = "hz") -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    factor, xlabel = speed_axis(speed_unit)
    label, values = COLOUR_BY[colour]
    x = cd.speed_hz * factor
    f, c = cd.freq_hz, values(cd)
    top = max_freq_hz if max_freq_hz is not None else 1.1 * max(orders) * cd.speed_hz[-1]
    finite = c[np.isfinite(c) & (f <= top)]
    lo, hi = (float(np.min(finite)), float(np.max(finite))) if finite.size else (0.0, 1.0)
    norm = plt.Normalize(min(lo, 0.0), max(hi, 1e-6))
    fig, ax = plt.subplots(figsize=(8, 5.5))
    for k in range(f.shape[1]):
        pts = np.column_stack([x, f[:, k]])
        seg = LineCollection(np.stack([pts[:-1], pts[1:]], axis=1), cmap="viridis", norm=norm, lw=2)
        seg.set_array(np.nan_to_num(0.5 * (c[:-1, k] + c[1:, k]), posinf=norm.vmax))
        ax.add_collection(seg)
    for order in orders:
        ax.plot(x, order * cd.speed_hz, "k--" if order == 1 else "k:", lw=0.9, label=f"{order}x")
    crit = cd.critical_speeds(orders)
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
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
