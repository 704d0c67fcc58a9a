"""``rotor-avc demo``: the main job.

1. The Werner 2021 analysis: pole tables of cases 1-3 (worst-case procedure, Figure 4) and their
   unbalance FRFs (CSV + plots).
2. The Werner 2021 machine as a ROS graph in lockstep -- plant, three foot controllers (case 3),
   recorder, composed in one process and executor (rotor_avc.nodes.graph, as a ROS 2 component
   container runs them; ``--processes``: each its own process, as ``ros2 run`` starts them) --
   through a stepped run-up that dwells at the six open-loop machine resonances, loops open
   (case 2) and closed (case 3), each recorded to ``<out>/bags/``, with the messages published and
   recorded per topic (a run that lost any is an error). Without rclpy the same runs go through the in-process loop (identical
   results, rotor_avc.sim.loop), and the demo says so.
3. Both bags compared offline against the continuous and sampled-loop models (``rotor-avc
   compare``), and the vibration reduction at each resonance: measured (case 3 vs case 2 bag)
   and predicted by the sampled-loop model at steady state.
4. One overview page, ``<out>/index.html`` (rotor_avc.reports.demo_page): the 1x response of
   case 2 against case 3 at each bearing housing with the model curves, the reduction table, the
   messages published and recorded, the pole tables and links to every report.
"""
from __future__ import annotations

import importlib.util
import json
import math
import time
from pathlib import Path

import numpy as np

from ..compare.comparison import compare_bag
from ..closed_loop.frf import unbalance_frf
from ..analysis.poles import machine_poles
from ..bag.reader import BagReader
from ..machine import load_machine
from ..reports.demo_page import write_demo_page
from ..reports.frf_files import plot_frf, write_frf_csv
from ..output_files import make_folder, write_text
from .compare import report
from .common import output_folder
from .run import record_graph

NAME = "demo"
HELP = ("The main job: Werner 2021 pole tables and FRFs, then the machine as a ROS graph (plant, "
        "three foot controllers, recorder) through a stepped run-up with the loops open and "
        "closed, both recorded to bags, compared with the models; prints the vibration "
        "reduction at each resonance and writes one overview page, <out>/index.html.")
EXAMPLE = "rotor-avc demo --out out/demo"

ANALYSIS_CASES = ("foot_mount_case1", "foot_mount_case2", "foot_mount_case3")
RUNS = {"case2": "scenario_demo_case2", "case3": "scenario_demo_case3"}
BEARINGS = ("bearing_D_vz", "bearing_D_vy", "bearing_N_vz", "bearing_N_vy")


def add_arguments(p) -> None:
    p.add_argument("--out", type=output_folder, default="out/demo", help="output folder")
    p.add_argument("--bags", type=Path, default=None,
                   help="where the runs are recorded (default: <out>/bags)")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--in-process", action="store_true",
                      help="run the scenarios in the in-process loop instead of the ROS graph")
    mode.add_argument("--composed", action="store_true",
                      help="the graph's nodes in one process and one executor (the default: "
                           "several times faster than one process per node)")
    mode.add_argument("--processes", action="store_true",
                      help="each node of the graph its own process, as `ros2 run` starts them "
                           "(the same messages and bag, bounded by the transport between "
                           "processes: README, 'How fast the ROS graph runs')")


def run(args) -> int:
    make_folder(args.out)
    out = args.out.resolve()
    bags_dir = (args.bags or args.out / "bags").resolve()
    t0 = time.monotonic()
    poles, analysis_files = analysis(out / "analysis")
    print("\n== The Werner 2021 machine in the ROS graph: stepped run-up, loops open and closed")
    bags = {case: record(scenario, bags_dir / f"demo_{case}.mcap", out / "logs" / case,
                         args.in_process, "processes" if args.processes else "composed")
            for case, scenario in RUNS.items()}
    comps, reports = {}, []
    for case, bag in bags.items():
        print(f"\n== Comparison of {bag} with the models")
        comps[case] = compare_bag(bag)
        reports.append(report(comps[case], bag, out / f"compare_{case}")["index"])
    rows = reductions(comps["case2"], comps["case3"])
    counts = {case: _bag_counts(bag) for case, bag in bags.items()}
    summary = {"analysis": {case: {"stable": all(r.stable for r in per.values())}
                            for case, per in poles.items()},
               **{f"compare_{c}": {"pass": comp.passed, "report": str(path)}
                  for (c, comp), path in zip(comps.items(), reports)},
               "reduction": rows, "counts": counts}
    write_text(out / "summary.json", json.dumps(summary, indent=1))
    index = write_demo_page(out / "index.html", comps, rows, counts, poles,
                            reports + analysis_files + list(bags.values()) + [out / "summary.json"],
                            BEARINGS)
    print(f"\nDone in {time.monotonic() - t0:.0f} s.")
    for what, path in [("overview", index), *zip(("report, case 2", "report, case 3"), reports),
                       ("bag, case 2", bags["case2"]), ("bag, case 3", bags["case3"]),
                       ("pole tables and FRFs", out / "analysis"), ("summary", out / "summary.json")]:
        print(f"  {what:<22} {path}")
    return 0 if all(c.passed for c in comps.values()) else 1


