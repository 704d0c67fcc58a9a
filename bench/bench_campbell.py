"""Benchmark: Campbell diagram of the Werner 2021 closed loop (case 3), 200 speeds 0..250 Hz.

Ours: ``campbell_diagram`` -- at every speed the worst-case poles of ``rotor-avc poles`` plus the
eigenvectors for MAC tracking. Baseline, interleaved in the same run: the worst-case poles alone
at the same speeds (what calling ``rotor-avc poles`` once per speed computes). Prints CPU and
wall time (goal: CPU <= 1 s; exit status 1 otherwise) and the ratio to the baseline (the cost of
the tracking).

Run: ``python bench/bench_campbell.py [--speeds 200] [--repeats 3]``; each figure is the best of
the repeats.
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")    # small matrices: threads only contend

import argparse  # noqa: E402
import sys  # noqa: E402

import numpy as np  # noqa: E402

from timing import interleaved, load_line, result  # noqa: E402
from rotor_avc.analysis.campbell import campbell_diagram  # noqa: E402
from rotor_avc.analysis.poles import machine_poles  # noqa: E402
from rotor_avc.machine import load_machine  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--speeds", type=int, default=200, help="speeds 0..250 Hz")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (best of)")
    args = ap.parse_args()
    machine = load_machine("foot_mount_case3")
    speeds = 2 * np.pi * np.linspace(0.0, 250.0, args.speeds)
    campbell_diagram(machine, speeds[:3])                      # warm-up
    out = {}
    best = interleaved({
        "ours": lambda: out.__setitem__("cd", campbell_diagram(machine, speeds)),
        "poles": lambda: [machine_poles(machine, float(w)) for w in speeds]}, args.repeats)
    (cpu, wall), (cpu_b, wall_b) = best["ours"], best["poles"]
    print(f"Campbell diagram, {args.speeds} speeds, Werner 2021 case 3 closed loop, "
          f"{out['cd'].poles.shape[1]} modes, best of {args.repeats} interleaved rounds; "
          f"{load_line()}")
    print(f"  campbell_diagram (poles + MAC tracking): CPU {cpu * 1e3:8.1f} ms  wall "
          f"{wall * 1e3:8.1f} ms   (goal: CPU <= 1000 ms)")
    print(f"  worst-case poles alone (baseline)      : CPU {cpu_b * 1e3:8.1f} ms  wall "
          f"{wall_b * 1e3:8.1f} ms")
    print(f"  ratio to the baseline (CPU)            : {cpu / cpu_b:8.2f} x")
    result(f"Campbell diagram, case 3, {args.speeds} speeds", cpu / args.speeds,
           wall / args.speeds, "speed", "worst-case poles alone", cpu / cpu_b)
    return 0 if cpu <= 1.0 else 1


if __name__ == "__main__":
    sys.exit(main())
