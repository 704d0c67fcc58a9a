"""Benchmark: the in-process lockstep loop of Werner 2021 (18 DOF, 36 states) with four controllers
(case 3*) at 5 kHz -- simulated seconds per wall second (goal: >= 20x real time) and the cost
of one sample against one 36x36 mat-vec measured in the same run.

Run: ``python bench/bench_sim.py [--seconds 4]``. Each figure is the best of three repeats.
BLAS threads are limited to one (the matrices are far too small to gain from threads, and on a
busy machine threaded BLAS makes the node matrix exponentials ~10x slower).
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from rotor_avc.control.block import build_digital_controllers  # noqa: E402
from rotor_avc.machine import load_machine  # noqa: E402
from rotor_avc.sim.loop import run_loop  # noqa: E402
from rotor_avc.sim.speed_profile import constant_speed, ramp  # noqa: E402
from rotor_avc.sim.stepper import PlantStepper  # noqa: E402

TWO_PI = 2 * np.pi
FS = 5000.0


def best_of(fn, repeats=3):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="simulated seconds per run")
    args = ap.parse_args()
    machine = load_machine("foot_mount_case3_4act")
    n = int(args.seconds * FS)
    amps = {"static": 1e-2, "moment": 2e-3j}

    rng = np.random.default_rng(0)
    A, x = rng.standard_normal((36, 36)), rng.standard_normal(36)

    def matvecs():
        for _ in range(n):
            A @ x
    t_mv = best_of(matvecs) / n

    const = PlantStepper(machine.plant, 1 / FS, constant_speed(TWO_PI * 50), amps)
    u = np.zeros(const.n_inputs)

    def plant_only():
        const.reset()
        for _ in range(n):
            const.step(u)
    t_plant = best_of(plant_only) / n

    def loop(stepper, initial):
        ctrls = build_digital_controllers(machine, 1 / FS)
        return lambda: run_loop(stepper, ctrls, n, initial_state=initial, progress=False)
    t_loop = best_of(loop(const, "steady_state")) / n
    runup = PlantStepper(machine.plant, 1 / FS, ramp(0.0, TWO_PI * 250, args.seconds), amps)
    t_build = best_of(lambda: runup.table.ensure(np.arange(runup.table.nodes.size)), 1)
    t_runup = best_of(loop(runup, "rest")) / n

    print(f"Werner 2021 case 3* (18 DOF, 36 states, 4 controllers), {FS:g} Hz, "
          f"{args.seconds:g} s simulated per run")
    print(f"  baseline: one 36x36 mat-vec                  {t_mv * 1e6:7.2f} us")
    print(f"  plant step, constant speed                   {t_plant * 1e6:7.2f} us "
          f"= {t_plant / t_mv:5.2f} mat-vecs")
    print(f"  loop step (plant + 4 controllers + record)   {t_loop * 1e6:7.2f} us "
          f"= {t_loop / t_mv:5.2f} mat-vecs  -> {1 / (t_loop * FS):6.1f}x real time (goal 20x)")
    print(f"  loop step, run-up 0 -> 250 Hz                {t_runup * 1e6:7.2f} us "
          f"= {t_runup / t_mv:5.2f} mat-vecs  -> {1 / (t_runup * FS):6.1f}x real time")
    print(f"  speed grid of that run-up: {runup.table.nodes.size} nodes, built in "
          f"{t_build:.2f} s (once per stepper)")


if __name__ == "__main__":
    main()
