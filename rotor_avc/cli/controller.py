"""``rotor-avc controller``: one foot's controller, continuous and discrete, and its gain margin."""
from __future__ import annotations

import argparse
import math

from ..analysis.design_check import DesignError, check_design
from ..analysis.poles import machine_poles
from ..analysis.sampled_loop import SampledLoop, machine_sampled_loop
from ..control.block import build_digital_controllers
from ..errors import ModelError
from ..machine import load_machine
from ..reports.controller_bode import plot_bode
from ..output_files import make_folder
from .common import nonnegative_float, output_folder, warn

NAME = "controller"
HELP = ("Print a foot controller's continuous G_c(s) and discrete G_d(z) coefficients, plot "
        "G_c(jw) against G_d(e^{jwT}) and print the stable gain range of the sampled loop.")
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
    p.add_argument("--speed-hz", type=nonnegative_float, default=0.0,
                   help="rotor speed of the gain-range search in Hz (default 0); damping at the "
                        "w_F of the config's continuous pole procedure")
    p.add_argument("--out", type=output_folder, default=".",
                   help="folder for controller_<foot>_bode.png (default: current folder)")


def run(args) -> int:
    machine = load_machine(args.config)
    if args.foot not in machine.controllers:
        known = ", ".join(machine.controllers) or "none"
        raise ModelError(f"--foot {args.foot}: no controller at that foot; controlled feet: {known}")
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
    fmt = lambda v: "[" + ", ".join(f"{x:.10g}" for x in v) + "]"  # noqa: E731
    print(f"{machine.plant.name} foot {args.foot}: {ctrl.describe()}  (force = -G_c * signal)")
    print(f"continuous G_c(s): num = {fmt(ctrl.num)}, den = {fmt(ctrl.den)}")
    print("discrete " + block.describe())
    make_folder(args.out)
    path = plot_bode(ctrl, block.tf, args.out / f"controller_{args.foot}_bode.png",
                     f"{machine.plant.name} {args.foot}: {ctrl.describe()}")
    print(f"wrote {path}")
    rng = SampledLoop.from_blocks(machine.plant, blocks).stable_gain_range(speed, w_F)
    print(f"stable gain range of the sampled loop (all {len(blocks)} controllers scaled by g; "
          f"f_r = {args.speed_hz:g} Hz, w_F = {w_F:.1f} rad/s):")
    nominal = {k: ", ".join(f"{name} {v * rng.lower:.4g} .. "
                            + ("inf" if math.isinf(rng.upper) else f"{v * rng.upper:.4g}")
                            for name, v in c.gains if name in GAIN_KEYS)
               for k, c in machine.controllers.items() if c.gains and rng.found}
    print("  " + rng.describe(nominal))
    return 0
