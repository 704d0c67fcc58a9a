"""Benchmark: the per-sample controller step -- ``IirFilter.step`` and ``DigitalController.step``
(rotor_avc.control) -- against a hand-written Python difference equation of the same order.

Three discretised controllers (Tustin, 5 kHz: Werner 2021's I on acceleration, a PID with
derivative filter, a lead-lag) run on the same random input. Arms, interleaved in one run:

* baseline: the direct form II transposed recursion written inline for the filter's order, on
  plain floats (``y = b0 x + z0; z0 = b1 x + z1 - a1 y; z1 = b2 x - a2 y``) -- the tightest
  Python loop, what the class costs on top of the arithmetic;
* ``IirFilter.step`` and ``DigitalController.step`` (filter, measurement check, sign) in the same
  loop; for the I controller also the block with a force limit and anti-windup;
* ``scipy.signal.lfilter`` over the whole array: the vectorised reference (not per sample).

Prints CPU and wall microseconds per sample, the ratios to the baseline (CPU), the largest
output difference to lfilter (relative to its peak; must be rounding), and checks the budgets
the simulator needs on CPU time (exit status 1 when one is exceeded or an output differs): the
limited block below 10 us per step (4 controllers at 5 kHz, 20x real time: 400,000 steps/s in
all) and the bare filter below 5 us.

Run: ``python bench/bench_filter.py [--samples 20000] [--repeats 5]``; each figure is the best of
the repeats, the arms of each controller interleaved.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
import scipy.signal

from timing import interleaved, load_line, result
from rotor_avc.control.block import DigitalController
from rotor_avc.control.discretize import discretize_controller
from rotor_avc.control.filter import IirFilter
from rotor_avc.control.spec import i_controller, lead_lag_controller, pid_controller

T = 1.0 / 5000.0
BLOCK_BUDGET_US = 10.0
FILTER_BUDGET_US = 5.0
WERNER = "I on acceleration (Werner 2021)"
CASES = {
    WERNER: i_controller(1.4e5, "acceleration"),
    "PID with derivative filter": pid_controller(1e6, 2e7, 1e3, "displacement", 1e-4),
    "lead-lag": lead_lag_controller(2e5, 20.0, 200.0, "velocity"),
}


def first_order(b, a, xs, out):
    """The baseline for one state: the recursion inline, plain floats."""
    b0, b1 = b
    a1 = a[1]
    z0 = 0.0
    for k, x in enumerate(xs):
        y = b0 * x + z0
        z0 = b1 * x - a1 * y
        out[k] = y


def second_order(b, a, xs, out):
    """The baseline for two states: the recursion inline, plain floats."""
    b0, b1, b2 = b
    a1, a2 = a[1], a[2]
    z0 = z1 = 0.0
    for k, x in enumerate(xs):
        y = b0 * x + z0
        z0 = b1 * x + z1 - a1 * y
        z1 = b2 * x - a2 * y
        out[k] = y


HAND_WRITTEN = {1: first_order, 2: second_order}


def stepped(block, xs, out):
    """``out[k] = block.step(xs[k])`` from rest, in the baseline's loop."""
    block.reset()
    step = block.step
    for k, x in enumerate(xs):
        out[k] = step(x)


def bench_case(name, ctrl, x, repeats):
    """``(best {arm: (cpu_s, wall_s)}, largest relative output difference to lfilter)``."""
    tf = discretize_controller(ctrl, T, "tustin")
    filt = IirFilter(tf.b, tf.a)
    xs = x.tolist()
    blocks = {"filter": filt, "block": DigitalController(tf)}
    if name == WERNER:
        blocks["limited"] = DigitalController(tf, force_limit_n=1e4,
                                              anti_windup="conditional_integration")
    outs = {arm: [0.0] * len(xs) for arm in ("hand", *blocks)}
    ref = {}
    arms = {"hand": lambda: HAND_WRITTEN[filt.n](filt.b, filt.a, xs, outs["hand"])}
    arms |= {arm: (lambda arm=arm: stepped(blocks[arm], xs, outs[arm])) for arm in blocks}
    arms["lfilter"] = lambda: ref.__setitem__("y", scipy.signal.lfilter(tf.b, tf.a, x))
    best = interleaved(arms, repeats)
    y = ref["y"]
    diff = max(np.max(np.abs(np.asarray(outs["hand"]) - y)),
               np.max(np.abs(np.asarray(outs["filter"]) - y)),
               np.max(np.abs(-np.asarray(outs["block"]) - y))) / np.max(np.abs(y))
    return {arm: (cpu / x.size, wall / x.size) for arm, (cpu, wall) in best.items()}, diff


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=20_000, help="input samples per run")
    ap.add_argument("--repeats", type=int, default=5, help="interleaved rounds (best of)")
    args = ap.parse_args()
    x = np.random.default_rng(1).standard_normal(args.samples)
    print(f"{args.samples} samples at {1 / T:g} Hz, best of {args.repeats} interleaved rounds; "
          f"{load_line()}")
    print(f"  us per sample, CPU (wall)      {'hand-written':>16} {'IirFilter':>16} "
          f"{'block':>16} {'lfilter, array':>16}   ratio to hand-written (CPU)  max |diff|")
    us = lambda t: f"{t[0] * 1e6:6.3f} ({t[1] * 1e6:6.3f})"  # noqa: E731
    status, per_case = 0, {}
    for name, ctrl in CASES.items():
        best, diff = bench_case(name, ctrl, x, args.repeats)
        per_case[name] = best
        hand = best["hand"][0]
        print(f"  {name:30} {us(best['hand']):>16} {us(best['filter']):>16} "
              f"{us(best['block']):>16} {us(best['lfilter']):>16}   filter "
              f"{best['filter'][0] / hand:4.2f}x, block {best['block'][0] / hand:4.2f}x   "
              f"{diff:9.1e}")
        status |= 0 if diff <= 1e-12 else 1
    pid, werner = per_case["PID with derivative filter"], per_case[WERNER]
    baseline = "hand-written difference equation, same order"
    result("IirFilter.step, PID (2nd order)", *pid["filter"], "sample", baseline,
           pid["filter"][0] / pid["hand"][0])
    result("DigitalController.step, I (Werner 2021)", *werner["block"], "sample", baseline,
           werner["block"][0] / werner["hand"][0])
    result("the same, force limit + anti-windup", *werner["limited"], "sample", baseline,
           werner["limited"][0] / werner["hand"][0])
    return status | check_budgets(werner["limited"][0], pid["filter"][0])


def check_budgets(block_s: float, filter_s: float) -> int:
    """1 when a per-sample CPU time exceeds its budget (module docstring), else 0."""
    t_blk, t_fil = block_s * 1e6, filter_s * 1e6
    over = [f"{what} {t:.2f} us > {budget:g} us" for what, t, budget in (
        ("limited block", t_blk, BLOCK_BUDGET_US), ("filter", t_fil, FILTER_BUDGET_US))
        if t > budget]
    print(f"budgets (CPU): limited block {t_blk:.2f} us (< {BLOCK_BUDGET_US:g}), filter "
          f"{t_fil:.2f} us (< {FILTER_BUDGET_US:g}): " + ("; ".join(over) if over else "ok"))
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
