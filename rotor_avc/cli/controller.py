"""``rotor-avc controller``: one foot's controller, continuous and discrete, and the loop margins
of every foot (continuous design and sampled loop) with the all-loop gain range."""
from __future__ import annotations

import argparse
import json
import math
from functools import partial

from ..analysis.design_check import DesignError, check_design
from ..analysis.loop_margins import (LoopAnalysis, analyse_loop, continuous_loop_frf,
                                     disk_gain_phase, sampled_loop_frf)
from ..analysis.poles import machine_poles
from ..analysis.sampled_loop import SampledLoop, machine_sampled_loop
from ..control.block import build_digital_controllers
from ..errors import ModelError, did_you_mean
from ..interactive.jsonable import jsonable
from ..machine import load_machine
from ..reports.controller_bode import plot_bode
from ..reports.loop_plots import plot_loop_bode, plot_loop_nyquist
from ..output_files import make_folder
from ..studies.progress import run_each
from .common import add_speed_option, nonnegative_float, output_folder, warn

NAME = "controller"
HELP = ("Print a foot controller's continuous G_c(s) and discrete G_d(z) coefficients, plot "
        "G_c(jw) against G_d(e^{jwT}), print every foot's loop margins (GM, PM, Ms, crossovers) "
        "of the continuous design and the sampled loop, the all-loop gain range and disk "
        "margin.")
#: the gains a common factor scales (filter corners and time constants stay)
GAIN_KEYS = ("kp", "ki", "kd", "gain")
EXAMPLE = "rotor-avc controller foot_mount_case3 --foot DL --rate-hz 5000 --out out/ctrl"


def _positive_float(text: str) -> float:
    value = nonnegative_float(text)
    if value == 0.0:
        raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
    return value


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name")
    p.add_argument("--foot", required=True, help="actuator id of a controlled foot (e.g. DL)")
    p.add_argument("--rate-hz", type=_positive_float, default=None,
                   help="sample rate in Hz (default: the config's control.sample_rate_hz)")
    add_speed_option(p, nonnegative_float, "rotor speed of the gain-range search in Hz "
                     "(default 0); damping at the w_F of the config's continuous pole procedure",
                     default=0.0)
    p.add_argument("--out", type=output_folder, default=".",
                   help="folder for controller_<foot>_bode.png and every controlled foot's "
                        "loop_<foot>_bode.png, loop_<foot>_nyquist.png (default: current folder)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON document (margins, gain range) instead of the text")


def controlled_foot(machine, given: str) -> str:
    """The controlled actuator ``given`` names (ids compared without case), or a ModelError
    naming the controlled ones and the closest."""
    by_case = {foot.casefold(): foot for foot in machine.controllers}
    if given.casefold() in by_case:
        return by_case[given.casefold()]
    known = ", ".join(machine.controllers) or "none"
    raise ModelError(f"--foot {given}: no controller at that foot"
                     f"{did_you_mean(given, machine.controllers)}; controlled feet: {known}")


def run(args) -> int:
    machine = load_machine(args.config)
    args.foot = controlled_foot(machine, args.foot)
    T = 1.0 / (machine.sample_rate_hz if args.rate_hz is None else args.rate_hz)
    speed = 2 * math.pi * args.speed_hz
    w_F = machine_poles(machine, speed).w_F
    check = check_design(machine, T, [speed], lambda _: w_F)
    try:
        for text in check.enforce(machine.control.allow_unstable, f"{machine.plant.name}"):
            warn(NAME, text)
    except DesignError as exc:
        if check.fatal:
            raise
        rng = machine_sampled_loop(machine, T).stable_gain_range(speed, w_F)
        raise DesignError(f"{exc}; {rng.describe()}") from None
    blocks = build_digital_controllers(machine, T)
    ctrl, block = machine.controllers[args.foot], blocks[args.foot]
    make_folder(args.out)
    title = f"{machine.plant.name} {args.foot}: {ctrl.describe()}"
    sampled = SampledLoop.from_blocks(machine.plant, blocks)
    rng = sampled.stable_gain_range(speed, w_F)
    cont = analyse_loop(continuous_loop_frf(machine.plant, machine.controllers, speed, w_F))
    samp = analyse_loop(sampled_loop_frf(sampled, speed, w_F))
    where = f"f_r = {args.speed_hz:g} Hz, w_F = {w_F:.1f} rad/s"
    figures = [partial(plot_bode, ctrl, block.tf, args.out / f"controller_{args.foot}_bode.png",
                       title)]
    for foot, m in samp.loops.items():
        head = f"{machine.plant.name} loop {foot} ({where}), {1 / T:g} Hz vs continuous"
        figures += [partial(plot_loop_bode, m, cont.loops[foot],
                            args.out / f"loop_{foot}_bode.png", head),
                    partial(plot_loop_nyquist, m, cont.loops[foot],
                            args.out / f"loop_{foot}_nyquist.png", head)]
    plots = run_each(figures, "figures")
    if args.json:
        print(json.dumps(jsonable(_document(args, T, w_F, rng, cont, samp)), sort_keys=True))
        return 0
    fmt = lambda v: "[" + ", ".join(f"{x:.10g}" for x in v) + "]"  # noqa: E731
    print(f"{machine.plant.name} foot {args.foot}: {ctrl.describe()}  (force = -G_c * signal)")
    print(f"continuous G_c(s): num = {fmt(ctrl.num)}, den = {fmt(ctrl.den)}")
    print("discrete " + block.describe())
    for path in plots:
        print(f"wrote {path}")
    print(f"stable gain range of the sampled loop (all {len(blocks)} controllers scaled by g; "
          f"{where}):")
    nominal = {k: ", ".join(f"{name} {v * rng.lower:.4g} .. "
                            + ("inf" if math.isinf(rng.upper) else f"{v * rng.upper:.4g}")
                            for name, v in c.gains if name in GAIN_KEYS)
               for k, c in machine.controllers.items() if c.gains and rng.found}
    print("  " + rng.describe(nominal))
    _print_margins(cont, samp, rng, T, where)
    return 0


