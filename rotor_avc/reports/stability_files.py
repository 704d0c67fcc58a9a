"""Files of `rotor-avc stability` (Werner 2017): the threshold (JSON), the study table (CSV), the
Campbell-style eigenvalue plot and the threshold map."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..analysis.stability_study import RAD_S_PER_RPM, StudyResult, stability_loop
from ..analysis.stability_threshold import eigenvalues_over_speed
from ..output_files import open_text, save_figure, write_text


# -- plots ----------------------------------------------------------------------------------------
def write_threshold(result, path: Path) -> Path:
    """The threshold, its status and the whirl-frequency iteration as JSON."""
    write_text(path, json.dumps(
        {**result.summary(), "status": result.status, "whirl_iteration": [
            {"w_F_rad_s": p.w_F, "threshold_rpm": None if p.speed_rad_s is None
             else p.speed_rad_s / RAD_S_PER_RPM, "whirl_rad_s": p.whirl_rad_s,
             "critical_mode": p.critical_mode} for p in result.history]}, indent=1))
    return path


def write_study_rows(rows: list[dict], path: Path) -> Path:
    """One row per study point (the varied values, threshold, whirl, mode, status) as CSV."""
    with open_text(path, newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return path


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_campbell(machine, result, settings, path: Path) -> Path:
    """Eigenvalues over speed with the damping frozen at the last ``w_F`` of the iteration:
    damped natural frequencies (with the line ``omega = Omega``) and real parts."""
    plt = _pyplot()
    top = (1.5 * result.speed_rad_s if result.speed_rad_s is not None
           else settings.speed_max_rpm * RAD_S_PER_RPM)
    speeds = np.linspace(0.0, top, 400)
    lam = eigenvalues_over_speed(stability_loop(machine, settings), speeds, result.w_F)
    lam = lam[:, lam.imag.min(axis=0) < settings.campbell_max_rad_s]
    rpm = speeds / RAD_S_PER_RPM
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    for k in range(lam.shape[1]):
        ax1.plot(rpm, lam[:, k].imag, lw=1)
        ax2.plot(rpm, lam[:, k].real, lw=1)
    ax1.plot(rpm, speeds, "k:", lw=0.8, label="synchronous")
    ax1.set_ylim(0, settings.campbell_max_rad_s)
    ax2.axhline(0.0, color="k", lw=0.6)
    if result.summary()["threshold_rpm"] is not None:
        for ax in (ax1, ax2):
            ax.axvline(result.threshold_rpm, color="r", ls="--", lw=0.8,
                       label=f"threshold {result.threshold_rpm:.0f} rpm")
    ax1.set_ylabel("damped natural frequency [rad/s]")
    ax2.set_ylabel("real part [1/s]")
    ax2.set_xlabel("rotor speed [rpm]")
    ax2.set_ylim(max(lam.real.min(), -50.0), max(lam.real.max(), 1.0) * 1.1)
    ax1.legend(fontsize=8)
    fig.suptitle(f"{machine.plant.name}: eigenvalues over speed, damping at w_F = {result.w_F:.2f} rad/s",
                 fontsize=10)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def plot_map(study: StudyResult, path: Path) -> Path:
    """Threshold over one parameter (curve, with the whirl frequency) or two (colour map)."""
    plt = _pyplot()
    n = study.threshold_rpm
    if len(study.varies) == 1:
        v = study.varies[0]
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        ax1.plot(v.values, n, "o-", ms=3)
        ax2.plot(v.values, study.whirl_rad_s, "o-", ms=3)
        ax1.set_ylabel("threshold [rpm]")
        ax2.set_ylabel("whirl frequency [rad/s]")
        ax2.set_xlabel(v.label)
        for ax in (ax1, ax2):
            ax.grid(alpha=0.3)
    else:
        vx, vy = study.varies
        fig, ax = plt.subplots(figsize=(7, 5.5))
        mesh = ax.pcolormesh(vx.values, vy.values, n.T, shading="nearest", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label="threshold of stability [rpm]")
        best = study.maximum()
        if best is not None:
            ax.plot(best[vx.label], best[vy.label], "r*", ms=12,
                    label=f"max {best['threshold_rpm']:.0f} rpm")
            ax.legend(fontsize=8)
        ax.set_xlabel(vx.label)
        ax.set_ylabel(vy.label)
    fig.suptitle("threshold of stability" + (" (blank: none found, see thresholds.csv)"
                                              if np.any(np.isnan(n)) else ""), fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
