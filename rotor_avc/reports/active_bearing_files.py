"""Files of `rotor-avc active-bearing` (Sci. Rep. 2023): the case table, the insertion loss over
speed (CSV), the summary (JSON) and their plots."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..analysis.active_bearing_ff import METHODS
from ..output_files import make_folder, open_text, save_figure, write_text


def write_active_bearing_files(out: Path, sweep, method, alpha, forces_sat, il_sat, piezo, rows, summary) -> None:
    make_folder(out)
    with open_text(out / "cases.csv", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    res = sweep[method]
    cols = {"speed_hz": res.speed_hz, "speed_rpm": 60 * res.speed_hz,
            "force_limit_n": piezo.force_limit_n(res.speed_rad_s), "saturation_alpha": alpha}
    for i, a in enumerate(res.actuator_ids):
        cols[f"force_{a}_n"] = np.abs(res.forces[:, i])
        cols[f"phase_{a}_deg"] = res.force_phase_deg()[:, i]
    shaft = res.outputs("shaft_")
    for m in METHODS:
        il = sweep[m].insertion_loss_db()
        for k in shaft:
            cols[f"il_{m}_{res.output_names[k]}_db"] = il[:, k]
    il_s = res.insertion_loss_db(forces_sat)
    for k in shaft:
        cols[f"il_saturated_{res.output_names[k]}_db"] = il_s[:, k]
    with open_text(out / "il_over_speed.csv", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        for row in np.column_stack(list(cols.values())):
            w.writerow([f"{x:.8g}" for x in row])
    write_text(out / "summary.json", json.dumps(summary, indent=1))
    paths = [out / "cases.csv", out / "il_over_speed.csv", out / "summary.json"]
    paths += plot_active_bearing(out, sweep, method, il_sat, piezo)
    for p in paths:
        print(f"wrote {p}")


def plot_active_bearing(out: Path, sweep, method, il_sat, piezo) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res = sweep[method]
    f = res.speed_hz
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, d in zip(axes, ("x", "y")):
        for m, style in zip(METHODS, ("-", "--")):
            il = sweep[m].insertion_loss_db()
            for n, k in enumerate(res.outputs("shaft_", d)):
                ax.plot(f, il[:, k], style, lw=0.8, color=f"C{n % 10}",
                        label=res.output_names[k][6:-2] if m == METHODS[0] else None)
        ax.plot(f, il_sat, ":", color="k", lw=1.2, label=f"{method}, piezo-saturated (min)")
        ax.axhline(0.0, color="k", ls=":", lw=0.8)
        ax.set_title(f"({'ab'[('x', 'y').index(d)]}) {d}-direction (solid: paper, dashed: exact)",
                     fontsize=9)
        ax.set_xlabel("rotational frequency [Hz]")
        ax.grid(alpha=0.3)
        ax.set_ylim(-40, 80)
    axes[0].set_ylabel("insertion loss IL [dB]")
    axes[1].legend(fontsize=6, ncol=2)
    fig.tight_layout()
    save_figure(fig, out / "il_over_speed.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4))
    for i, a in enumerate(res.actuator_ids):
        ax.semilogy(f, np.abs(res.forces[:, i]), lw=1, label=f"required |F_{a}| ({method})")
    ax.semilogy(f, piezo.force_limit_n(res.speed_rad_s), "k--", lw=1.2, label="piezo force limit")
    ax.set_xlabel("rotational frequency [Hz]")
    ax.set_ylabel("force amplitude [N]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, out / "piezo_force.png", dpi=110)
    plt.close(fig)
    return [out / "il_over_speed.png", out / "piezo_force.png"]
