"""FRF tables and plots: ``frf.csv`` and PNG magnitude/phase plots in dB (Werner 2021 eqs. 52-54)."""
from __future__ import annotations

import csv
from collections import defaultdict
from pathlib import Path

import numpy as np

from ..closed_loop.frf import SpeedFrf
from ..interactive.page import Figure, write_page
from ..output_files import open_text, save_figure


def write_frf_csv(frf: SpeedFrf, path: Path) -> Path:
    """``speed_hz`` then ``<name>_mag`` (SI per unit excitation) and ``<name>_phase_deg``."""
    names = list(frf.responses)
    with open_text(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["speed_hz"] + [f"{n}_{c}" for n in names for c in ("mag", "phase_deg")])
        cols = [frf.speed_hz]
        for n in names:
            v = frf.responses[n]
            cols += [np.abs(v), np.degrees(np.angle(v))]
        for row in np.column_stack(cols):
            w.writerow([f"{x:.10g}" for x in row])
    return path


def _groups(frf: SpeedFrf) -> dict[tuple[str, str], dict[str, list[str]]]:
    """``(kind of point, excitation) -> point -> response keys`` (one per component)."""
    groups: dict[tuple[str, str], dict[str, list[str]]] = defaultdict(lambda: defaultdict(list))
    for key, (quantity, excitation) in frf.parts.items():
        point, _, component = quantity.rpartition("_")
        groups[(point.split("_")[0], excitation)][point].append(key)
    return groups


def plot_frf(frf: SpeedFrf, out_dir: Path, title: str = "", progress=None) -> list[Path]:
    """One PNG per (kind of point, excitation): subplots per point, one curve per component,
    magnitude in dB re 1 SI unit over the rotational frequency, phase below. ``progress``:
    called ``(figures written, figures)`` after each (None: quiet)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths, groups = [], _groups(frf)
    for (kind, excitation), points in groups.items():
        fig, axes = plt.subplots(2, len(points), figsize=(3.6 * len(points) + 1, 6),
                                 sharex=True, squeeze=False)
        for col, (point, keys) in enumerate(points.items()):
            for key in keys:
                comp = frf.parts[key][0].rpartition("_")[2]
                v = frf.responses[key]
                if not np.any(v):
                    continue
                axes[0, col].plot(frf.speed_hz, frf.db(key), lw=1, label=comp)
                axes[1, col].plot(frf.speed_hz, np.degrees(np.angle(v)), lw=0.8, label=comp)
            axes[0, col].set_title(point, fontsize=9)
            axes[1, col].set_xlabel("rotational frequency f_r [Hz]")
            axes[0, col].grid(alpha=0.3)
            axes[1, col].grid(alpha=0.3)
            if axes[0, col].lines:
                axes[0, col].legend(fontsize=7)
        unit = frf.units[next(iter(next(iter(points.values()))))]
        axes[0, 0].set_ylabel(f"dB re 1 {unit}")
        axes[1, 0].set_ylabel("phase [deg]")
        fig.suptitle(f"{title} {kind} response to {excitation} excitation".strip(), fontsize=10)
        fig.tight_layout()
        path = out_dir / f"frf_{kind}_{excitation}.png"
        save_figure(fig, path, dpi=110)
        plt.close(fig)
        paths.append(path)
        if progress is not None:
            progress(len(paths), len(groups))
    return paths


def write_frf_html(frf: SpeedFrf, path: Path, title: str = "") -> Path:
    """``index.html``: the magnitudes of :func:`plot_frf`'s groups, one interactive plot per
    point (a curve per component; dB or SI units and Hz or rpm by the page's selectors)."""
    blocks: list = []
    for (kind, excitation), points in _groups(frf).items():
        blocks.append(f"<h2>{kind} response to {excitation} excitation</h2>")
        for point, keys in points.items():
            traces = [{"type": "scatter", "mode": "lines", "name": frf.parts[key][0]
                       .rpartition("_")[2], "x": frf.speed_hz, "y": np.abs(frf.responses[key])}
                      for key in keys if np.any(frf.responses[key])]
            if traces:
                blocks.append(Figure(f"frf_{point}_{excitation}", f"{point}: {excitation}",
                                     traces, x_title="rotational frequency f_r",
                                     y_title="magnitude per unit excitation",
                                     unit=frf.units[keys[0]], magnitude_key="y"))
    return write_page(path, f"Unbalance FRFs over speed {title}".strip(), blocks)