def _bag_counts(bag: Path) -> dict:
    """The bag's messages published and recorded per topic (its own record of them)."""
    with BagReader(bag) as reader:
        return reader.counts or {t: {"published": None, "recorded": i.count}
                                 for t, i in reader.topics.items()}


def analysis(out: Path) -> tuple[dict, list[Path]]:
    """Poles and FRFs of cases 1-3 (the analysis part of the Werner 2021 paper): the poles per
    case and speed (for the overview page and poles.json), and the files written."""
    print("== Werner 2021: poles and unbalance FRFs, cases 1-3")
    make_folder(out)
    poles, files = {}, []
    for case in ANALYSIS_CASES:
        machine = load_machine(case)
        poles[case] = {f_hz: machine_poles(machine, 2 * math.pi * f_hz)
                       for f_hz in machine.analysis.pole_speeds_hz}
        case_dir = out / case
        make_folder(case_dir)
        write_text(case_dir / "poles.json", json.dumps(
            {str(f): {"poles": r.table(), "stable": r.stable, "w_F_history": r.history}
             for f, r in poles[case].items()}, indent=1))
        rng = machine.analysis.frf_speed_hz
        frf = unbalance_frf(machine.loop, 2 * np.pi * np.linspace(rng.start, rng.stop, rng.n))
        files += [write_frf_csv(frf, case_dir / "frf.csv"), *plot_frf(frf, case_dir, case)]
        verdict = "stable" if all(r.stable for r in poles[case].values()) else "UNSTABLE"
        print(f"  {case}: {verdict} at f_r = "
              + ", ".join(f"{f:g}" for f in poles[case]) + f" Hz; poles and FRFs in {case_dir}")
    return poles, files


def record(scenario: str, bag: Path, logs: Path, in_process: bool,
           layout: str = "processes") -> Path:
    """Run one scenario through the ROS graph (or in-process) and record it to ``bag``; prints
    the messages published and recorded per topic."""
    if in_process:
        return _record_in_process(scenario, bag, "requested")
    if importlib.util.find_spec("rclpy") is None:        # found, not imported: nodes/ imports it
        return _record_in_process(scenario, bag, "rclpy is not installed")
    return record_graph(scenario, bag, logs, layout)


def _record_in_process(scenario: str, bag: Path, why: str) -> Path:
    from ..recording import write_run_bag
    from ..scenario import load_scenario
    print(f"{scenario}: in-process lockstep loop ({why}; identical results to the ROS graph)")
    sc = load_scenario(scenario)
    ts = sc.run(progress=True)
    make_folder(bag.parent)
    if bag.exists():
        bag.unlink()
    return write_run_bag(bag, sc, ts)


def reductions(open_loop, closed_loop) -> list[dict]:
    """Vibration reduction at each dwell (resonance) speed: for the bearing-housing channel that
    resonates most in the open loop, measured |Y3| / |Y2| from the bags and the sampled-loop
    model's steady-state ratio; open-loop points still building up are flagged."""
    a, b = open_loop.one_x, closed_loop.one_x
    rows = []
    print("\n== Vibration reduction at each resonance (bearing housings, 1x, case 3 vs case 2)")
    print(f"{'speed':>9}  {'channel':<13} {'case 2':>10} {'case 3':>10} {'measured':>9} "
          f"{'model':>8}")
    for i, w in enumerate(a.speed_rad_s):
        j = int(np.argmin(np.abs(b.speed_rad_s - w)))
        chans = [c for c in BEARINGS if c in a.measured and c in b.measured]
        ch = max(chans, key=lambda c: abs(a.model["sampled"][c][i]))
        y2, y3 = abs(a.measured[ch][i]), abs(b.measured[ch][j])
        m2, m3 = abs(a.model["sampled"][ch][i]), abs(b.model["sampled"][ch][j])
        drift = float(a.drift.get(ch, np.zeros(i + 1))[i])
        row = {"speed_hz": w / (2 * math.pi), "channel": ch,
               "case2_db": 20 * math.log10(y2), "case3_db": 20 * math.log10(y3),
               "reduction_db": 20 * math.log10(y3 / y2), "model_reduction_db": 20 * math.log10(m3 / m2),
               "case2_drift": drift}
        note = (f"  (case 2 still building up: {100 * drift:.0f} % drift within the dwell)"
                if drift > 0.02 else "")
        print(f"{row['speed_hz']:7.2f} Hz  {ch:<13} {row['case2_db']:7.1f} dB {row['case3_db']:7.1f} dB "
              f"{row['reduction_db']:+6.1f} dB {row['model_reduction_db']:+6.1f} dB{note}")
        rows.append(row)
    print("(dB re 1 m/s for the run's unbalance; 'model': sampled-loop steady state)")
    return rows
