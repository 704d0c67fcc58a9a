"""Benchmark: the adaptive harmonic controller's cost per sample in the in-process lockstep loop
(Werner 2021 case 2, 3 actuators x 2 bearing sensors, 1x, Newton, once per revolution, 20 Hz,
5 kHz; quasi-steady phasors, and the dynamic feed-forward adapting the unbalance estimate):
loop with the block minus loop without it (goal: <= 5 us), and as a ratio.

Run: ``python bench/bench_harmonic.py [--seconds 4]``. Each figure is the best of three repeats.
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import copy  # noqa: E402

from bench_sim import best_of  # noqa: E402
from rotor_avc.config import load_config  # noqa: E402
from rotor_avc.scenario import scenario_from_config  # noqa: E402
from rotor_avc.sim.loop import run_loop  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="simulated seconds per run")
    args = ap.parse_args()
    data = copy.deepcopy(load_config("scenario_harmonic_case2_steady").data)
    data["simulation"].update(duration_s=args.seconds, speed={"type": "constant", "speed_hz": 20.0})
    data["harmonic"]["start_s"] = 0.0
    scen = scenario_from_config(data, "bench_harmonic")
    n = scen.n_steps
    stepper = scen.stepper()
    block = scen.harmonic()
    ctrls = scen.controllers()
    run = lambda h: lambda: run_loop(stepper, ctrls, n, harmonic=h,  # noqa: E731
                                     initial_state="steady_state", progress=False)
    t_without = best_of(run(None)) / n
    print(f"Werner 2021 case 2 + harmonic control, 20 Hz, {1 / scen.sample_period_s:g} Hz, "
          f"{args.seconds:g} s simulated per run")
    print(f"  loop step without a block          {t_without * 1e6:7.2f} us")
    data["harmonic"].update(adapt_in="excitations", refresh_samples=25, feedforward="dynamic")
    dynamic = scenario_from_config(data, "bench_harmonic_dynamic").harmonic()
    for blk in (block, dynamic):
        t_with = best_of(run(blk)) / n
        print(f"  {blk.describe()}")
        print(f"    loop step with the block         {t_with * 1e6:7.2f} us "
              f"= {t_with / t_without:5.2f} x without")
        print(f"    the block's cost per sample      {(t_with - t_without) * 1e6:7.2f} us "
              "(goal <= 5 us)")


if __name__ == "__main__":
    main()
