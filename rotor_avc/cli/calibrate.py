"""``rotor-avc calibrate``: fit machine parameters to recordings, with their uncertainty."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ..calibration.fit import IDENTIFIED_WITHIN, MAX_EVALUATIONS
from ..calibration.results import calibration_document
from ..calibration.problem import DEFAULT_SENSOR_UNCERTAINTY
from ..calibration.targets import DEFAULT_POINT_UNCERTAINTY
from ..calibration.session import CALIBRATED, run_calibration, write_configs
from ..errors import ConfigError
from ..output_files import make_folder, write_text
from ..reports.calibration_report import write_calibration_html
from ..studies.backends import add_backend_arguments, backend_from_args, check_scheduler_arg
from ..studies.progress import clock_text
from .common import nonnegative_float, output_folder

NAME = "calibrate"
HELP = ("Fit declared parameters of a machine configuration (masses, stiffnesses, loss factors, "
        "bearing and controller values) to recordings taken as `compare` takes them: the "
        "measured 1x per dwell and channel (and H1 where the run had a test force), each "
        "weighted by its uncertainty; sensitivities first (parameters the data do not determine "
        "are reported as not identifiable, with the reason, and keep their configured values), "
        "then a bounded least-squares fit. Writes DIR/calibration.json (values, standard "
        "deviations, 95-percent intervals, correlation, residual and compare verdicts before and "
        "after, validation on --validate recordings), DIR/calibrated.yaml (the configuration "
        "with the fitted values: `compare DATA --config DIR/calibrated.yaml` uses it) and "
        "DIR/index.html. Exit status 0 when every fitted recording compares PASS with the "
        "calibrated machine (measured FRFs have no compare verdict), 1 otherwise, 2 for bad "
        "input or a fit that does not converge.")
EXAMPLE = ("rotor-avc calibrate recording/ --config machine.yaml --map sensors.yaml "
           "--fit elements.actuator.stiffness_n_per_m.z,foundation.tan_delta "
           "--validate runup/ --out out/calibration")


def add_arguments(p) -> None:
    p.add_argument("data", nargs="+", type=Path,
                   help="recordings to fit: bags this package wrote, or with --map any .mcap "
                        "file or rosbag2 directory; UFF 58 files (.uff, .unv) of measured FRFs "
                        "with --uff-map")
    p.add_argument("--config", required=True,
                   help="the machine configuration to calibrate (a YAML path or a shipped name)")
    p.add_argument("--map", type=Path, help="mapping file of the recordings (as for compare)")
    p.add_argument("--uff-map", type=Path,
                   help="mapping file of UFF 58 files among DATA (measured FRFs: input "
                        "actuator, responses by node and direction, speed; README)")
    p.add_argument("--fit", action="append", required=True, metavar="PATH[,PATH...]",
                   help="declared numeric configuration paths to fit (rotor-avc config "
                        "reference); PATH* fits a factor on every number under PATH (e.g. a "
                        "stiffness triple)")
    p.add_argument("--bounds", action="append", default=[], metavar="PATH=LO:HI",
                   help="bounds of a fitted value (default: a tenth to ten times the "
                        "configured value, inside the declared range)")
    p.add_argument("--prior", action="append", default=[], metavar="PATH=normal(MEAN,STD)",
                   help="a Gaussian prior of a fitted value (the fit becomes the maximum a "
                        "posteriori estimate)")
    p.add_argument("--validate", nargs="+", type=Path, default=[], metavar="DATA",
                   help="held-out recordings (same --map): compared before and after, never "
                        "fitted")
    p.add_argument("--starts", type=int, default=0, metavar="N",
                   help="N more seeded starts inside the bounds, each fitted on the study "
                        "engine, against local minima (default 0)")
    p.add_argument("--seed", type=int, default=0, help="seed of the extra starts (default 0)")
    p.add_argument("--sensor-uncertainty", type=nonnegative_float,
                   default=DEFAULT_SENSOR_UNCERTAINTY, metavar="REL",
                   help="relative calibration uncertainty of each sensor channel, a gain and "
                        "phase error shared by all its points (default "
                        f"{DEFAULT_SENSOR_UNCERTAINTY:g}; 0: exact sensors)")
    p.add_argument("--point-uncertainty", type=nonnegative_float,
                   default=DEFAULT_POINT_UNCERTAINTY, metavar="REL",
                   help="relative uncertainty of each measured point beyond its random error "
                        "(leakage, interpolation, jitter; default "
                        f"{DEFAULT_POINT_UNCERTAINTY:g})")
    p.add_argument("--identified-within", type=nonnegative_float, default=IDENTIFIED_WITHIN,
                   metavar="REL", help="a fitted parameter counts as identified when its 95 "
                   "percent interval lies within +-REL of its value (default "
                   f"{IDENTIFIED_WITHIN:g}); a wider one is reported uncertain")
    p.add_argument("--out", type=output_folder, default=None,
                   help="output folder (created; default: out/calibration)")
    add_backend_arguments(p)


class Progress:
    """One line per Jacobian on stderr: evaluations, cost, elapsed time and at most how long the
    evaluation budget leaves."""

    def __init__(self):
        self.t0 = time.perf_counter()

    def __call__(self, evaluations: int, cost: float) -> None:
        elapsed = time.perf_counter() - self.t0
        left = elapsed / max(evaluations, 1) * max(MAX_EVALUATIONS - evaluations, 0)
        print(f"calibrate: {evaluations} model evaluations, cost {cost:.6g}, "
              f"{clock_text(elapsed)} elapsed (at most {clock_text(left)} more)",
              file=sys.stderr, flush=True)


def run(args) -> int:
    check_scheduler_arg(args.scheduler)
    if args.starts < 0:
        raise ConfigError("--starts", f"must be >= 0 (got {args.starts})", fix="give --starts 4")
    backend = backend_from_args(args.workers, args.scheduler)
    cal = run_calibration(args.data, args.config, args.map, args.fit, args.bounds, args.prior,
                          args.validate, backend, args.starts, args.seed, args.sensor_uncertainty, Progress(),
                          args.batch_size, args.uff_map, args.point_uncertainty,
                          args.identified_within)
    out = args.out if args.out is not None else Path("out") / "calibration"
    doc = calibration_document(cal)
    make_folder(out)
    write_configs(out, cal)
    write_text(out / "calibration.json", json.dumps(doc, indent=1))
    channels = [c for t in cal.curves[:len(cal.fitted)] for c in t["target"].point_channels()]
    write_calibration_html(cal, doc, out / "index.html", channels)
    summary(doc, out)
    verdicts = [r["calibrated"]["verdict"] for r in doc["data"]
                if r["calibrated"]["verdict"] is not None]
    return 0 if all(v == "PASS" for v in verdicts) else 1


def summary(doc: dict, out: Path) -> None:
    for p in doc["parameters"]:
        if p["fitted"]:
            lo, hi = p["ci95"]
            why = "" if p["identifiable"] else f"; {p['reason']}"
            print(f"  {p['path']}: {p['value']:.6g} {p['unit']} (configured {p['initial']:.6g}; "
                  f"95 % interval [{lo:.6g}, {hi:.6g}]{why})")
        else:
            print(f"  {p['path']}: not identifiable, kept at {p['initial']:.6g} {p['unit']} "
                  f"({p['reason']})")
    res = doc["residual"]
    print(f"reduced chi-square {res['before']:.4g} -> {res['after']:.4g}")
    for kind, rows in (("fitted", doc["data"]), ("held out", doc["validation"])):
        for r in rows:
            before, after = r["configured"]["verdict"], r["calibrated"]["verdict"]
            verdicts = ("measured FRFs" if before is None
                        else f"compare {before} -> {after}")
            print(f"  {kind} {r['data']}: {verdicts}; chi2 {r['configured']['chi2']:.4g} -> "
                  f"{r['calibrated']['chi2']:.4g}")
    print(f"-> {out / CALIBRATED}; report: {out / 'index.html'}")
