"""Per-sample controller filter: IirFilter.step vs scipy.signal.lfilter called once per sample.

Both run the same discretised controllers on the same random input in this run; the baseline is
``lfilter(b, a, [x], zi=z)`` per sample (what a naive node would do). Prints microseconds per
sample, the speed-up ratio (goal >= 10x) and the largest output difference (must be 0 up to
rounding), then checks the budgets the simulator needs (exit status 1 when one is exceeded):
a limited controller block with anti-windup below 10 us per step (4 controllers at 5 kHz, 20x real
time: 400,000 steps/s in all) and the bare filter below 5 us (best of 3).
Run: ``python bench/bench_filter.py``.
"""
from __future__ import annotations

import sys
import time

import numpy as np
import scipy.signal

from rotor_avc.control.block import DigitalController
from rotor_avc.control.discretize import discretize_controller
from rotor_avc.control.filter import IirFilter
from rotor_avc.control.spec import i_controller, lead_lag_controller, pid_controller

N = 20_000
T = 1.0 / 5000.0
BLOCK_BUDGET_US = 10.0
FILTER_BUDGET_US = 5.0
CASES = {
    "I on acceleration (Werner 2021)": i_controller(1.4e5, "acceleration"),
    "PID with derivative filter": pid_controller(1e6, 2e7, 1e3, "displacement", 1e-4),
    "lead-lag": lead_lag_controller(2e5, 20.0, 200.0, "velocity"),
}


def per_sample_lfilter(b, a, x):
    z = np.zeros(max(len(a), len(b)) - 1)
    out = np.empty_like(x)
    for k in range(x.size):
        y, z = scipy.signal.lfilter(b, a, x[k:k + 1], zi=z)
        out[k] = y[0]
    return out


def per_sample_filter(filt, x):
    step = filt.step
    return np.array([step(v) for v in x.tolist()])


def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, (time.perf_counter() - t0) / args[-1].size * 1e6


def main() -> int:
    x = np.random.default_rng(1).standard_normal(N)
    print(f"{N} samples at {1 / T:g} Hz, microseconds per sample (same run)")
    print(f"{'controller':32} {'lfilter/sample':>15} {'IirFilter':>10} {'block':>8} {'ratio':>7} "
          f"{'max |diff|':>11}")
    for name, ctrl in CASES.items():
        tf = discretize_controller(ctrl, T, "tustin")
        ref, t_ref = timed(per_sample_lfilter, tf.b, tf.a, x)
        out, t_fil = timed(per_sample_filter, IirFilter(tf.b, tf.a), x)
        block = DigitalController(tf)
        blk, t_blk = timed(lambda xs: np.array([block.step(v) for v in xs.tolist()]), x)
        diff = max(np.max(np.abs(out - ref)), np.max(np.abs(-blk - ref))) / np.max(np.abs(ref))
        print(f"{name:32} {t_ref:15.2f} {t_fil:10.2f} {t_blk:8.2f} {t_ref / t_fil:6.1f}x "
              f"{diff:11.1e}")
    return check_budgets(x)


def check_budgets(x) -> int:
    """1 when a per-sample cost exceeds its budget (module docstring), else 0."""
    block = DigitalController(discretize_controller(CASES["I on acceleration (Werner 2021)"], T),
                              force_limit_n=1e4, anti_windup="conditional_integration")
    _, t_blk = timed(lambda xs: [block.step(v) for v in xs.tolist()], x)
    tf = discretize_controller(CASES["PID with derivative filter"], T, "tustin")
    t_fil = min(timed(per_sample_filter, IirFilter(tf.b, tf.a), x)[1] for _ in range(3))
    over = [f"{what} {t:.2f} us > {budget:g} us" for what, t, budget in (
        ("limited block", t_blk, BLOCK_BUDGET_US), ("filter", t_fil, FILTER_BUDGET_US))
        if t > budget]
    print(f"budgets: limited block {t_blk:.2f} us (< {BLOCK_BUDGET_US:g}), filter {t_fil:.2f} us "
          f"(< {FILTER_BUDGET_US:g}): " + ("; ".join(over) if over else "ok"))
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
