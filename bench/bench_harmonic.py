"""Benchmark: the adaptive harmonic controller's cost per sample in the in-process lockstep loop
(Werner 2021 case 2, 3 actuators x 2 bearing sensors, 1x, Newton, once per revolution, 20 Hz,
5 kHz; quasi-steady phasors with the supervisor, and the dynamic feed-forward adapting the
unbalance estimate), in CPU time with wall time beside it (goal: the block <= 5 us per sample):

- the block alone: its ``step`` on the inputs it saw in the loop (signals, angle, speed),
  replayed, minus the same replay calling an empty function;
- in the loop: the loop with the block minus the loop without it (the block plus the loop's
  work of handing it the signals and adding its forces).

Run: ``python bench/bench_harmonic.py [--seconds 4] [--repeats 5]``. The arms of each comparison
run interleaved; each figure is the best of the repeats.
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import copy  # noqa: E402

from timing import interleaved, load_line, result  # noqa: E402
from rotor_avc.config import load_config  # noqa: E402
from rotor_avc.scenario import scenario_from_config  # noqa: E402
from rotor_avc.sim.loop import run_loop  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="simulated seconds per run")
    ap.add_argument("--repeats", type=int, default=5, help="interleaved rounds (best of)")
    args = ap.parse_args()
    data = copy.deepcopy(load_config("scenario_harmonic_case2_steady").data)
    data["simulation"].update(duration_s=args.seconds, speed={"type": "constant", "speed_hz": 20.0})
    data["harmonic"]["start_s"] = 0.0
    scen = scenario_from_config(data, "bench_harmonic")
    n = scen.n_steps
    stepper = scen.stepper()
    ctrls = scen.controllers()
    blocks = {"quasi-steady": scen.harmonic()}
    data["harmonic"].update(adapt_in="excitations", refresh_samples=25, feedforward="dynamic")
    blocks["dynamic"] = scenario_from_config(data, "bench_harmonic_dynamic").harmonic()
    run = lambda h: lambda: run_loop(stepper, ctrls, n, harmonic=h,  # noqa: E731
                                     initial_state="steady_state", progress=False)
    arms = {"none": run(None)} | {name: run(blk) for name, blk in blocks.items()}
    best = interleaved(arms, args.repeats)
    print(f"Werner 2021 case 2 + harmonic control, 20 Hz, {1 / scen.sample_period_s:g} Hz, "
          f"{args.seconds:g} s simulated per run, best of {args.repeats} interleaved rounds; "
          f"{load_line()}")
    cpu0, wall0 = (t / n * 1e6 for t in best["none"])
    print(f"  loop step without a block       CPU {cpu0:7.2f} us   wall {wall0:7.2f} us")
    for name, blk in blocks.items():
        alone = block_alone(blk, run(blk), args.repeats)
        cpu, wall = (t / n * 1e6 for t in best[name])
        print(f"  {blk.describe()}")
        print(f"    the block alone               CPU {alone[0]:7.2f} us   wall "
              f"{alone[1]:7.2f} us   (goal: CPU <= 5 us)")
        print(f"    in the loop: with the block   CPU {cpu:7.2f} us   wall {wall:7.2f} us "
              f"= {cpu / cpu0:5.2f} x without (CPU)")
        print(f"    in the loop: the difference   CPU {cpu - cpu0:7.2f} us   wall "
              f"{wall - wall0:7.2f} us")
        result(f"harmonic block alone, {name}", alone[0] * 1e-6, alone[1] * 1e-6, "sample",
               "goal 5 us", alone[0] / 5.0)
        result(f"loop step with the {name} harmonic block", cpu * 1e-6, wall * 1e-6, "sample",
               "loop step without a block", cpu / cpu0)


def block_alone(block, run_once, repeats: int) -> tuple[float, float]:
    """``(cpu_us, wall_us)`` per sample of the block's ``step`` on the inputs it saw in a loop run,
    minus the replay calling an empty function."""
    seen = []
    step = block.step
    block.step = lambda signals, angle, speed: (seen.append((signals, angle, speed)),
                                                step(signals, angle, speed))[1]
    run_once()
    del block.step

    def replay(fn):
        def run():
            block.reset()
            for signals, angle, speed in seen:
                fn(signals, angle, speed)
        return run
    best = interleaved({"empty": replay(lambda s, a, w: None), "block": replay(block.step)},
                       repeats)
    n = len(seen)
    return tuple((b - e) / n * 1e6 for b, e in zip(best["block"], best["empty"]))


if __name__ == "__main__":
    main()