def _document(args, T, w_F, rng, cont: LoopAnalysis, samp: LoopAnalysis) -> dict:
    """The ``--json`` document: per foot the sampled loop's margins with the continuous design's
    under ``continuous``; all loops: eigenvalue gain range, the FRF one, the disk margin."""
    loops = {foot: {**m.summary(), "continuous": cont.loops[foot].summary()}
             for foot, m in samp.loops.items()}
    return {"config": args.config, "foot": args.foot, "rate_hz": 1.0 / T,
            "speed_hz": args.speed_hz, "w_F_rad_s": w_F, "loops": loops,
            "all_loops": {"gain_range": [rng.lower, rng.upper], **samp.summary(),
                          "stable_at_nominal": rng.stable_at_nominal,
                          "continuous": cont.summary()}}


def _num(value: float, spec: str) -> str:
    return "-" if math.isnan(value) else ("inf" if math.isinf(value) else format(value, spec))


def _print_margins(cont: LoopAnalysis, samp: LoopAnalysis, rng, T: float, where: str) -> None:
    print(f"loop margins ({where}), each loop broken at its actuator input with the other loops "
          "closed (1 + L_i, force = -G * signal):")
    print("  GM: smallest destabilising gain factor > 1, at its phase crossover; PM: 180 deg + "
          "arg L_i in [-180, 180) at the gain crossover of smallest |PM| (negative: reached with "
          "phase lead)")
    print("  Ms = max |1/(1 + L_i)| (at inf: approached as f -> inf); disk: balanced disk margin")
    print(f"  {'foot':6} {'loop':11} {'GM [dB]':>8} {'GM':>9} {'at [Hz]':>9} {'PM [deg]':>9} "
          f"{'at [Hz]':>9} {'Ms':>7} {'at [Hz]':>9} {'disk':>6}")
    for foot in samp.loops:
        for name, m in (("continuous", cont.loops[foot]), (f"{1 / T:g} Hz", samp.loops[foot])):
            print(f"  {foot:6} {name:11} {_num(m.gain_margin_db, '8.2f'):>8} "
                  f"{_num(m.gain_margin, '9.4g'):>9} {_num(m.phase_crossover_hz, '9.4g'):>9} "
                  f"{_num(m.phase_margin_deg, '9.2f'):>9} {_num(m.crossover_hz, '9.4g'):>9} "
                  f"{m.sensitivity_peak:7.4f} {m.sensitivity_peak_hz:9.4g} {m.disk_margin:6.3f}")
    print("all loops scaled by one factor g:")
    for name, a in (("continuous", cont), (f"{1 / T:g} Hz", samp)):
        lo, hi = a.gain_margin_frf
        glo, ghi, phase = disk_gain_phase(a.disk_margin)
        eig = (f"; from the poles {rng.lower:.4g} < g < {_num(rng.upper, '.4g')}"
               if a is samp else "")
        print(f"  {name}: from the frequency response (det(I + g L) = 0) {lo:.4g} < g < "
              f"{_num(hi, '.4g')}{eig}; disk margin {a.disk_margin:.3f} (gains "
              f"{glo:.3g} .. {_num(ghi, '.3g')}, phase +-{phase:.1f} deg at once in every loop)")
