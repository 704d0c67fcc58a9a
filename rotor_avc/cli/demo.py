"""``rotor-avc demo``: the main job -- the seed-000 analysis of cases 1-3."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..analysis.frf import unbalance_frf
from ..analysis.poles import machine_poles
from ..machine import load_machine
from ..reports.frf_files import plot_frf, write_frf_csv

NAME = "demo"
HELP = ("The seed-000 machine (Werner 2021): pole tables of cases 1-3 and their unbalance FRFs "
        "(CSV + plots) in an output folder.")
EXAMPLE = "rotor-avc demo --out out/demo"

CASES = ("foot_mount_case1", "foot_mount_case2", "foot_mount_case3")


def add_arguments(p) -> None:
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder")


def run(args) -> int:
    args.out.mkdir(parents=True, exist_ok=True)
    summary = {}
    for case in CASES:
        machine = load_machine(case)
        case_dir = args.out / case
        case_dir.mkdir(exist_ok=True)
        poles = {}
        for f_hz in machine.analysis.number_list("pole_speeds_hz", [0.0]):
            res = machine_poles(machine, 2 * math.pi * f_hz)
            poles[f_hz] = res
            print(f"\n{case}: poles at f_r = {f_hz:g} Hz (w_F iterations "
                  + " -> ".join(f"{w:.1f}" for w in res.history) + " rad/s)")
            for r in res.table()[:8]:
                print(f"  {r['re']:9.2f} {r['im']:+10.2f}j rad/s  {r['freq_hz']:8.2f} Hz  "
                      f"zeta {r['damping_ratio']:.3f}")
            print(f"  max Re = {res.max_real:.3f} 1/s -> {'stable' if res.stable else 'UNSTABLE'}")
        (case_dir / "poles.json").write_text(json.dumps(
            {str(f): {"poles": r.table(), "stable": r.stable, "w_F_history": r.history}
             for f, r in poles.items()}, indent=1))
        rng = machine.analysis.section("frf_speed_hz")
        speeds = np.linspace(rng.number("start"), rng.number("stop"), rng.integer("n"))
        frf = unbalance_frf(machine.loop, 2 * np.pi * speeds)
        write_frf_csv(frf, case_dir / "frf.csv")
        plot_frf(frf, case_dir, case)
        peak = {k: float(np.max(frf.db(k))) for k in ("bearing_D_vz_static", "bearing_D_vy_static",
                                                      "bearing_D_vz_moment", "bearing_D_vy_moment")}
        summary[case] = {"stable": all(r.stable for r in poles.values()), "peak_db": peak}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1))
    print("\nPeak bearing-housing velocity over 1-250 Hz [dB re 1 (m/s)/(kg m) or /(kg m^2)]:")
    for case, s in summary.items():
        print(f"  {case}: " + ", ".join(f"{k} {v:.1f}" for k, v in s["peak_db"].items()))
    print(f"\nResults (poles.json, frf.csv, frf_*.png per case) are in {args.out.resolve()}")
    return 0
