"""``rotor-avc harmonic commission SCENARIO``: the influence matrix identified on the machine with
test phasors, the margin checked, the table written as a config (rotor_avc.harmonic.commission).
"""
from __future__ import annotations

import sys

from ..config import load_config
from ..errors import ConfigError, ModelError
from ..studies.progress import Bars
from .common import add_speed_option, positive_speed_list

NAME = "harmonic"
HELP = ("Adaptive harmonic control on the machine: commission identifies the influence matrix "
        "with test phasors (bounded force and added vibration), checks the loop's phase margin "
        "with it and writes the table as a config the controller uses.")
EXAMPLE = ("rotor-avc harmonic commission scenario_harmonic_case2_steady --out out/commission "
           "--test-force-n 50")
EXIT_REFUSED = 1


def add_arguments(p) -> None:
    sub = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    s = sub.add_parser("commission", help="identify the influence matrix, check the margin, "
                                          "write the table (exit 1: refused, with the reason)")
    s.add_argument("scenario", help="the machine: a scenario with a `harmonic:` section")
    s.add_argument("--model", help="the controller's model config (the loop of the margin "
                                   "check; default: the scenario's machine)")
    add_speed_option(s, positive_speed_list, "speeds F[,F...] in Hz (default: the scenario's "
                     "constant speed)", metavar="F[,F...]")
    s.add_argument("--out", default="out/commission", help="folder of commissioned.yaml and "
                                                          "commission.json")
    s.add_argument("--test-force-n", type=float, help="harmonic.commission.test_force_n")
    s.add_argument("--max-added-vibration", type=float,
                   help="harmonic.commission.max_added_vibration (sensor unit)")
    s.add_argument("--min-margin-deg", type=float,
                   help="harmonic.commission.min_phase_margin_deg")


def run(args) -> int:
    from ..harmonic.commission import commission
    from ..machine import load_machine
    from ..reports.commission_files import write_commission
    from ..scenario import scenario_from_config
    cfg = load_config(args.scenario)
    model = load_machine(args.model) if args.model else None
    try:
        with Bars("steps") as bar:
            result = commission(cfg.data, cfg.source, scenario_from_config, model,
                                args.speed_hz, progress=bar, test_force_n=args.test_force_n,
                                max_added_vibration=args.max_added_vibration,
                                min_phase_margin_deg=args.min_margin_deg)
    except ModelError as exc:
        raise ConfigError("harmonic", str(exc), source=cfg.source) from None
    path = write_commission(result, args.out, cfg.source, cfg.data,
                            "rotor-avc harmonic commission")
    for r in result.speeds:
        print(f"{r.speed_hz:g} Hz: test levels {r.levels_n.round(3).tolist()} N, settling "
              f"{r.settling.max():.2g}, phase margin {r.margin.phase_margin_deg:.1f} deg "
              f"(quasi-steady {min(r.margin.quasi_steady_deg):.1f}, exact "
              f"{r.margin.exact_deg:.1f}, radius {r.margin.radius:.4f})")
        for line in r.log:
            print(f"  {line}")
    if path is None:
        print(f"rotor-avc harmonic: refused: {result.refusal}", file=sys.stderr)
        return EXIT_REFUSED
    print(f"wrote {path} (phase margin {result.phase_margin_deg:.1f} deg) and "
          f"{path.parent / 'commission.json'}")
    return 0
