"""``rotor-avc api684``: API 684 unbalance-response checks of a machine model's critical speeds,
an overall verdict (exit status 1 when a requirement fails) and, with ``--out``, ``api684.json``
and the picture ``api684.png`` (:mod:`rotor_avc.reports.api684_plot`)."""
from __future__ import annotations

import json

import numpy as np

from ..analysis.api684 import (check_response, damping_rule, format_table, overall_verdict,
                               verdict_line)
from ..closed_loop.frf import unbalance_frf
from ..errors import ConfigError
from ..machine import load_machine
from ..interactive.jsonable import jsonable
from ..output_files import make_folder, write_text
from ..reports.api684_plot import plot_api684
from .common import add_speed_option, config_frf_speeds_hz, output_folder, speed_range_hz
from .runup import operating_range

NAME = "api684"
HELP = ("API 684 unbalance-response checks of a machine model: per resonance of each response "
        "over speed, the critical speed, peak, half-power amplification factor and separation "
        "margin against the one the standard requires, with a verdict (see `rotor-avc runup` "
        "for a measured run-up). Ends with one verdict line; exit status 1 when a requirement "
        "fails.")
EXAMPLE = ("rotor-avc api684 sleeve_bearing_motor --operating-hz 55:65 --speed-hz 5:75:1401 "
           "--out out/api684")


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name")
    p.add_argument("--operating-hz", type=operating_range, required=True, metavar="MIN:MAX",
                   help="minimum and maximum continuous speed in Hz")
    add_speed_option(p, speed_range_hz, "speed grid of the unbalance response (default: "
                     "analysis.frf_speed_hz)", metavar="START:STOP:N")
    p.add_argument("--responses", nargs="+", default=None, metavar="NAME",
                   help="responses (<output>_<excitation>, as in frf.csv; default: every "
                        "bearing-housing output to every excitation)")
    p.add_argument("--json", action="store_true",
                   help='print {"operating_speed_hz": [MIN, MAX], "damping_rule": TEXT, '
                        '"verdict": {...}, "responses": {NAME: [checks]}}')
    p.add_argument("--out", type=output_folder, default=None, metavar="DIR",
                   help="also write DIR/api684.json (the --json document) and DIR/api684.png "
                        "(amplitude over speed, critical speeds, half-power bands, separation "
                        "margins, operating range)")


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
    verdict = overall_verdict(checks)
    rule = damping_rule(machine.analysis.damping_floor_hz, speeds_hz)
    document = jsonable({"machine": machine.plant.name,
                         "operating_speed_hz": list(args.operating_hz), "damping_rule": rule,
                         "verdict": verdict,
                         "responses": {n: [c.row() for c in cs] for n, cs in checks.items()}})
    loops = "closed loop" if machine.controllers else "loops open"
    if args.json:
        print(json.dumps(document))
    else:
        print(f"{machine.plant.name}: API 684 checks of the unbalance response ({loops}, per "
              f"unit excitation)\ndamping: {rule}")
        for n, cs in checks.items():
            print(f"\n{n}:")
            print(format_table(cs, frf.units[n], args.operating_hz))
    if args.out is not None:
        make_folder(args.out)
        paths = [write_text(args.out / "api684.json", json.dumps(document, indent=1) + "\n"),
                 plot_api684(args.out / "api684.png", speeds_hz,
                             {n: np.abs(frf.responses[n]) for n in names}, frf.units, checks,
                             args.operating_hz, f"{machine.plant.name} ({loops})")]
        if not args.json:
            print("\n" + "\n".join(f"wrote {p}" for p in paths))
    if not args.json:
        print("\n" + verdict_line(verdict))
    return 1 if verdict["verdict"] == "FAIL" else 0
