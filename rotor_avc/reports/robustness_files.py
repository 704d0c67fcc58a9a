"""Files of `rotor-avc study robustness`: the summary (JSON and CSV) and the histograms of the
stability margin and the resonance peaks (a maximum at a grid end is counted apart,
:func:`rotor_avc.analysis.robustness.resonance_peak`)."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..analysis.robustness import GRID_END, grid_end_lines
from ..output_files import open_text, write_text
from .panel_grid import panel_grid, save_panels

#: the columns of the quantile table (:func:`rotor_avc.analysis.robustness.summarize`)
STATS = ("mean", "std", "min", "p5", "p50", "p95", "max")


def write_summary(summary: dict, unit_of, folder: Path) -> list[Path]:
    """``summary.json`` (everything) and ``summary.csv``: one row per quantity (``n`` the points
    that have it), then one row per response whose maximum lies at a grid end in ``n`` points
    (the note says which end and what to do)."""
    js = folder / "summary.json"
    write_text(js, json.dumps(summary, indent=1) + "\n")
    path = folder / "summary.csv"
    with open_text(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["quantity", "unit", "n"] + list(STATS) + ["note"])
        for name, m in summary["metrics"].items():
            w.writerow([name, unit_of(name), m["n"]] + [repr(m[s]) for s in STATS] + [""])
        for (name, g), line in zip(summary["grid_end"].items(), grid_end_lines(summary)):
            w.writerow([GRID_END + name, "", g["points"]] + [""] * len(STATS) + [line])
    return [js, path]


def plot_distributions(records: list[dict], summary: dict, unit_of, path: Path) -> Path:
    """Histograms of the stability margin and of every resonance peak (5/50/95 % marked; the
    points whose maximum lies at a grid end counted in the title)."""
    names = ["stability_margin_1_per_s"] + [n for n in summary["metrics"]
                                            if n.startswith("peak_") and "_speed_hz_" not in n]
    fig, axes = panel_grid(len(names), 4, (3.6, 2.8))
    for ax, name in zip(axes, names):
        v = np.array([r[name] for r in records if r[name] is not None], dtype=float)
        ax.hist(v, bins=min(50, max(10, len(v) // 20)), color="tab:blue", alpha=0.8)
        for q in ("p5", "p50", "p95"):
            ax.axvline(summary["metrics"][name][q], color="k", ls=":" if q != "p50" else "-", lw=0.8)
        label = f"peak |{name[5:]}|" if name.startswith("peak_") else name
        ends = summary["grid_end"].get(name[5:], {}).get("points", 0)
        note = f"\n{ends} points: max at the grid end (rising)" if ends else ""
        ax.set_title(f"{label} [{unit_of(name)}]{note}", fontsize=8)
        ax.tick_params(labelsize=7)
    return save_panels(fig, f"{summary['points']} points: P(stable) = "
                            f"{summary['stability_probability']:.3f}; lines: 5 / 50 / 95 % "
                            "quantiles", path)
