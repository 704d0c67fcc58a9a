"""``rotor-avc study robustness``: Monte-Carlo robustness of a machine's closed loop -- the
probability of stability and the distributions of peak response and stability margin when
config parameters are drawn from distributions (:mod:`rotor_avc.analysis.robustness`). A mode of
``rotor-avc study`` (:mod:`rotor_avc.cli.study` dispatches to it), not a command of its own."""
from __future__ import annotations

from pathlib import Path

from ..analysis.robustness import grid_end_lines, robustness_point, summarize
from ..config import load_config
from ..reports.robustness_files import STATS, plot_distributions, write_summary
from ..studies.backends import backend_from_args
from ..studies.engine import StudySpec, run_study
from ..studies.points import Sample, parse_sample
from .common import add_speed_option, speed_range_hz

#: the options of this mode (argparse dest -> option), refused by the other studies
OPTIONS = {"sample": "--sample", "n": "--n", "seed": "--seed", "speed_hz": "--speed-hz",
           "response": "--response"}


def add_arguments(p) -> None:
    g = p.add_argument_group("robustness study (rotor-avc study robustness CONFIG ...)")
    g.add_argument("--sample", action="append", default=[], metavar="PATH=DIST",
                   help="sampled config path(s): PATH=normal(MEAN, STD), uniform(LOW, HIGH) or "
                        "lognormal(MU, SIGMA) (ln x ~ N(MU, SIGMA)); PATH*=... for a factor on "
                        "the base value; comma-join paths that take the same value (repeatable)")
    g.add_argument("--n", type=int, help="number of points (default 1000)")
    g.add_argument("--seed", type=int, help="study seed (default 0)")
    add_speed_option(g, speed_range_hz, "speeds of the peak responses (default: "
                     "analysis.frf_speed_hz)", metavar="START:STOP:N")
    g.add_argument("--response", action="append", metavar="NAME",
                   help="response whose peak is recorded (repeatable; default: every bearing "
                        "response, e.g. bearing_D_vz_static)")


def run(args) -> int:
    cfg = load_config(args.target)
    args.out = args.out or Path("out/robustness")
    sample = Sample([parse_sample(t) for t in args.sample], 1000 if args.n is None else args.n,
                    args.seed or 0, cfg)
    spec = StudySpec(sample, robustness_point(cfg, args.speed_hz, args.response))
    backend = backend_from_args(args.workers, args.scheduler)
    study = run_study(spec, backend, out=args.out, batch_size=args.batch_size)
    records = [o.record for o in study.outcomes if o.error is None]
    summary = summarize(records, len(study.failed))
    cost = (f", {study.cost_per_point_s * 1e3:.1f} ms per point" if study.cost_per_point_s
            else "")
    print(f"{len(sample)} points ({study.computed} computed in this run{cost}, "
          f"{study.elapsed_s:.1f} s on {backend.workers} worker(s), batches of "
          f"{study.batch_size})")
    print(table(summary, spec.evaluator.unit_of))
    for o in study.failed[:5]:
        print(f"  point {o.index} failed: {o.error}")
    paths = study.files + write_summary(summary, spec.evaluator.unit_of, args.out)
    if not args.no_plots and records:
        paths.append(plot_distributions(records, summary, spec.evaluator.unit_of,
                                        args.out / "robustness.png"))
    for path in paths:
        print(f"wrote {path}")
    return 0


def table(summary: dict, unit_of) -> str:
    lo, hi = summary["probability_95_low"], summary["probability_95_high"]
    lines = [f"stable: {summary['stable']} of {summary['points']} evaluated points -> probability "
             f"{summary['stability_probability']:.4f} (95 % interval {lo:.4f} .. {hi:.4f}); "
             f"{summary['failed']} failed",
             f"{'quantity':38s}{'unit':>14s}{'n':>6s}" + "".join(f"{s:>11s}" for s in STATS)]
    for name, m in summary["metrics"].items():
        lines.append(f"{name:38s}{unit_of(name):>14s}{m['n']:6d}"
                     + "".join(f"{m[s]:11.4g}" for s in STATS))
    return "\n".join(lines + grid_end_lines(summary))
