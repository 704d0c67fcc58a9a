"""``rotor-avc frf``: closed-loop unbalance FRFs over speed, as CSV and dB plots."""
from __future__ import annotations

import numpy as np

from ..closed_loop.frf import unbalance_frf
from ..machine import load_machine
from ..interactive.page import page_files
from ..reports.frf_files import plot_frf, write_frf_csv, write_frf_html
from ..output_files import make_folder
from ..studies.progress import Bars
from .common import add_speed_option, config_frf_speeds_hz, output_folder, speed_range_hz

NAME = "frf"
HELP = ("Synchronous (unbalance) frequency responses over rotor speed of every output and "
        "actuator force, written to DIR/frf.csv with dB plots and DIR/index.html (damping at "
        "w_F = Omega).")
EXAMPLE = "rotor-avc frf foot_mount_case3 --speed-hz 1:250:2000 --out out/case3"


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name")
    add_speed_option(p, speed_range_hz, "rotational frequencies in Hz (default: the config's "
                     "analysis.frf_speed_hz)", metavar="START:STOP:N")
    p.add_argument("--out", type=output_folder, required=True, help="output folder (created)")
    p.add_argument("--no-plots", action="store_true", help="write only frf.csv")


def run(args) -> int:
    machine = load_machine(args.config)
    speeds_hz = args.speed_hz
    if speeds_hz is None:
        speeds_hz = config_frf_speeds_hz(machine)
    frf = unbalance_frf(machine.loop, 2 * np.pi * speeds_hz)
    make_folder(args.out)
    csv_path = write_frf_csv(frf, args.out / "frf.csv")
    print(f"wrote {csv_path} ({len(frf.responses)} responses x {len(speeds_hz)} speeds)")
    if not args.no_plots:
        with Bars("figures") as bar:
            pngs = plot_frf(frf, args.out, machine.plant.name, progress=bar)
        for path in pngs:
            print(f"wrote {path}")
        for path in page_files(write_frf_html(frf, args.out / "index.html", machine.plant.name)):
            print(f"wrote {path}")
    return 0
