"""``rotor-avc study strategies SCENARIO``: the vibration-control strategies on one machine and
speed profile (rotor_avc.harmonic.strategy_study), tabulated and reported; one line per strategy
started and finished on stderr, with the elapsed time and the time left."""
from __future__ import annotations

from pathlib import Path

from ..config import load_config
from ..errors import ConfigError, ModelError

#: options of this mode (none besides --out and --no-plots, which every study has)
OPTIONS: dict[str, str] = {}


def add_arguments(p) -> None:
    """No options of its own."""


def run(args) -> int:
    from ..harmonic.strategy_study import strategy_study
    from ..reports.strategy_report import rows, write_report
    from ..scenario import scenario_from_config
    cfg = load_config(args.target)
    try:
        results, sensors = strategy_study(cfg.data, scenario_from_config, cfg.source,
                                          progress=True)
    except ModelError as exc:
        raise ConfigError("harmonic", str(exc), source=cfg.source) from None
    out = args.out or Path("out/strategies")
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
