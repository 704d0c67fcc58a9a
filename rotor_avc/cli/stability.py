"""``rotor-avc stability``: threshold of stability (Werner 2017's procedure) and parameter maps."""
from __future__ import annotations

import json

from ..analysis.stability_study import (RAD_S_PER_RPM, machine_threshold, parse_vary, run_study,
                                        study_from_config, threshold_settings, with_variants)
from ..analysis.stability_threshold import STATUSES
from ..config import load_config
from ..errors import ConfigError
from ..reports.stability_files import plot_campbell, plot_map, write_study_rows, write_threshold
from ..reports.stability_report import write_stability_study_html
from ..studies.backends import (BACKEND_OPTIONS, add_backend_arguments, backend_from_args,
                                check_scheduler_arg)
from ..output_files import make_folder
from .common import output_folder

NAME = "stability"
HELP = ("Threshold of stability of a machine with loss-factor and internal damping (eigenvalues "
        "over speed, whirl-frequency iteration; Werner 2017), or maps of it over one or two "
        "config parameters, with a Campbell-style eigenvalue plot.")
EXAMPLE = ("rotor-avc stability roller_bearing_stability --vary "
           "'foundation.stiffness_n_per_m.z,foundation.stiffness_n_per_m.y=2.0e+7:7.5e+8:15' --out out/stab")


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name "
                                  "(roller_bearing_stability)")
    p.add_argument("--variant", action="append", default=[], metavar="NAME",
                   help="apply a variant of the config's `variants:` section (repeatable, in order; "
                        "e.g. d = rigid foundation, demo, velocity_feedback)")
    p.add_argument("--study", metavar="NAME",
                   help="run a study of the config's `studies:` section (e.g. fig7, velocity_feedback)")
    p.add_argument("--vary", action="append", default=[], metavar="PARAM=START:STOP:N",
                   help="vary a dotted config path (once or twice for a 2-D map); comma-join paths "
                        "that take the same value, `*=` for factors on the base values, "
                        "START:STOP:N:log for log spacing or [v1,v2,...] for a list")
    p.add_argument("--out", type=output_folder, help="folder for threshold.json / thresholds.csv and plots "
                                            "(a map's points also go to DIR/points/, resumed)")
    p.add_argument("--json", action="store_true",
                   help='print {"threshold_rpm", "whirl_rad_s", "critical_mode"} (threshold_rpm null '
                        'when none is found); with --vary/--study {"points": [...], "maximum": ...}')
    add_backend_arguments(p)


def run(args) -> int:
    check_scheduler_arg(args.scheduler)
    if not (args.study or args.vary):
        given = [opt for dest, opt in BACKEND_OPTIONS.items() if getattr(args, dest) is not None]
        if given:
            raise ConfigError(given[0], "applies to maps (--vary, --study) only",
                              fix="leave it out for a single threshold")
    cfg = with_variants(load_config(args.config), args.variant)
    if args.study and args.vary:
        raise ConfigError("--vary", "--study and --vary both given",
                          fix="give either a named study or the parameters to vary")
    if args.study:
        cfg, varies = study_from_config(cfg, args.study)
    else:
        varies = [parse_vary(text) for text in args.vary]
    if args.out:
        make_folder(args.out)
    if varies:
        return _run_study(cfg, varies, args)
    machine, result = machine_threshold(cfg)
    if args.json:
        print(json.dumps(result.summary()))
    else:
        kind = threshold_settings(cfg).controller if machine.controllers else "no"
        print(f"{machine.plant.name} ({', '.join(args.variant) or 'base config'}; {kind} controllers):")
        print("whirl-frequency iteration (damping at w_F -> threshold, whirl):")
        for k, p in enumerate(result.history):
            found = (f"{p.speed_rad_s / RAD_S_PER_RPM:10.1f} rpm, {p.whirl_rad_s:9.4f} rad/s, mode "
                     f"{p.critical_mode}" if p.speed_rad_s is not None else "no threshold")
            print(f"  {k + 1:2d}: w_F = {p.w_F:9.4f} rad/s -> {found}")
        print(result.describe())
        if result.mode_shape is not None:
            print("critical mode shape |q| (normalised): " + ", ".join(
                f"{c} {abs(v):.2f}" for c, v in zip(machine.plant.coords, result.mode_shape)))
    if args.out:
        write_threshold(result, args.out / "threshold.json")
        path = plot_campbell(machine, result, threshold_settings(cfg), args.out / "campbell.png")
        if not args.json:
            print(f"wrote {args.out / 'threshold.json'} and {path}")
    return 0


def _run_study(cfg, varies, args) -> int:
    study = run_study(cfg, varies, backend=backend_from_args(args.workers, args.scheduler),
                      batch_size=args.batch_size, out=args.out and args.out / "points",
                      progress=not args.json)
    rows = study.rows()
    if args.json:
        print(json.dumps({"points": rows, "maximum": study.maximum()}, indent=1))
    else:
        labels = [v.label for v in varies]
        print(" | ".join(labels) + " | threshold [rpm] | whirl [rad/s] | mode")
        for row in rows:
            vals = " | ".join(f"{row[lab]:.4g}" for lab in labels)
            if row["threshold_rpm"] is None:
                print(f"{vals} | {STATUSES.get(row['status'], row['status'])}")
            else:
                print(f"{vals} | {row['threshold_rpm']:.1f} | {row['whirl_rad_s']:.3f} | "
                      f"{row['critical_mode']}")
        best = study.maximum()
        if best is not None:
            print("maximum: " + ", ".join(f"{k} = {v:.6g}" if isinstance(v, float) else f"{k} = {v}"
                                          for k, v in best.items()))
    if args.out:
        write_study_rows(rows, args.out / "thresholds.csv")
        path = plot_map(study, args.out / "threshold_map.png")
        report = write_stability_study_html(study, args.out / "index.html",
                                            f"{cfg.string('name', 'machine')}: threshold of stability")
        if not args.json:
            print(f"wrote {args.out / 'thresholds.csv'}, {path} and {report}")
    return 0
