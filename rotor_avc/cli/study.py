"""``rotor-avc study``: controller gain sweeps -- resonance shifts, reductions, actuator forces
(seed 001 Sec. 4, Figs. 5-13), as CSV and PNG; ``rotor-avc study robustness``: the Monte-Carlo
robustness study (:mod:`rotor_avc.cli.robustness`)."""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from ..analysis.gain_study import DEFAULT_SWEEP, GainStudy, gain_study
from ..analysis.stability_study import parse_vary
from ..control.spec import FEEDBACK_ORDER
from ..errors import ConfigError
from ..machine import load_machine
from ..studies.backends import add_backend_arguments, backend_from_args
from . import robustness
from .common import speed_range_hz

NAME = "study"
HELP = ("Sweep a controller gain (same controller on every actuator) and write the forced "
        "response over speed per gain, the resonance speeds and reductions versus gain and the "
        "actuator forces (CSV + PNG), as in Werner 2019's Figs. 5-13. `study robustness CONFIG "
        "--sample PATH=DIST --n N`: probability of stability and distributions of peak response "
        "and stability margin under sampled parameters.")
EXAMPLE = ("rotor-avc study sleeve_bearing_motor --feedback velocity --gains 1e4:1e6:20 "
           "--out out/study\n  rotor-avc study robustness foot_mount_case3 --sample "
           "'foundation.stiffness_n_per_m.z*=normal(1, 0.15)' --n 1000 --out out/robust")

#: paper units for the plots: (mm/s)/um for velocities per metre, N/um for forces per metre
PLOT_SCALE = {"m/s/(m)": (1e-3, "(mm/s)/um"), "N/(m)": (1e-6, "N/um")}


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name "
                                  "(sleeve_bearing_motor); its controllers are replaced. Or "
                                  "`robustness CONFIG` for the Monte-Carlo study")
    p.add_argument("robustness_config", nargs="?", metavar="CONFIG", help=argparse.SUPPRESS)
    p.add_argument("--feedback", choices=list(FEEDBACK_ORDER), action="append",
                   help="feedback kind (repeatable; default: every kind in the config's "
                        "analysis.study.gains)")
    p.add_argument("--gains", metavar="RANGE",
                   help="START:STOP:N, START:STOP:N:log or [v1, v2, ...] in SI (N/m, N s/m, kg "
                        "for P on displacement, velocity, acceleration); the open loop (0) is "
                        "always added (default: analysis.study.gains of the feedback kind)")
    p.add_argument("--structure", default="P", choices=list(DEFAULT_SWEEP),
                   help="controller structure (default P)")
    p.add_argument("--sweep", metavar="GAIN", help="the swept gain (default kp; ki for I)")
    p.add_argument("--fixed", action="append", default=[], metavar="NAME=VALUE",
                   help="value of a gain that is not swept (e.g. kd=2.0e+3 for a PD sweep)")
    p.add_argument("--excitation", help="excitation (default analysis.study.excitation)")
    p.add_argument("--out", type=Path, help="output folder (default out/study, for the robustness "
                                            "study out/robustness)")
    p.add_argument("--no-plots", action="store_true", help="write only the CSV files")
    g = p.add_argument_group("robustness study (rotor-avc study robustness CONFIG ...)")
    g.add_argument("--sample", action="append", default=[], metavar="PATH=DIST",
                   help="sampled config path(s): PATH=normal(MEAN, STD), uniform(LOW, HIGH) or "
                        "lognormal(MU, SIGMA) (ln x ~ N(MU, SIGMA)); PATH*=... for a factor on "
                        "the base value; comma-join paths that take the same value (repeatable)")
    g.add_argument("--n", type=int, help="number of points (default 1000)")
    g.add_argument("--seed", type=int, help="study seed (default 0)")
    g.add_argument("--speed-hz", type=speed_range_hz, metavar="START:STOP:N",
                   help="speeds of the peak responses (default: analysis.frf_speed_hz)")
    g.add_argument("--response", action="append", metavar="NAME",
                   help="response whose peak is recorded (repeatable; default: every bearing "
                        "response, e.g. bearing_D_vz_static)")
    add_backend_arguments(p)


#: options of one kind of study (argparse dest -> option), refused by the other
GAIN_OPTIONS = {"feedback": "--feedback", "gains": "--gains", "sweep": "--sweep",
                "fixed": "--fixed", "excitation": "--excitation"}
ROBUSTNESS_OPTIONS = {"sample": "--sample", "n": "--n", "seed": "--seed", "speed_hz": "--speed-hz",
                      "response": "--response"}


def _refuse(args, options: dict, study: str) -> None:
    given = [opt for dest, opt in options.items() if getattr(args, dest) not in (None, [])]
    if study == "the robustness study" and args.structure != "P":
        given.append("--structure")
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


def _names(sec, key: str) -> list[str] | None:
    value = sec.raw(key, None)
    if value is not None and not (isinstance(value, list)
                                  and all(isinstance(v, str) for v in value)):
        raise sec.error(key, f"must be a list of response names (got {value!r})",
                        fix="e.g. [bearing_vz, bearing_vy, foundation_L_vy]")
    return value


