"""``rotor-avc simulate``: run a scenario in the in-process lockstep loop, save the time series."""
from __future__ import annotations

import time

import numpy as np

from ..analysis.design_check import DivergenceError, DivergenceWatch, check_scenario, fault_summary
from ..recording import stream_run_bag
from ..resources import check_disk, check_time
from ..scenario import load_scenario
from ..sim.timeseries import save_blocks
from ..output_files import writing
from .common import EXIT_INTERRUPTED, interrupt_flag, output_file, warn

NAME = "simulate"
HELP = ("Run a simulation scenario (machine config + `simulation:` section) in the in-process "
        "lockstep loop and save the time series, streamed block by block (memory independent "
        "of the duration): .mcap (a bag with the ROS graph's topics) or .npz (format in "
        "rotor_avc.sim.timeseries).")
EXAMPLE = "rotor-avc simulate scenario_case3_steady --out out/case3_steady.npz"


def add_arguments(p) -> None:
    p.add_argument("scenario", help="scenario config: a YAML path or a shipped name "
                                    "(scenario_case3_steady, scenario_case2_runup, ...)")
    p.add_argument("--out", type=lambda text: output_file(text, (".mcap", ".npz")), required=True,
                   help="output file: .mcap (bag, rosbag2 MCAP profile) or .npz; an existing "
                        "file is replaced when the new run is complete")
    p.add_argument("--progress", action="store_true", default=None,
                   help="show a progress bar on stderr (default: on long runs in a terminal)")
    p.add_argument("--per-sample", action="store_true",
                   help="step every block on its own per-sample path, as the ROS graph does: "
                        "a bag whose messages equal a lockstep graph run's byte for byte "
                        "(default: plant and linear controllers fused where they run linearly, "
                        "the same numbers to rounding, about 3x faster)")


def run(args) -> int:
    scenario = load_scenario(args.scenario)
    check = check_scenario(scenario)
    for text in check.enforce(scenario.machine.control.allow_unstable,
                              scenario.machine.config.source):
        warn(NAME, text)
    with interrupt_flag() as interrupted:     # from here a Ctrl-C ends the run at a clean point
        return _simulate(args, scenario, check, interrupted)


def _simulate(args, scenario, check, interrupted) -> int:
    """The run of :func:`run`, its output and summary (``interrupted()``: stop after a block)."""
    plant = scenario.machine.plant
    print(f"{plant.name}: {scenario.duration_s:g} s at {1 / scenario.sample_period_s:g} Hz "
          f"({scenario.n_steps} samples), {len(scenario.machine.controllers)} controller(s), "
          f"{scenario.damping.describe()}, start: {scenario.initial_state}", flush=True)
    t0 = time.perf_counter()
    controllers = scenario.controllers()
    watch = DivergenceWatch(check, scenario.n_steps, controllers)

    def watched(blocks, partial):
        """The blocks, each checked for overflow (the growth is judged at the end); after the
        first, the whole run's time and output size (written to ``partial``) are estimated and
        refused above the limits."""
        first = True
        for ts in blocks:
            why = watch.feed(ts)
            if why:
                raise DivergenceError(f"{why} -- nothing written")
            yield ts
            if first:
                _check_budget(ts, scenario.n_steps, time.perf_counter() - t0, partial)
                first = False
    with writing(args.out) as partial:
        with np.errstate(over="ignore", invalid="ignore"):
            blocks = watched(scenario.run_blocks(args.progress, stop=interrupted,
                                                 controllers=controllers,
                                                 fast_path=not args.per_sample), partial)
            n, peaks, units = _summary(
                stream_run_bag(partial, scenario, blocks) if args.out.suffix == ".mcap"
                else save_blocks(partial, blocks, scenario.n_steps))
        why = watch.verdict() if n == scenario.n_steps else None
        if why:
            raise DivergenceError(f"{why} -- nothing written")
    wall = time.perf_counter() - t0
    for text in fault_summary(controllers):
        warn(NAME, text)
    if n < scenario.n_steps:
        kept = (f"wrote {args.out}, a valid partial run of {n} of {scenario.n_steps} samples "
                f"({n * scenario.sample_period_s:g} s)" if args.out.suffix == ".mcap"
                else f"nothing written ({n} of {scenario.n_steps} samples run)")
        print(f"interrupted: {kept}")
        return EXIT_INTERRUPTED
    print(f"wrote {args.out} ({len(units)} channels x {n} samples; "
          f"{scenario.duration_s / wall:.1f}x real time)")
    if peaks:
        name = max(peaks, key=peaks.get)
        print(f"largest bearing-housing value: {name} {peaks[name]:.3g} {units[name]}")
    return 0


def _check_budget(first, total: int, elapsed_s: float, partial) -> None:
    """Refuse a run whose rest, extrapolated from its ``first`` block, would exceed the time
    limit or the output folder's free disk space (a bag: the bytes written so far; ``.npz``:
    the raw arrays twice, the ``.npy`` files and the archive deflated from them)."""
    done = len(first)
    rest = (total - done) / max(done, 1)
    fix = "shorten simulation.duration_s or lower simulation.sample_rate_hz"
    check_time(elapsed_s * rest, f"the run of {total} samples", fix)
    written = (partial.stat().st_size if partial.suffix == ".mcap"
               else 2 * sum(a.nbytes for a in first._arrays().values()))
    check_disk(written * rest, partial.parent, f"the output of {total} samples", fix)


def _summary(blocks) -> tuple[int, dict[str, float], dict[str, str]]:
    """Samples, peak absolute bearing-housing values and units over the run's blocks."""
    n, peaks, units = 0, {}, {}
    for ts in blocks:
        n += len(ts)
        units = ts.units
        for name, values in ts.channels.items():
            if name.startswith("bearing_"):
                peaks[name] = max(peaks.get(name, 0.0), float(np.max(np.abs(values))))
    return n, peaks, units
