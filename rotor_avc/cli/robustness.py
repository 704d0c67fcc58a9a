"""``rotor-avc study robustness``: Monte-Carlo robustness of a machine's closed loop -- the
probability of stability and the distributions of peak response and stability margin when
config parameters are drawn from distributions (:mod:`rotor_avc.studies.robustness`). A mode of
``rotor-avc study`` (:mod:`rotor_avc.cli.study` parses its options), not a command of its own."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from ..config import load_config
from ..studies.backends import backend_from_args
from ..studies.engine import StudySpec, run_study
from ..studies.points import Sample, parse_sample
from ..studies.robustness import robustness_point, summarize

STATS = ("mean", "std", "min", "p5", "p50", "p95", "max")


def run(args) -> int:
    cfg = load_config(args.robustness_config)
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
             f"{'quantity':38s}{'unit':>14s}" + "".join(f"{s:>11s}" for s in STATS)]
    for name, m in summary["metrics"].items():
        lines.append(f"{name:38s}{unit_of(name):>14s}" + "".join(f"{m[s]:11.4g}" for s in STATS))
    return "\n".join(lines)


def write_summary(summary: dict, unit_of, folder: Path) -> list[Path]:
    """``summary.json`` (everything) and ``summary.csv`` (one row per quantity)."""
    js = folder / "summary.json"
    js.write_text(json.dumps(summary, indent=1) + "\n")
    path = folder / "summary.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["quantity", "unit"] + list(STATS))
        for name, m in summary["metrics"].items():
            w.writerow([name, unit_of(name)] + [repr(m[s]) for s in STATS])
    return [js, path]


def plot_distributions(records: list[dict], summary: dict, unit_of, path: Path) -> Path:
    """Histograms of the stability margin and of every peak response (5/50/95 % marked)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ["stability_margin_1_per_s"] + [n for n in summary["metrics"]
                                            if n.startswith("peak_") and "_speed_hz_" not in n]
    cols = min(4, len(names))
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 2.8 * rows), squeeze=False)
    for ax, name in zip(axes.flat, names):
        v = np.array([r[name] for r in records], dtype=float)
        ax.hist(v, bins=min(50, max(10, len(v) // 20)), color="tab:blue", alpha=0.8)
        for q in ("p5", "p50", "p95"):
            ax.axvline(summary["metrics"][name][q], color="k", ls=":" if q != "p50" else "-", lw=0.8)
        label = f"peak |{name[5:]}|" if name.startswith("peak_") else name
        ax.set_title(f"{label} [{unit_of(name)}]", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    fig.suptitle(f"{summary['points']} points: P(stable) = {summary['stability_probability']:.3f}; "
                 "lines: 5 / 50 / 95 % quantiles", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
