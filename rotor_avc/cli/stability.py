"""``rotor-avc stability``: threshold of stability (seed 003's procedure) and parameter maps."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..analysis.stability_study import (RAD_S_PER_RPM, StudyResult, machine_threshold,
                                        parse_vary, run_study, stability_loop, study_from_config,
                                        threshold_settings, with_variants)
from ..analysis.stability_threshold import STATUSES, eigenvalues_over_speed
from ..config import load_config
from ..errors import ConfigError
from ..studies.backends import add_backend_arguments, backend_from_args

NAME = "stability"
HELP = ("Threshold of stability of a machine with loss-factor and internal damping (eigenvalues "
        "over speed, whirl-frequency iteration; Werner 2017), or maps of it over one or two "
        "config parameters, with a Campbell-style eigenvalue plot.")
EXAMPLE = ("rotor-avc stability roller_bearing_stability --vary "
           "'foundation.stiffness_n_per_m.z,foundation.stiffness_n_per_m.y=2.0e+7:7.5e+8:15' --out out/stab")


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name "
                                  "(roller_bearing_stability)")
    p.add_argument("--variant", action="append", default=[], metavar="NAME",
                   help="apply a variant of the config's `variants:` section (repeatable, in order; "
                        "e.g. d = rigid foundation, demo, velocity_feedback)")
    p.add_argument("--study", metavar="NAME",
                   help="run a study of the config's `studies:` section (e.g. fig7, velocity_feedback)")
    p.add_argument("--vary", action="append", default=[], metavar="PARAM=START:STOP:N",
                   help="vary a dotted config path (once or twice for a 2-D map); comma-join paths "
                        "that take the same value, `*=` for factors on the base values, "
                        "START:STOP:N:log for log spacing or [v1,v2,...] for a list")
    p.add_argument("--out", type=Path, help="folder for threshold.json / thresholds.csv and plots "
                                            "(a map's points also go to DIR/points/, resumed)")
    p.add_argument("--json", action="store_true",
                   help='print {"threshold_rpm", "whirl_rad_s", "critical_mode"} (threshold_rpm null '
                        'when none is found); with --vary/--study {"points": [...], "maximum": ...}')
    add_backend_arguments(p)


def run(args) -> int:
    cfg = with_variants(load_config(args.config), args.variant)
    if args.study and args.vary:
        raise ConfigError("--vary", "--study and --vary both given",
                          fix="give either a named study or the parameters to vary")
    if args.study:
        cfg, varies = study_from_config(cfg, args.study)
    else:
        varies = [parse_vary(text) for text in args.vary]
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
    if varies:
        return _run_study(cfg, varies, args)
    machine, result = machine_threshold(cfg)
    if args.json:
        print(json.dumps(result.summary()))
    else:
        kind = threshold_settings(cfg).controller if machine.controllers else "no"
        print(f"{machine.plant.name} ({', '.join(args.variant) or 'base config'}; {kind} controllers):")
        print("whirl-frequency iteration (damping at w_F -> threshold, whirl):")
        for k, p in enumerate(result.history):
            found = (f"{p.speed_rad_s / RAD_S_PER_RPM:10.1f} rpm, {p.whirl_rad_s:9.4f} rad/s, mode "
                     f"{p.critical_mode}" if p.speed_rad_s is not None else "no threshold")
            print(f"  {k + 1:2d}: w_F = {p.w_F:9.4f} rad/s -> {found}")
        print(result.describe())
        if result.mode_shape is not None:
            print("critical mode shape |q| (normalised): " + ", ".join(
                f"{c} {abs(v):.2f}" for c, v in zip(machine.plant.coords, result.mode_shape)))
    if args.out:
        (args.out / "threshold.json").write_text(json.dumps(
            {**result.summary(), "status": result.status, "whirl_iteration": [
                {"w_F_rad_s": p.w_F, "threshold_rpm": None if p.speed_rad_s is None
                 else p.speed_rad_s / RAD_S_PER_RPM, "whirl_rad_s": p.whirl_rad_s,
                 "critical_mode": p.critical_mode} for p in result.history]}, indent=1))
        path = plot_campbell(machine, result, threshold_settings(cfg), args.out / "campbell.png")
        if not args.json:
            print(f"wrote {args.out / 'threshold.json'} and {path}")
    return 0


def _run_study(cfg, varies, args) -> int:
    study = run_study(cfg, varies, backend=backend_from_args(args.workers, args.scheduler),
                      batch_size=args.batch_size, out=args.out and args.out / "points",
                      progress=not args.json)
    rows = study.rows()
    if args.json:
        print(json.dumps({"points": rows, "maximum": study.maximum()}, indent=1))
    else:
        labels = [v.label for v in varies]
        print(" | ".join(labels) + " | threshold [rpm] | whirl [rad/s] | mode")
        for row in rows:
            vals = " | ".join(f"{row[lab]:.4g}" for lab in labels)
            if row["threshold_rpm"] is None:
                print(f"{vals} | {STATUSES.get(row['status'], row['status'])}")
            else:
                print(f"{vals} | {row['threshold_rpm']:.1f} | {row['whirl_rad_s']:.3f} | "
                      f"{row['critical_mode']}")
        best = study.maximum()
        if best is not None:
            print("maximum: " + ", ".join(f"{k} = {v:.6g}" if isinstance(v, float) else f"{k} = {v}"
                                          for k, v in best.items()))
    if args.out:
        with open(args.out / "thresholds.csv", "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        path = plot_map(study, args.out / "threshold_map.png")
        if not args.json:
            print(f"wrote {args.out / 'thresholds.csv'} and {path}")
    return 0


# -- plots ----------------------------------------------------------------------------------------
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
    fig.savefig(path, dpi=110)
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
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
