"""``rotor-avc study``: controller gain sweeps -- resonance shifts, reductions, actuator forces
(Werner 2019 Sec. 4, Figs. 5-13), as CSV, PNG and an interactive HTML page; ``rotor-avc study MODE
TARGET``: the study modes of :data:`MODES` (``robustness``: the Monte-Carlo study of
:mod:`rotor_avc.cli.robustness`; ``strategies``: the vibration-control strategies compared,
:mod:`rotor_avc.cli.strategies`)."""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..analysis.gain_study import DEFAULT_SWEEP, GainStudy, gain_study
from ..analysis.stability_study import parse_vary
from ..control.spec import FEEDBACK_ORDER
from ..errors import ConfigError
from ..machine import load_machine
from ..output_files import make_folder
from ..reports.gain_study_files import write_gain_study
from ..studies.backends import (BACKEND_OPTIONS, add_backend_arguments, backend_from_args,
                                check_scheduler_arg)
from . import robustness, strategies
from .common import output_folder

NAME = "study"
HELP = ("Sweep a controller gain (same controller on every actuator) and write the forced "
        "response over speed per gain, the resonance speeds and reductions versus gain and the "
        "actuator forces (CSV + PNG), as in Werner 2019's Figs. 5-13. `study robustness CONFIG "
        "--sample PATH=DIST --n N`: probability of stability and distributions of peak response "
        "and stability margin under sampled parameters. `study strategies SCENARIO`: no control, "
        "feedback, harmonic control (each law), combinations, compared.")
EXAMPLE = ("rotor-avc study sleeve_bearing_motor --feedback velocity --gains 1e4:1e6:20 "
           "--out out/study\n  rotor-avc study robustness foot_mount_case3 --sample "
           "'foundation.stiffness_n_per_m.z*=normal(1, 0.15)' --n 1000 --out out/robust")

#: `rotor-avc study MODE TARGET ...`: mode name -> its module (``add_arguments``, ``OPTIONS``: the
#: options only it takes, ``run``)
MODES = {"robustness": robustness, "strategies": strategies}
#: options of the gain study (argparse dest -> option), refused by the modes
GAIN_OPTIONS = {"feedback": "--feedback", "gains": "--gains", "structure": "--structure",
                "sweep": "--sweep", "fixed": "--fixed", "excitation": "--excitation"}


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name "
                                  "(sleeve_bearing_motor); its controllers are replaced. Or a "
                                  "mode and its input: `robustness CONFIG`, `strategies SCENARIO`")
    p.add_argument("target", nargs="?", metavar="CONFIG", help=argparse.SUPPRESS)
    p.add_argument("--feedback", choices=list(FEEDBACK_ORDER), action="append",
                   help="feedback kind (repeatable; default: every kind in the config's "
                        "analysis.study.gains)")
    p.add_argument("--gains", metavar="RANGE",
                   help="START:STOP:N, START:STOP:N:log or [v1, v2, ...] in SI (N/m, N s/m, kg "
                        "for P on displacement, velocity, acceleration); the open loop (0) is "
                        "always added (default: analysis.study.gains of the feedback kind)")
    p.add_argument("--structure", choices=list(DEFAULT_SWEEP),
                   help="controller structure (default P)")
    p.add_argument("--sweep", metavar="GAIN", help="the swept gain (default kp; ki for I)")
    p.add_argument("--fixed", action="append", default=[], metavar="NAME=VALUE",
                   help="value of a gain that is not swept (e.g. kd=2.0e+3 for a PD sweep)")
    p.add_argument("--excitation", help="excitation (default analysis.study.excitation)")
    p.add_argument("--out", type=output_folder, help="output folder (default out/study, for the robustness "
                                            "study out/robustness)")
    p.add_argument("--no-plots", action="store_true", help="write only the CSV files")
    for mode in MODES.values():
        mode.add_arguments(p)
    add_backend_arguments(p)


