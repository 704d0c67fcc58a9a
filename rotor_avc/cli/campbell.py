"""``rotor-avc campbell``: Campbell diagram of a machine, loops open or closed."""
from __future__ import annotations

import dataclasses
import json

import numpy as np

from ..analysis.campbell import DAMPING_RULES, campbell_diagram
from ..analysis.mode_shapes import dominant_parts
from ..errors import ConfigError
from ..machine import load_machine
from ..reports.campbell_plot import COLOUR_BY, plot_campbell
from ..reports.campbell_report import write_campbell_html
from ..output_files import make_folder, open_text
from ..studies.progress import Bars
from .common import (add_speed_option, config_frf_speeds_hz, output_folder,
                     speed_range_from_zero_hz)

NAME = "campbell"
HELP = ("Campbell diagram: every mode's damped natural frequency and damping over rotor speed "
        "(modes tracked by eigenvector similarity), its whirl direction and mode shape, the 1x/2x "
        "lines, critical speeds and onsets of instability; poles as `rotor-avc poles` gives them "
        "at each speed.")
EXAMPLE = "rotor-avc campbell foot_mount_case3 --speed-hz 0:250:200 --out out/campbell"


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name")
    add_speed_option(p, speed_range_from_zero_hz, "rotor speeds in Hz (START >= 0; default: "
                     "the config's analysis.frf_speed_hz)", metavar="START:STOP:N")
    loops = p.add_mutually_exclusive_group()
    loops.add_argument("--closed", action="store_true",
                       help="loops closed with the config's controllers (the default where it has any)")
    loops.add_argument("--open", action="store_true", help="loops open (controllers removed)")
    p.add_argument("--sampled", action="store_true",
                   help="poles of the sampled loop (the digital controllers at the config's "
                        "control.sample_rate_hz) as s = ln(z)/T, at the rule's damping frequency")
    p.add_argument("--damping", choices=list(DAMPING_RULES), default="config",
                   help="loss-factor damping rule: config = the config's analysis.pole_method "
                        "(as `rotor-avc poles`), forced = w_F = max(Omega, floor), or a pole method")
    p.add_argument("--colour", choices=list(COLOUR_BY), default="damping-ratio",
                   help="colour the modes by damping ratio or logarithmic decrement")
    p.add_argument("--orders", type=_orders, default=(1, 2), metavar="K,K",
                   help="excitation orders for the lines and critical speeds (default 1,2)")
    p.add_argument("--max-freq-hz", type=float, default=None,
                   help="top of the plot's frequency axis (default 1.2 x the highest frequency of "
                        "the modes below the highest speed)")
    p.add_argument("--running-hz", type=float, default=None, metavar="HZ",
                   help="speed at which whirl direction and mode shapes are reported (the "
                        "nearest grid speed; default the highest)")
    p.add_argument("--speed-unit", choices=("hz", "rpm"), default="hz",
                   help="speed axis of the PNG and the report's initial choice")
    p.add_argument("--json", action="store_true",
                   help='print {"speed_hz": [...], "modes": [{"label", "freq_hz", "damping_ratio", '
                        '"whirl", "shape": [{"coordinate", "magnitude", "phase_deg"}]}], '
                        '"critical_speeds": [{"mode", "order", "speed_hz"}], "reference_speed_hz", '
                        '"damping_rule"}')
    p.add_argument("--out", type=output_folder, help="folder for campbell.png, campbell.json and index.html")


def _orders(text: str) -> tuple[int, ...]:
    import argparse
    try:
        orders = tuple(int(t) for t in text.split(","))
    except ValueError:
        orders = ()
    if not orders or min(orders) < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: give positive integers, e.g. 1,2")
    return orders


def selected_machine(config, closed: bool, open_: bool):
    """The machine with its loops as asked: the config's by default, open, or closed (refused
    when the config has no controllers)."""
    machine = load_machine(config)
    if closed and not machine.controllers:
        raise ConfigError("controllers", "--closed asked, but the config has no controllers",
                          fix="add controllers to the config or drop --closed",
                          source=machine.config.source)
    return dataclasses.replace(machine, controllers={}) if open_ else machine


def run(args) -> int:
    machine = selected_machine(args.config, args.closed, args.open)
    if args.speed_hz is None:
        args.speed_hz = config_frf_speeds_hz(machine)
    speeds = np.asarray(args.speed_hz, dtype=float)
    if args.running_hz is not None and not speeds.min() <= args.running_hz <= speeds.max():
        raise ConfigError("--running-hz", f"{args.running_hz:g} Hz lies outside the speed grid "
                          f"{speeds.min():g} .. {speeds.max():g} Hz",
                          fix="give a speed within --speed-hz")
    with Bars("speeds") as bar:
        cd = campbell_diagram(machine, 2 * np.pi * args.speed_hz, args.damping, args.sampled,
                              progress=bar)
    data = cd.to_json(args.orders, args.running_hz)
    if args.json:
        print(json.dumps(data))
    loops = ("sampled closed loop" if args.sampled else "closed loop") if machine.controllers \
        else "loops open"
    title = f"{machine.plant.name}: Campbell diagram ({loops}; damping {cd.damping_rule})"
    if args.out:
        make_folder(args.out)
        onsets = cd.instability_onsets()
        with open_text(args.out / "campbell.json") as fh:
            json.dump({**data, "instability_onsets": onsets, "loops": loops,
                       "damping": args.damping, "machine": machine.plant.name}, fh, indent=1)
        png = plot_campbell(cd, args.out / "campbell.png", title, args.colour, args.orders,
                            args.max_freq_hz, args.speed_unit, args.running_hz)
        report = write_campbell_html(cd, args.out / "index.html", title, args.colour, args.orders,
                                     args.max_freq_hz, args.speed_unit, args.running_hz)
        if not args.json:
            print(f"wrote {args.out / 'campbell.json'}, {png} and {report}")
    if not args.json:
        _print_summary(cd, title, args.orders, cd.reference_index(args.running_hz))
    return 0


def _print_summary(cd, title: str, orders, ref: int) -> None:
    s = cd.speed_hz
    print(title)
    print(f"whirl and dominant coordinates at {s[ref]:g} Hz")
    print(f"{'mode':>28} {f'f at {s[0]:g} Hz':>14} {f'f at {s[-1]:g} Hz':>14} {'min zeta':>9} "
          f"{'whirl':>8}  dominant coordinates")
    whirl = cd.whirl(ref)
    for k, label in enumerate(cd.labels):
        print(f"{label:>28} {cd.freq_hz[0, k]:14.3f} {cd.freq_hz[-1, k]:14.3f} "
              f"{cd.damping_ratio[:, k].min():9.4f} {whirl[k]:>8}  "
              f"{dominant_parts(cd.shapes[ref, :, k], cd.geometry)}")
    for r in cd.critical_speeds(orders):
        print(f"critical speed {r['speed_hz']:10.3f} Hz ({r['speed_hz'] * 60:9.1f} rpm): "
              f"{r['mode']}, order {r['order']}")
    onsets = cd.instability_onsets()
    for r in onsets:
        print(f"onset of instability {r['speed_hz']:10.3f} Hz ({r['speed_hz'] * 60:9.1f} rpm): "
              f"{r['mode']} at {r['freq_hz']:.3f} Hz")
    if not onsets:
        print("no onset of instability in the speed range")
