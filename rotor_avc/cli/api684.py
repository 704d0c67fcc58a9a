"""``rotor-avc api684``: API 684 unbalance-response checks of a machine model's critical speeds."""
from __future__ import annotations

import json

import numpy as np

from ..analysis.api684 import check_response, format_table
from ..closed_loop.frf import unbalance_frf
from ..errors import ConfigError
from ..machine import load_machine
from ..interactive.jsonable import jsonable
from .common import config_frf_speeds_hz, speed_range_hz
from .runup import operating_range

NAME = "api684"
HELP = ("API 684 unbalance-response checks of a machine model: per resonance of each response "
        "over speed, the critical speed, peak, half-power amplification factor and separation "
        "margin against the one the standard requires, with a verdict (see `rotor-avc runup` "
        "for a measured run-up).")
EXAMPLE = "rotor-avc api684 sleeve_bearing_motor --operating-hz 55:65 --speed-hz 5:75:1401"


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name")
    p.add_argument("--operating-hz", type=operating_range, required=True, metavar="MIN:MAX",
                   help="minimum and maximum continuous speed in Hz")
    p.add_argument("--speed-hz", type=speed_range_hz, default=None, metavar="START:STOP:N",
                   help="speed grid of the unbalance response (default: analysis.frf_speed_hz)")
    p.add_argument("--responses", nargs="+", default=None, metavar="NAME",
                   help="responses (<output>_<excitation>, as in frf.csv; default: every "
                        "bearing-housing output to every excitation)")
    p.add_argument("--json", action="store_true",
                   help='print {"operating_speed_hz": [MIN, MAX], "responses": {NAME: [checks]}}')


def run(args) -> int:
    machine = load_machine(args.config)
    speeds_hz = args.speed_hz
    if speeds_hz is None:
        speeds_hz = config_frf_speeds_hz(machine)
    frf = unbalance_frf(machine.loop, 2 * np.pi * speeds_hz)
    names = args.responses or [k for k in frf.responses if k.startswith("bearing")]
    unknown = [n for n in names if n not in frf.responses]
    if unknown:
        raise ConfigError("--responses", f"unknown response(s) {', '.join(unknown)}",
                          fix="known: " + ", ".join(frf.responses))
    checks = {n: check_response(speeds_hz, np.abs(frf.responses[n]), args.operating_hz)
              for n in names}
    if args.json:
        print(json.dumps(jsonable({"operating_speed_hz": list(args.operating_hz),
                                   "responses": {n: [c.row() for c in cs]
                                                 for n, cs in checks.items()}})))
        return 0
    print(f"{machine.plant.name}: API 684 checks of the unbalance response "
          f"({'closed loop' if machine.controllers else 'loops open'}, per unit excitation)")
    for n, cs in checks.items():
        print(f"\n{n}:")
        print(format_table(cs, frf.units[n], args.operating_hz))
    return 0
