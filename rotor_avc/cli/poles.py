"""``rotor-avc poles``: closed-loop poles at one rotor speed."""
from __future__ import annotations

import json
import math

from ..analysis.poles import machine_poles
from ..machine import load_machine
from .common import add_speed_option, nonnegative_float

NAME = "poles"
HELP = ("Closed-loop poles of a machine config at one rotor speed, with the loss-factor "
        "damping procedure of its paper (analysis.pole_method: Werner 2021's worst case, the "
        "whirl-frequency iteration, ...), with frequencies and damping ratios.")
EXAMPLE = "rotor-avc poles foot_mount_case3 --speed-hz 50 --json"


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name (foot_mount_case3)")
    add_speed_option(p, nonnegative_float, "rotor speed f_r in Hz (default: the first of the "
                     "config's analysis.pole_speeds_hz, else 0)")
    p.add_argument("--json", action="store_true",
                   help='print {"speed_hz": F, "poles": [{"re","im","freq_hz","damping_ratio"}]} '
                        "(re/im in rad/s; one pole of each conjugate pair)")


def damping_rule(machine) -> str:
    """The loss-factor damping of the poles printed (``analysis.pole_method``, DESIGN.md 2)."""
    a = machine.analysis
    if a.pole_method == "worst_case":
        return (f"loss-factor damping c tan(delta) / w_F of every mode at one w_F, the whirl "
                f"frequency of mode {a.worst_case.n_modes}, iterated (Werner 2021 Fig. 4; "
                "analysis.pole_method worst_case)")
    return ("loss-factor damping c tan(delta) / w_F of each mode at its own whirl frequency "
            "(Werner 2019 Sec. 3.3; analysis.pole_method whirl_iteration)")


def run(args) -> int:
    machine = load_machine(args.config)
    if args.speed_hz is None:
        args.speed_hz = machine.analysis.pole_speeds_hz[0]
    result = machine_poles(machine, 2 * math.pi * args.speed_hz)
    rows = result.table()
    if args.json:
        print(json.dumps({"speed_hz": args.speed_hz, "poles": rows,
                          "damping_rule": damping_rule(machine),
                          "damping_frequency_rad_s": result.w_F,
                          "damping_frequency_history_rad_s": result.history,
                          "stable": result.stable}, indent=1))
        return 0
    print(f"{machine.plant.name}: poles at f_r = {args.speed_hz:g} Hz "
          f"({'closed loop' if machine.controllers else 'loops open'})")
    print(f"damping: {damping_rule(machine)}")
    print("damping frequency w_F iterations [rad/s]: "
          + " -> ".join(f"{w:.1f}" for w in result.history))
    print(f"{'re [1/s]':>12} {'im [rad/s]':>12} {'f [Hz]':>10} {'zeta':>8}")
    for r in rows:
        print(f"{r['re']:12.3f} {r['im']:12.3f} {r['freq_hz']:10.3f} {r['damping_ratio']:8.4f}")
    print(f"max Re(s) = {result.max_real:.4g} 1/s -> {'stable' if result.stable else 'UNSTABLE'}")
    return 0
