"""``rotor-avc runup``: the views of a recorded run-up -- waterfall, 1x Bode and polar plots,
orbits and API 684 checks, measured and modelled."""
from __future__ import annotations

import argparse
import json
from functools import partial
from pathlib import Path

import numpy as np

from ..analysis.api684 import format_table, overall_verdict, verdict_line
from ..compare.iso_zones import format_iso_table, iso20816_entries
from ..compare.mapped_run import read_mapped_run
from ..compare.recorded_run import read_run
from ..errors import ConfigError
from ..compare.runup_views import (api684_tables, channel_unit, housing_channels, one_x_track,
                                    orbit_pairs, orbits, run_waterfall)
from ..interactive.jsonable import jsonable
from ..interactive.page import page_files
from ..reports.runup_plots import plot_bode, plot_orbits, plot_polar, plot_waterfall
from ..reports.runup_report import api_rows, write_runup_html
from ..output_files import make_folder, write_text
from ..studies.progress import run_each
from .common import output_folder

NAME = "runup"
HELP = ("Run-up views of a bag: waterfall (spectra over speed, orders marked), 1x Bode and polar "
        "plots per channel against the bag's model, bearing-housing orbits, API 684 "
        "unbalance-response checks of the measured and the modelled 1x, and the ISO 20816-3 "
        "zone of each bearing-housing channel (largest 1 s r.m.s. velocity of the run, "
        "`analysis.iso20816`; metrics.json). Exit status 1 when an API 684 row fails.")
EXAMPLE = ("rotor-avc runup runup.mcap --operating-hz 28:30 --orbit-hz 10,20 --out out/runup\n"
           "  rotor-avc runup rig_runup/ --config machine.yaml --map map.yaml --out out/rig")


def _hz_list(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if not values or min(values) <= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: give positive speeds in Hz, e.g. 10,20")
    return values


def operating_range(text: str) -> tuple[float, float]:
    """``MIN:MAX`` in Hz -> (min, max), 0 < MIN <= MAX."""
    try:
        lo, hi = (float(v) for v in text.split(":"))
    except ValueError:
        lo = hi = -1.0
    if not 0 < lo <= hi:
        raise argparse.ArgumentTypeError(f"{text!r}: give MIN:MAX in Hz with 0 < MIN <= MAX")
    return lo, hi


def add_arguments(p) -> None:
    p.add_argument("bag", type=Path, help="a run-up recorded by `rotor-avc simulate` or the "
                                          "recorder, or any recording with --config and --map")
    p.add_argument("--config", help="machine config of the recorded machine (with --map), as "
                                    "`rotor-avc compare` takes it")
    p.add_argument("--map", type=Path, help="mapping file of the recording (with --config)")
    p.add_argument("--out", type=output_folder, required=True, help="output folder (created)")
    p.add_argument("--channels", nargs="+", default=None, metavar="NAME",
                   help="channels for the 1x plots, orbits and API 684 checks (default: the "
                        "bearing housings' outputs, else every output of the plant)")
    p.add_argument("--waterfall-channel", default=None,
                   help="channel of the waterfall (default: the first of --channels)")
    p.add_argument("--window-s", type=float, default=1.0, help="waterfall window length [s]")
    p.add_argument("--orbit-hz", type=_hz_list, default=None, metavar="F,F",
                   help="speeds of the orbit plots in Hz (default: 1/3 and 2/3 of the top speed)")
    p.add_argument("--operating-hz", type=operating_range, default=None, metavar="MIN:MAX",
                   help="operating speed range for the API 684 separation margins (default: the "
                        "speed the run ends at)")
    p.add_argument("--speed-unit", choices=("hz", "rpm"), default="hz",
                   help="speed axis of the PNGs and the report's initial choice (default Hz, as "
                        "every report)")


def run(args) -> int:
    if (args.config is None) != (args.map is None):
        raise ConfigError("--config/--map", "a mapped recording needs both",
                          fix="give --config MACHINE.yaml and --map MAP.yaml, or neither for a "
                              "bag this package wrote")
    run_ = (read_run(args.bag) if args.map is None
            else read_mapped_run(args.bag, args.config, args.map))
    channels = args.channels or housing_channels(run_)
    track = one_x_track(run_, channels)
    top_hz = float(track.speed_hz.max())
    operating = args.operating_hz or (float(run_.speed_rad_s[-1] / (2 * np.pi)),) * 2
    wf_channel = args.waterfall_channel or channels[0]
    wf = run_waterfall(run_, wf_channel, args.window_s)
    orbit_speeds = args.orbit_hz or [top_hz / 3, 2 * top_hz / 3]
    orbs = orbits(run_, track, orbit_speeds)
    tables = api684_tables(track, operating)
    iso, iso_notes = iso20816_entries(run_, whole_run=True)
    verdict = overall_verdict({f"{c} ({kind})": checks for c, both in tables.items()
                               for kind, checks in both.items()})
    make_folder(args.out)
    unit = args.speed_unit
    figures = [partial(plot_waterfall, wf, channel_unit(run_, wf_channel),
                       args.out / "waterfall.png", unit)]
    for c in channels:
        figures += [partial(plot_bode, track, c, args.out / f"bode_{c}.png", unit),
                    partial(plot_polar, track, c, args.out / f"polar_{c}.png", unit)]
    if orbs:
        figures.append(partial(plot_orbits, orbs, args.out / "orbits.png", unit))
    written = run_each(figures, "figures")
    write_text(args.out / "api684.json", json.dumps(jsonable({
        "operating_speed_hz": list(operating),
        "channels": {c: {k: api_rows(v) for k, v in both.items()} for c, both in tables.items()}}),
        indent=1))
    write_text(args.out / "metrics.json", json.dumps(jsonable({
        "api684": verdict,
        "iso20816": iso}), indent=1))
    name = run_.machine.plant.name
    summary = [("bag", str(run_.path)), ("machine", name),
               ("speed range", f"{track.speed_hz.min():.4g} .. {top_hz:.4g} Hz"),
               ("sample rate", f"{1 / run_.sample_period_s:g} Hz"),
               ("damping", run_.scenario.damping.describe()),
               ("1x order tracking", track.method)]
    report = write_runup_html(args.out / "index.html", f"{name}: run-up", summary,
                              run_.notes + iso_notes, verdict, wf, channel_unit(run_, wf_channel),
                              track, orbs, tables, operating, unit, iso)
    for c, both in tables.items():
        for kind, checks in both.items():
            print(f"API 684, {c} ({kind}):")
            print(format_table(checks, track.units[c], operating))
    print(format_iso_table(iso))
    for note in iso_notes:
        print(f"  note: {note}")
    if not orbit_pairs(run_, channels):
        print("no orbit: the channels hold no point with two transverse outputs of one kind")
    for path in written + [args.out / "api684.json", args.out / "metrics.json",
                           *page_files(report)]:
        print(f"wrote {path}")
    print(f"-> {verdict_line(verdict)}")
    return 1 if verdict["failed"] else 0

