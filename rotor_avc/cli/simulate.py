"""``rotor-avc simulate``: run a scenario in the in-process lockstep loop, save the time series."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..analysis.design_check import DivergenceError, check_scenario, divergence, fault_summary
from ..recording import write_run_bag
from ..scenario import load_scenario
from .common import warn

NAME = "simulate"
HELP = ("Run a simulation scenario (machine config + `simulation:` section) in the in-process "
        "lockstep loop and save the time series: .mcap (a bag with the ROS graph's topics) or "
        ".npz (format in rotor_avc.sim.timeseries).")
EXAMPLE = "rotor-avc simulate scenario_case3_steady --out out/case3_steady.npz"


def add_arguments(p) -> None:
    p.add_argument("scenario", help="scenario config: a YAML path or a shipped name "
                                    "(scenario_case3_steady, scenario_case2_runup, ...)")
    p.add_argument("--out", type=Path, required=True,
                   help="output file: .mcap (bag, rosbag2 MCAP profile) or .npz")
    p.add_argument("--progress", action="store_true", default=None,
                   help="show a progress bar on stderr (default: on long runs in a terminal)")


def run(args) -> int:
    scenario = load_scenario(args.scenario)
    check = check_scenario(scenario)
    for text in check.enforce(scenario.machine.control.allow_unstable,
                              scenario.machine.config.source):
        warn(NAME, text)
    plant = scenario.machine.plant
    print(f"{plant.name}: {scenario.duration_s:g} s at {1 / scenario.sample_period_s:g} Hz "
          f"({scenario.n_steps} samples), {len(scenario.machine.controllers)} controller(s), "
          f"{scenario.damping.describe()}, start: {scenario.initial_state}")
    t0 = time.perf_counter()
    blocks = scenario.controllers()
    with np.errstate(over="ignore", invalid="ignore"):     # a diverging run is said below
        ts = scenario.run(progress=args.progress, controllers=blocks)
    wall = time.perf_counter() - t0
    why = divergence(ts, check, blocks)
    if why:
        raise DivergenceError(f"{why} -- nothing written")
    for text in fault_summary(blocks):
        warn(NAME, text)
    if args.out.suffix == ".mcap":
        args.out.parent.mkdir(parents=True, exist_ok=True)
        path = write_run_bag(args.out, scenario, ts)
    else:
        path = ts.save(args.out)
    print(f"wrote {path} ({len(ts.channels)} channels x {len(ts)} samples; "
          f"{scenario.duration_s / wall:.1f}x real time)")
    peaks = {k: float(np.max(np.abs(v))) for k, v in ts.channels.items()
             if k.startswith("bearing_")}
    if peaks:
        name = max(peaks, key=peaks.get)
        print(f"largest bearing-housing value: {name} {peaks[name]:.3g} {ts.units[name]}")
    return 0
