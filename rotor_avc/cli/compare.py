"""``rotor-avc compare``: a recorded bag against the analytical models, from the bag alone."""
from __future__ import annotations

import math
from pathlib import Path

from ..compare.checks import EXIT_NO_VERDICT
from ..compare.comparison import compare_bag
from ..compare.iso_zones import format_iso_table, iso20816_entries
from ..compare.left_out import left_out_points
from ..compare.mapped_stream import compare_mapped
from ..errors import ConfigError
from ..compare.report import ACCEPTANCE, write_report
from ..machine import load_machine
from ..studies.progress import Bars
from .common import output_folder

NAME = "compare"
HELP = ("Compare a recorded run (.mcap bag) with the continuous and the sampled-loop model built "
        "from the bag's own configuration: 1x response per speed (order tracking), broadband "
        "FRFs (H1/H2) when the run had a test force; writes DIR/index.html, PNG plots, frf.csv, "
        "frf.uff (UFF type 58: measured and model FRFs, coherence, SI units) and metrics.json "
        "(with the ISO 20816-3 zone of each bearing-housing channel, `analysis.iso20816`). "
        "Exit status 1 when a check fails (magnitude, phase, dead channels), 5 when nothing "
        "could be rated (no verdict, with the reason), 2 for an unreadable bag, 3 for a "
        "recording with missing samples (checked first: stamps contiguous at the run's period, "
        "counts equal across the plant's topics, published = recorded), 4 for a corrupted bag. "
        "A recording of any machine (a .mcap file or a rosbag2 directory, e.g. from `ros2 bag "
        "record`) compares with --config MACHINE.yaml --map MAP.yaml: the mapping says which "
        "topic and field is which model signal; each channel's 1x is fitted at its own stamps "
        "over windows of whole shaft revolutions (streamed chunk by chunk; with a test force "
        "the channels are resampled onto the configuration's sample grid for the broadband "
        "estimate) and the report lists rate, jitter and dropouts per channel, the shaft's "
        "pulses and dwells and the coherence per output.")
EXAMPLE = ("rotor-avc compare bags/reference/case3_stepped.mcap --out out/compare_case3\n"
           "  rotor-avc compare recording/ --config machine.yaml --map sensors.yaml --out out/real")


def add_arguments(p) -> None:
    p.add_argument("bag", type=Path, help="the recorded run: a .mcap bag with the run's "
                                          "configuration (rotor-avc simulate --out, recorder), "
                                          "or any .mcap file or rosbag2 directory with --map")
    p.add_argument("--config", help="machine config of the recorded machine (with --map; a "
                                    "`simulation:` section is optional: sample rate, unbalance, "
                                    "test_signal; speeds and duration come from the recording); "
                                    "for a bag this package wrote, the machine the recorded run "
                                    "is compared with instead of the bag's own (e.g. a "
                                    "calibrated one)")
    p.add_argument("--map", type=Path, help="mapping file: topics and fields -> model signals, "
                                            "shaft source, unbalance reference (README)")
    p.add_argument("--out", type=output_folder, default=None,
                   help="report folder (created; default: out/compare_<bag name>)")
    p.add_argument("--in-memory", action="store_true",
                   help="read the whole bag into memory first instead of streaming it dwell by "
                        "dwell (same result; memory grows with the recording); a mapped "
                        "recording is then resampled onto the grid")


def run(args) -> int:
    if args.map is not None and args.config is None:
        raise ConfigError("--map", "a mapped comparison needs the machine too",
                          fix="give --config MACHINE.yaml with --map MAP.yaml")
    with Bars("s of recording") as passes:     # each pass over a streamed bag
        if args.map is None:
            machine = None if args.config is None else load_machine(args.config)
            comp = compare_bag(args.bag, in_memory=args.in_memory, machine=machine,
                               progress=passes)
        else:
            comp = compare_mapped(args.bag, args.config, args.map, args.in_memory)
        out = args.out if args.out is not None else Path("out") / f"compare_{args.bag.stem}"
        report(comp, args.bag, out)
    return {"PASS": 0, "FAIL": 1}.get(comp.verdict, EXIT_NO_VERDICT)


def report(comp, bag, out: Path) -> dict:
    """Write the report folder and print the summary; returns the report's files."""
    from ..reports.uff_files import write_uff      # pyuff: imported only to write the file
    iso, iso_notes = iso20816_entries(comp.run)
    comp.notes.extend(iso_notes)
    with Bars("figures") as bar:
        files = write_report(comp, out, iso, progress=bar)
    uff = write_uff(comp, out / "frf.uff")
    if uff is not None:
        files["uff"] = uff
    run_ = comp.run
    sc = run_.scenario
    print(f"{bag}: {sc.machine.plant.name}, {1 / run_.sample_period_s:g} Hz, "
          f"{sc.damping.describe()}")
    if comp.one_x is not None:
        speeds = ", ".join(f"{f:g}" for f in comp.one_x.speed_rad_s / (2 * math.pi))
        print(f"1x: {comp.one_x.method} at {speeds} Hz; {comp.one_x.reference}")
    for bb in comp.broadband:
        print(f"broadband: H1/H2 at {bb.speed_rad_s / (2 * math.pi):g} Hz, "
              f"{bb.estimate.averages} averages of {bb.estimate.nperseg} samples")
    for c in comp.checks:
        verdict = {True: "pass", False: "FAIL", None: "  - "}[c.passed]
        value = "-" if c.value is None else f"{c.value:.3g} {c.unit}"
        print(f"  {verdict:4s}  {c.name}: {value} (tolerance {c.tolerance:g} {c.unit}); "
              f"{c.detail}")
    print(format_iso_table(iso))
    for note in comp.notes:
        print(f"  note: {note}")
    why = f" ({comp.no_verdict_reason})" if comp.no_verdict_reason else ""
    left = left_out_points(comp)
    for note in left.notes():
        print(f"  left out: {note}")
    counted = f", {left.summary()}" if left.summary() else ""
    print(f"{ACCEPTANCE}\n-> {comp.verdict}{why}{counted}; report: {files['index']}")
    return files
