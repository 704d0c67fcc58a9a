"""Files of `rotor-avc study` (Werner 2019 gain studies): the curves and the per-gain summary (CSV)
and their plots (PNG and an interactive HTML page)."""
from __future__ import annotations

import csv
from pathlib import Path

from ..analysis.gain_study import GainStudy
from ..control.spec import FEEDBACK_ORDER
from ..interactive.page import page_files
from .study_report import write_study_html
from ..output_files import open_text, save_figure


#: paper units for the plots: (mm/s)/um for velocities per metre, N/um for forces per metre
PLOT_SCALE = {"m/s/(m)": (1e-3, "(mm/s)/um"), "N/(m)": (1e-6, "N/um")}


def write_gain_study(study: GainStudy, stem: Path, plots: bool) -> list[Path]:
    """``<stem>_curves.csv`` (amplitude over speed per gain), ``<stem>_summary.csv`` (per gain:
    resonance speeds, heights, reductions, largest actuator forces) and the plots."""
    gname = f"{study.gain_name}_{study.structure}"
    curves = stem.with_name(stem.name + "_curves.csv")
    with open_text(curves, newline="") as fh:
        w = csv.writer(fh)
        cols = [(q, i) for q in study.curves for i in range(len(study.gains))]
        w.writerow(["speed_rpm"] + [f"{q}_{gname}={study.gains[i]:g}" for q, i in cols])
        for k, n in enumerate(study.speed_rpm):
            w.writerow([f"{n:.6g}"] + [f"{study.curves[q][i, k]:.8g}" for q, i in cols])
    summary = stem.with_name(stem.name + "_summary.csv")
    forces = [q for q in study.curves if q.startswith("actuator")]
    with open_text(summary, newline="") as fh:
        w = csv.writer(fh)
        w.writerow([gname] + [f"{r.label}_{c}" for r in study.resonances for c in
                              ("speed_rpm", "amplitude", "reduction_window_pct",
                               "reduction_same_speed_pct")]
                   + [f"{q}_max_{c}" for q in forces for c in ("amplitude", "speed_rpm")])
        for i, gain in enumerate(study.gains):
            row = [f"{gain:g}"]
            for r in study.resonances:
                row += [f"{v:.6g}" for v in (r.speed_rpm[i], r.amplitude[i],
                                              r.reduction_window_pct[i],
                                              r.reduction_same_speed_pct[i])]
            for q in forces:
                force, at = study.max_force(q)
                row += [f"{force[i]:.6g}", f"{at[i]:.6g}"]
            w.writerow(row)
    return [curves, summary] + (plot_gain_study(study, stem) if plots else [])


def plot_gain_study(study: GainStudy, stem: Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    title = f"{study.structure} on {study.feedback} ({study.excitation} excitation)"
    glabel = f"{study.gain_name} [{_gain_unit(study)}]"
    quantities = list(study.curves)
    cols = 3
    rows = -(-len(quantities) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.0 * rows), squeeze=False,
                             sharex=True)
    for ax, q in zip(axes.flat, quantities):
        scale, unit = PLOT_SCALE.get(study.units[q], (1.0, study.units[q]))
        for i, gain in enumerate(study.gains):
            ax.plot(study.speed_rpm, scale * study.curves[q][i], lw=1, label=f"{gain:g}")
        ax.set_title(q, fontsize=9)
        ax.set_ylabel(unit, fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(quantities):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("speed [rpm]")
    axes.flat[0].legend(fontsize=6, title=glabel, title_fontsize=6)
    fig.suptitle(f"Response over speed per gain: {title}", fontsize=10)
    fig.tight_layout()
    paths = [stem.with_name(stem.name + "_curves.png")]
    save_figure(fig, paths[-1], dpi=110)
    plt.close(fig)

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    for r in study.resonances:
        a1.plot(study.gains, r.speed_rpm, "o-", ms=3, label=r.label)
        a2.plot(study.gains, r.reduction_window_pct, "o-", ms=3, label=r.label)
    a1.set_ylabel("resonance speed [rpm]")
    a2.set_ylabel("reduction of the resonance peak [%] (+-window)")
    for ax in (a1, a2):
        ax.set_xlabel(glabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"Resonance shift and reduction: {title}", fontsize=10)
    fig.tight_layout()
    paths.append(stem.with_name(stem.name + "_resonances.png"))
    save_figure(fig, paths[-1], dpi=110)
    plt.close(fig)
    paths += page_files(write_study_html(study, stem.with_name(stem.name + ".html"), glabel))
    return paths


def _gain_unit(study: GainStudy) -> str:
    """SI unit of the swept gain: force per unit of the fed-back signal, times s per integral."""
    order = FEEDBACK_ORDER[study.feedback] + {"ki": -1, "kd": 1}.get(study.gain_name, 0)
    return {-1: "N/(m s)", 0: "N/m", 1: "N s/m", 2: "kg", 3: "kg/s"}.get(order, "SI")
