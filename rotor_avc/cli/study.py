"""``rotor-avc study``: controller gain sweeps -- resonance shifts, reductions, actuator forces
(seed 001 Sec. 4, Figs. 5-13), as CSV, PNG and an interactive HTML page."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis.gain_study import DEFAULT_SWEEP, GainStudy, gain_study
from ..analysis.stability_study import parse_vary
from ..control.spec import FEEDBACK_ORDER
from ..errors import ConfigError, ModelError
from ..machine import load_machine
from ..reports.gain_study_files import write_gain_study

NAME = "study"
HELP = ("Sweep a controller gain (same controller on every actuator) and write the forced "
        "response over speed per gain, the resonance speeds and reductions versus gain and the "
        "actuator forces (CSV + PNG), as in Werner 2019's Figs. 5-13; or `study strategies "
        "SCENARIO`: no control, feedback, harmonic control (each law), combinations, compared.")
EXAMPLE = ("rotor-avc study sleeve_bearing_motor --feedback velocity --gains 1e4:1e6:20 "
           "--out out/study")


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name "
                                  "(sleeve_bearing_motor); its controllers are replaced -- or "
                                  "the word `strategies` followed by a scenario")
    p.add_argument("scenario", nargs="?",
                   help="with `strategies`: a scenario with a `harmonic:` section "
                        "(scenario_harmonic_case3_steady)")
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
    p.add_argument("--out", type=Path, default=Path("out/study"), help="output folder")
    p.add_argument("--no-plots", action="store_true", help="write only the CSV files")


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


def run_strategies(args) -> int:
    """``rotor-avc study strategies SCENARIO``: the strategy comparison and its report."""
    from ..config import load_config
    from ..harmonic.strategy_study import strategy_study
    from ..scenario import scenario_from_config
    from ..reports.strategy_report import rows, write_report
    if not args.scenario:
        raise ConfigError("scenario", "missing after `strategies`",
                          fix="e.g. rotor-avc study strategies scenario_harmonic_case3_steady")
    cfg = load_config(args.scenario)
    try:
        results, sensors = strategy_study(cfg.data, scenario_from_config, cfg.source)
    except ModelError as exc:
        raise ConfigError("harmonic", str(exc), source=cfg.source) from None
    out = args.out if args.out != Path("out/study") else Path("out/strategies")
    path = write_report(results, sensors, out, cfg.source, plot=not args.no_plots)
    head, body = rows(results, sensors)
    widths = [max(len(str(x)) for x in col) for col in zip(head, *body)]
    for line in [head, *body]:
        print("  ".join(str(x).ljust(w) for x, w in zip(line, widths)))
    for r in results:
        if r.peak_reduction_db:
            print(f"{r.name}: 1x peak reduction " + ", ".join(
                f"{n} {f:.1f} Hz {v:.1f} dB" for (n, f), v in r.peak_reduction_db.items()))
    print(f"report: {path}")
    return 0


def run(args) -> int:
    if args.config == "strategies":
        return run_strategies(args)
    if args.scenario:
        raise ConfigError("scenario", f"unexpected second argument {args.scenario!r}",
                          fix="give one machine config, or `strategies SCENARIO`")
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
    args.out.mkdir(parents=True, exist_ok=True)
    for kind in kinds:
        if not args.gains and getattr(study_cfg.gains, kind) is None:
            sec.section("gains", {}).raw(kind)               # raises "missing" with the fix
        gains = (parse_vary("gain=" + args.gains, "--gains").values if args.gains
                 else np.array(getattr(study_cfg.gains, kind)))
        study = gain_study(machine.plant, kind, gains, speeds, excitation, args.structure,
                           args.sweep, _fixed(args.fixed),
                           study_cfg.window_rpm, study_cfg.peak_fraction,
                           None if study_cfg.resonances_of is None else list(study_cfg.resonances_of))
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