def _refuse(args, options: dict, study: str) -> None:
    given = [opt for dest, opt in options.items() if getattr(args, dest) not in (None, [])]
    if given:
        verb = "does" if len(given) == 1 else "do"
        raise ConfigError(given[0], f"{', '.join(given)} {verb} not apply to {study}",
                          fix="leave it out (rotor-avc study --help lists the options of each)")


def _fixed(items: list[str]) -> dict[str, float]:
    out = {}
    for text in items:
        name, _, value = text.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise ConfigError("--fixed", f"{text!r} is not NAME=VALUE",
                              fix="e.g. --fixed kd=2.0e+3") from None
    return out


def run(args) -> int:
    mode = MODES.get(args.config)
    which = f"the {args.config} study" if mode else "a gain study"
    for other in MODES.values():
        if other is not mode:
            _refuse(args, other.OPTIONS, which)
    if mode is strategies:
        _refuse(args, BACKEND_OPTIONS, which)
    check_scheduler_arg(args.scheduler)
    if mode is not None:
        if args.target is None:
            raise ConfigError("CONFIG", f"no machine config given after `{args.config}`",
                              fix=f"write rotor-avc study {args.config} CONFIG ...")
        _refuse(args, GAIN_OPTIONS, which)
        return mode.run(args)
    if args.target is not None:
        raise ConfigError("CONFIG", "a gain study takes one config",
                          fix="write rotor-avc study MODE CONFIG for a study mode (modes: "
                              + ", ".join(MODES) + ")")
    args.out = args.out or Path("out/study")
    backend = backend_from_args(args.workers, args.scheduler)
    machine = load_machine(args.config)
    study_cfg = machine.analysis.study
    sec = machine.config.section("analysis", {}).section("study", {})
    if study_cfg.speed_rpm is None:
        sec.raw("speed_rpm")                                 # raises "missing" with the fix
    rng = study_cfg.speed_rpm
    speeds = np.linspace(rng.start, rng.stop, rng.n)
    kinds = args.feedback or [k for k in FEEDBACK_ORDER if getattr(study_cfg.gains, k) is not None]
    if not kinds:
        raise ConfigError("--feedback", "no feedback kind given and none in analysis.study.gains",
                          fix="give --feedback velocity (and --gains)")
    excitation = args.excitation or study_cfg.excitation or sec.raw("excitation")
    if machine.controllers:
        print(f"note: the config's controllers ({', '.join(machine.controllers)}) are replaced "
              "by the swept ones")
    make_folder(args.out)
    for kind in kinds:
        if not args.gains and getattr(study_cfg.gains, kind) is None:
            sec.section("gains", {}).raw(kind)               # raises "missing" with the fix
        gains = (parse_vary("gain=" + args.gains, "--gains").values if args.gains
                 else np.array(getattr(study_cfg.gains, kind)))
        study = gain_study(machine.plant, kind, gains, speeds, excitation, args.structure or "P",
                           args.sweep, _fixed(args.fixed),
                           study_cfg.window_rpm, study_cfg.peak_fraction,
                           None if study_cfg.resonances_of is None else list(study_cfg.resonances_of),
                           backend, args.batch_size)
        stem = args.out / f"{machine.plant.name}_{kind}"
        for path in write_gain_study(study, stem, not args.no_plots):
            print(f"wrote {path}")
        _print_summary(study)
    return 0


def _print_summary(study: GainStudy) -> None:
    print(f"\n{study.structure} on {study.feedback}, {study.gain_name} = {study.gains[1]:g} .. "
          f"{study.gains[-1]:g}, {study.excitation} excitation:")
    for r in study.resonances:
        end = ("out of range / flattened" if np.isnan(r.speed_rpm[-1])
               else f"{r.speed_rpm[-1]:.0f} rpm")
        print(f"  {r.label:28s} -> {end:>24s}; reduction {r.reduction_window_pct[-1]:6.1f} % "
              f"(window), {r.reduction_same_speed_pct[-1]:6.1f} % (same speed)")
    for q in study.curves:
        if q.startswith("actuator"):
            force, at = study.max_force(q)
            print(f"  max |{q}| at the largest gain: {force[-1]:.4g} {study.units[q]} "
                  f"at {at[-1]:.0f} rpm")
