"""Benchmark: 2,000-speed closed-loop unbalance FRF of the seed-000 machine (case 3).

Ours: one batched dynamic-stiffness solve over all speeds (rotor_avc.closed_loop.frf).
Baseline, same run: python-control's ``frequency_response`` on the same closed-loop system,
rebuilt at every speed (D = D_eta / Omega and G = Omega G1 change with speed, so the system is
a different LTI system at each speed). Prints the speed-up and the largest relative difference
(goal: >= 20x, equal to 1e-9).
"""
import os
import sys
import time

import numpy as np

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF")

import control  # noqa: E402

from rotor_avc.closed_loop.frf import unbalance_frf  # noqa: E402
from rotor_avc.machine import load_machine  # noqa: E402


def baseline(loop, speeds):
    plant = loop.plant
    out = plant.output("bearing_D_vz")
    P = plant.excitation("static").p2
    n = plant.n
    result = np.empty(len(speeds), complex)
    for i, w in enumerate(speeds):
        A, B = loop.state_space(w, w)
        C = np.zeros((1, A.shape[0]))
        C[0, n:2 * n] = out.row                      # velocity output
        force = B @ P * w**2                          # complex: real and imaginary input
        sys_ = control.ss(A, np.column_stack([force.real, force.imag]), C, np.zeros((1, 2)))
        h = np.squeeze(control.frequency_response(sys_, [w]).complex)
        result[i] = h[0] + 1j * h[1]
    return result


def main(n_speeds: int = 2000) -> int:
    loop = load_machine("foot_mount_case3").loop
    speeds = 2 * np.pi * np.linspace(1.0, 250.0, n_speeds)
    unbalance_frf(loop, speeds[:10])                 # warm-up
    t0 = time.perf_counter()
    reps = 5
    for _ in range(reps):
        ours = unbalance_frf(loop, speeds).responses["bearing_D_vz_static"]
    t_ours = (time.perf_counter() - t0) / reps
    every = 10                                       # the baseline is slow: time 1 in 10 speeds
    t0 = time.perf_counter()
    ref = baseline(loop, speeds[::every])
    t_base = (time.perf_counter() - t0) * every
    err = np.max(np.abs(ours[::every] - ref) / np.abs(ref))
    print(f"closed-loop FRF, {n_speeds} speeds, 18-DOF seed-000 case 3")
    print(f"  rotor_avc batched solve      : {t_ours * 1e3:8.1f} ms")
    print(f"  python-control per speed    : {t_base * 1e3:8.1f} ms  (timed on {len(ref)} speeds, x{every})")
    print(f"  speed-up                     : {t_base / t_ours:8.1f} x   (goal >= 20 x)")
    print(f"  max relative difference      : {err:.2e}   (goal <= 1e-9)")
    return 0 if err <= 1e-9 else 1


if __name__ == "__main__":
    sys.exit(main())
