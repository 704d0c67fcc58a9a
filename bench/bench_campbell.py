"""Benchmark: Campbell diagram of the Werner 2021 closed loop (case 3), 200 speeds 0..250 Hz.

Ours: ``campbell_diagram`` -- at every speed the worst-case poles of ``rotor-avc poles`` plus the
eigenvectors for MAC tracking. Baseline, same run: the worst-case poles alone at the same speeds
(what calling ``rotor-avc poles`` once per speed computes). Prints the time (goal <= 1 s) and the
ratio to the baseline (the cost of the tracking).
"""
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")    # small matrices: threads only contend

import numpy as np  # noqa: E402

from rotor_avc.analysis.campbell import campbell_diagram  # noqa: E402
from rotor_avc.analysis.poles import machine_poles  # noqa: E402
from rotor_avc.machine import load_machine  # noqa: E402


def main(n_speeds: int = 200) -> int:
    machine = load_machine("foot_mount_case3")
    speeds = 2 * np.pi * np.linspace(0.0, 250.0, n_speeds)
    campbell_diagram(machine, speeds[:3])                      # warm-up
    t0 = time.perf_counter()
    cd = campbell_diagram(machine, speeds)
    t_ours = time.perf_counter() - t0
    t0 = time.perf_counter()
    for w in speeds:
        machine_poles(machine, float(w))
    t_base = time.perf_counter() - t0
    print(f"Campbell diagram, {n_speeds} speeds, Werner 2021 case 3 closed loop, {cd.poles.shape[1]} modes")
    print(f"  campbell_diagram (poles + MAC tracking): {t_ours * 1e3:8.1f} ms   (goal <= 1000 ms)")
    print(f"  worst-case poles alone (baseline)      : {t_base * 1e3:8.1f} ms")
    print(f"  ratio to the baseline                  : {t_ours / t_base:8.2f} x")
    return 0 if t_ours <= 1.0 else 1


if __name__ == "__main__":
    sys.exit(main())
