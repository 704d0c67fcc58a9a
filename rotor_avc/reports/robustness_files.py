"""Files of `rotor-avc study robustness`: the summary (JSON and CSV) and the histograms of the
stability margin and the peak responses."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from ..output_files import open_text, save_figure, write_text

#: the columns of the quantile table (:func:`rotor_avc.analysis.robustness.summarize`)
STATS = ("mean", "std", "min", "p5", "p50", "p95", "max")


def write_summary(summary: dict, unit_of, folder: Path) -> list[Path]:
    """``summary.json`` (everything) and ``summary.csv`` (one row per quantity)."""
    js = folder / "summary.json"
    write_text(js, json.dumps(summary, indent=1) + "\n")
    path = folder / "summary.csv"
    with open_text(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["quantity", "unit"] + list(STATS))
        for name, m in summary["metrics"].items():
            w.writerow([name, unit_of(name)] + [repr(m[s]) for s in STATS])
    return [js, path]


def plot_distributions(records: list[dict], summary: dict, unit_of, path: Path) -> Path:
    """Histograms of the stability margin and of every peak response (5/50/95 % marked)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ["stability_margin_1_per_s"] + [n for n in summary["metrics"]
                                            if n.startswith("peak_") and "_speed_hz_" not in n]
    cols = min(4, len(names))
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 2.8 * rows), squeeze=False)
    for ax, name in zip(axes.flat, names):
        v = np.array([r[name] for r in records], dtype=float)
        ax.hist(v, bins=min(50, max(10, len(v) // 20)), color="tab:blue", alpha=0.8)
        for q in ("p5", "p50", "p95"):
            ax.axvline(summary["metrics"][name][q], color="k", ls=":" if q != "p50" else "-", lw=0.8)
        label = f"peak |{name[5:]}|" if name.startswith("peak_") else name
        ax.set_title(f"{label} [{unit_of(name)}]", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    fig.suptitle(f"{summary['points']} points: P(stable) = {summary['stability_probability']:.3f}; "
                 "lines: 5 / 50 / 95 % quantiles", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
