"""Benchmark: the in-process lockstep loop of Werner 2021 (18 DOF, 36 states) with four controllers
(case 3*) at 5 kHz, in CPU time with wall time beside it, against one 36x36 mat-vec measured in
the same run (goal: the loop at <= 3 mat-vecs per sample):

- the plant step alone (the stepper's one mat-vec per sample);
- the loop on its fast path (plant and linear controllers in one matrix, rotor_avc.sim.fused)
  and the same loop with the fast path off (every controller stepped in Python per sample);
- a run-up 0 -> 250 Hz (between speed nodes every sample: the per-sample path) and the cost of
  its speed grid, built by the scenario's first run and reused by the next ones.

Run: ``python bench/bench_sim.py [--seconds 4] [--repeats 5]``. The arms run interleaved (A B C
A B C ...), each figure the best of the repeats. BLAS threads are limited to one (the matrices
are far too small to gain from threads, and on a busy machine threaded BLAS makes the node
matrix exponentials ~10x slower).
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import copy  # noqa: E402

import numpy as np  # noqa: E402

from timing import interleaved, load_line, result, timed  # noqa: E402
from rotor_avc.config import load_config  # noqa: E402
from rotor_avc.control.block import build_digital_controllers  # noqa: E402
from rotor_avc.machine import load_machine  # noqa: E402
from rotor_avc.scenario import scenario_from_config  # noqa: E402
from rotor_avc.sim.loop import run_loop  # noqa: E402
from rotor_avc.sim.speed_profile import constant_speed, ramp  # noqa: E402
from rotor_avc.sim.stepper import PlantStepper  # noqa: E402

TWO_PI = 2 * np.pi
FS = 5000.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="simulated seconds per run")
    ap.add_argument("--repeats", type=int, default=5, help="interleaved rounds (best of)")
    args = ap.parse_args()
    machine = load_machine("foot_mount_case3_4act")
    n = int(args.seconds * FS)
    amps = {"static": 1e-2, "moment": 2e-3j}
    rng = np.random.default_rng(0)
    A, x = rng.standard_normal((36, 36)), rng.standard_normal(36)

    def matvecs():
        for _ in range(n):
            A @ x

    const = PlantStepper(machine.plant, 1 / FS, constant_speed(TWO_PI * 50), amps)
    u = np.zeros(const.n_inputs)

    def plant_only():
        const.reset()
        for _ in range(n):
            const.step(u)

    def run(stepper, initial, fast_path=True):
        ctrls = build_digital_controllers(machine, 1 / FS)
        return lambda: run_loop(stepper, ctrls, n, initial_state=initial, progress=False,
                                fast_path=fast_path)

    runup = PlantStepper(machine.plant, 1 / FS, ramp(0.0, TWO_PI * 250, args.seconds), amps)
    runup.table.ensure(np.arange(runup.table.nodes.size))
    arms = {"mat-vec": matvecs, "plant": plant_only, "fast": run(const, "steady_state"),
            "per-sample": run(const, "steady_state", fast_path=False),
            "run-up": run(runup, "rest")}
    best = {name: (cpu / n, wall / n) for name, (cpu, wall) in
            interleaved(arms, args.repeats).items()}
    first, again, nodes = grid_cost(args.seconds)

    mv = best["mat-vec"][0]
    print(f"Werner 2021 case 3* (18 DOF, 36 states, 4 controllers), {FS:g} Hz, "
          f"{args.seconds:g} s simulated per run, best of {args.repeats} interleaved rounds; "
          f"{load_line()}")
    rows = [("baseline: one 36x36 mat-vec", "mat-vec"),
            ("plant step, constant speed", "plant"),
            ("loop step, fast path (goal <= 3 mat-vecs)", "fast"),
            ("loop step, fast path off (per sample)", "per-sample"),
            ("loop step, run-up 0 -> 250 Hz", "run-up")]
    for label, name in rows:
        cpu, wall = best[name]
        print(f"  {label:<44} CPU {cpu * 1e6:6.2f} us  wall {wall * 1e6:6.2f} us  "
              f"= {cpu / mv:5.2f} mat-vecs  -> {1 / (cpu * FS):6.1f}x real time")
    print(f"  fast path / per-sample path: {best['fast'][0] / best['per-sample'][0]:.2f} (CPU)")
    result("loop step, case 3*, 5 kHz", *best["fast"], "sample", "one 36x36 mat-vec",
           best["fast"][0] / mv)
    result("loop step, case 3*, 5 kHz", *best["fast"], "sample", "the per-sample path",
           best["fast"][0] / best["per-sample"][0])
    result("loop step, run-up 0 -> 250 Hz", *best["run-up"], "sample", "one 36x36 mat-vec",
           best["run-up"][0] / mv)
    print(f"  run-up scenario (case 2, {nodes} speed nodes): first run CPU "
          f"{first[0]:.2f} s (wall {first[1]:.2f} s), the next run on the same scenario CPU "
          f"{again[0]:.2f} s (wall {again[1]:.2f} s): the speed grid is built once")


def grid_cost(seconds):
    """``(cpu, wall)`` of a run-up scenario's first run and of its second, and its speed
    nodes (Werner 2021 case 2, 0 -> 30 Hz over 30 s, the first ``seconds`` of it)."""
    data = copy.deepcopy(load_config("scenario_case2_runup").data)
    data["simulation"]["duration_s"] = seconds
    scen = scenario_from_config(data, "bench_runup")
    first, again = (timed(lambda: scen.run(progress=False)) for _ in range(2))
    return first, again, scen.stepper().table.nodes.size


if __name__ == "__main__":
    main()