def run(args) -> int:
    if args.config == "robustness":
        if args.robustness_config is None:
            raise ConfigError("CONFIG", "no machine config given after `robustness`",
                              fix="write rotor-avc study robustness foot_mount_case3 --sample ...")
        _refuse(args, GAIN_OPTIONS, "the robustness study")
        return robustness.run(args)
    if args.robustness_config is not None:
        raise ConfigError("CONFIG", "a gain study takes one config",
                          fix="write rotor-avc study robustness CONFIG --sample ... for the "
                              "Monte-Carlo study")
    _refuse(args, ROBUSTNESS_OPTIONS, "a gain study")
    args.out = args.out or Path("out/study")
    machine = load_machine(args.config)
    sec = machine.analysis.section("study", {})
    sec.check_keys(("excitation", "speed_rpm", "window_rpm", "peak_fraction", "gains",
                    "resonances_of"))
    rng = sec.section("speed_rpm")
    speeds = np.linspace(rng.number("start", positive=True, unit="rpm"),
                         rng.number("stop", positive=True, unit="rpm"), rng.integer("n", minimum=5))
    gains_sec = sec.section("gains", {})
    gains_sec.check_keys(FEEDBACK_ORDER)
    kinds = args.feedback or [k for k in FEEDBACK_ORDER if gains_sec.has(k)]
    if not kinds:
        raise ConfigError("--feedback", "no feedback kind given and none in analysis.study.gains",
                          fix="give --feedback velocity (and --gains)")
    excitation = args.excitation or sec.string("excitation")
    if machine.controllers:
        print(f"note: the config's controllers ({', '.join(machine.controllers)}) are replaced "
              "by the swept ones")
    args.out.mkdir(parents=True, exist_ok=True)
    for kind in kinds:
        gains = (parse_vary("gain=" + args.gains, "--gains").values if args.gains
                 else np.array(gains_sec.number_list(kind, min_length=1)))
        study = gain_study(machine.plant, kind, gains, speeds, excitation, args.structure,
                           args.sweep, _fixed(args.fixed),
                           sec.number("window_rpm", 200.0, positive=True, unit="rpm"),
                           sec.number("peak_fraction", 0.25, positive=True, maximum=1.0),
                           _names(sec, "resonances_of"),
                           backend_from_args(args.workers, args.scheduler), args.batch_size)
        stem = args.out / f"{machine.plant.name}_{kind}"
        for path in _write(study, stem, not args.no_plots):
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


def _write(study: GainStudy, stem: Path, plots: bool) -> list[Path]:
    """``<stem>_curves.csv`` (amplitude over speed per gain), ``<stem>_summary.csv`` (per gain:
    resonance speeds, heights, reductions, largest actuator forces) and the plots."""
    gname = f"{study.gain_name}_{study.structure}"
    curves = stem.with_name(stem.name + "_curves.csv")
    with open(curves, "w", newline="") as fh:
        w = csv.writer(fh)
        cols = [(q, i) for q in study.curves for i in range(len(study.gains))]
        w.writerow(["speed_rpm"] + [f"{q}_{gname}={study.gains[i]:g}" for q, i in cols])
        for k, n in enumerate(study.speed_rpm):
            w.writerow([f"{n:.6g}"] + [f"{study.curves[q][i, k]:.8g}" for q, i in cols])
    summary = stem.with_name(stem.name + "_summary.csv")
    forces = [q for q in study.curves if q.startswith("actuator")]
    with open(summary, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([gname] + [f"{r.label}_{c}" for r in study.resonances for c in
                              ("speed_rpm", "amplitude", "reduction_window_pct",
                               "reduction_same_speed_pct")]
                   + [f"{q}_max_{c}" for q in forces for c in ("amplitude", "speed_rpm")])
        for i, gain in enumerate(study.gains):
            row = [f"{gain:g}"]
            for r in study.resonances:
                row += [f"{v:.6g}" for v in (r.speed_rpm[i], r.amplitude[i],
                                              r.reduction_window_pct[i],
                                              r.reduction_same_speed_pct[i])]
            for q in forces:
                force, at = study.max_force(q)
                row += [f"{force[i]:.6g}", f"{at[i]:.6g}"]
            w.writerow(row)
    return [curves, summary] + (_plot(study, stem) if plots else [])


def _plot(study: GainStudy, stem: Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    title = f"{study.structure} on {study.feedback} ({study.excitation} excitation)"
    glabel = f"{study.gain_name} [{_gain_unit(study)}]"
    quantities = list(study.curves)
    cols = 3
    rows = -(-len(quantities) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.0 * rows), squeeze=False,
                             sharex=True)
    for ax, q in zip(axes.flat, quantities):
        scale, unit = PLOT_SCALE.get(study.units[q], (1.0, study.units[q]))
        for i, gain in enumerate(study.gains):
            ax.plot(study.speed_rpm, scale * study.curves[q][i], lw=1, label=f"{gain:g}")
        ax.set_title(q, fontsize=9)
        ax.set_ylabel(unit, fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(quantities):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("speed [rpm]")
    axes.flat[0].legend(fontsize=6, title=glabel, title_fontsize=6)
    fig.suptitle(f"Response over speed per gain: {title}", fontsize=10)
    fig.tight_layout()
    paths = [stem.with_name(stem.name + "_curves.png")]
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    for r in study.resonances:
        a1.plot(study.gains, r.speed_rpm, "o-", ms=3, label=r.label)
        a2.plot(study.gains, r.reduction_window_pct, "o-", ms=3, label=r.label)
    a1.set_ylabel("resonance speed [rpm]")
    a2.set_ylabel("reduction of the resonance peak [%] (+-window)")
    for ax in (a1, a2):
        ax.set_xlabel(glabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"Resonance shift and reduction: {title}", fontsize=10)
    fig.tight_layout()
    paths.append(stem.with_name(stem.name + "_resonances.png"))
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths


def _gain_unit(study: GainStudy) -> str:
    """SI unit of the swept gain: force per unit of the fed-back signal, times s per integral."""
    order = FEEDBACK_ORDER[study.feedback] + {"ki": -1, "kd": 1}.get(study.gain_name, 0)
    return {-1: "N/(m s)", 0: "N/m", 1: "N s/m", 2: "kg", 3: "kg/s"}.get(order, "SI")
