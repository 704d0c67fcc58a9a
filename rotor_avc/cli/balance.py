"""``rotor-avc balance``: a balanced run-up in-process, with and without balancing.

Zhou & Shi 2001 rotor (``model: rigid_rotor``): the time-domain run-up of the paper's Figure 4 with the
config's strategy and with no balancing. A LinearPlant machine with a ``balancer:`` section
(Werner 2021): the quasi-steady run-up (:mod:`rotor_avc.balancing.quasi_steady`) with every
correction strategy, and the per-resonance peak comparison. Both: the ISO 21940-11 balance
grade (:mod:`rotor_avc.balancing.grade`) of the true unbalance, of the balancer's final
estimate and of the residual after its final correction, printed and in ``balance.json``.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..balancing.grade import grade_text, service_speed_note
from ..balancing.plane_correction import CORRECTION_STRATEGIES
from ..balancing.quasi_steady import resonance_comparison, simulate_machine_runup
from ..balancing.rigid_runup import simulate_rigid_runup
from ..balancing.scenario import machine_setup, rigid_setup
from ..config import load_config
from ..machine import load_machine, model_supports
from ..reports.balance_files import (plot_machine_runs, plot_rigid_runs, write_grades,
                                    write_machine_runs, write_rigid_runs)
from ..output_files import make_folder
from ..studies.progress import run_each
from .common import nonnegative_float, output_folder

NAME = "balance"
HELP = ("Balanced run-up (in-process) of a machine with a one-plane balancer: time series (npz), "
        "a plot of the vibration with and without balancing, the estimate's convergence and the "
        "switching instants, and the ISO 21940-11 balance grade of the balancer's estimate and "
        "of the residual unbalance (balance.json).")
EXAMPLE = "rotor-avc balance balancer_rigid_rotor --out out/balance"


def add_arguments(p) -> None:
    p.add_argument("scenario", help="config with a balancer: section (YAML path or shipped name, "
                                    "e.g. balancer_rigid_rotor, balancer_foot_mount)")
    p.add_argument("--out", type=output_folder, default="out/balance", help="output folder")
    p.add_argument("--duration-s", type=nonnegative_float, default=None,
                   help="shorten the Zhou & Shi 2001 run-up (default: the config's duration)")


def run(args) -> int:
    cfg = load_config(args.scenario)
    make_folder(args.out)
    if model_supports(cfg, "rigid_balancer"):
        return _rigid(cfg, args)
    return _machine(load_machine(args.scenario), args)


def _rigid(cfg, args) -> int:
    setup = rigid_setup(cfg)
    runup = setup.runup
    if args.duration_s:
        runup = dataclasses.replace(runup, duration_s=args.duration_s)
    block = setup.block()
    bal, ref = run_each([lambda: simulate_rigid_runup(runup, block, setup.actuator()),
                         lambda: simulate_rigid_runup(runup, None, setup.actuator())],
                        "runs")                # with balancing and without
    b_true = runup.true_b()
    err = np.column_stack([np.linalg.norm(bal.b_hat[:, :2] - b_true[:2], axis=1)
                           / np.linalg.norm(b_true[:2]),
                           np.linalg.norm(bal.b_hat[:, 2:] - b_true[2:], axis=1)
                           / np.linalg.norm(b_true[2:])])
    sched = setup.schedule()
    path = write_rigid_runs(args.out / "balance.npz", bal, ref, b_true, err, sched.times)
    print(f"wrote {path}")
    print(f"switching weight W = {sched.weight:.4f}, switching instants: "
          + ", ".join(f"{t:.5f} s -> mode {m}" for t, m, _ in sched.switches))
    for t, mode, target in block.events:
        print(f"  t = {t:.4f} s: {mode}, target w = ({target.real:+.5f}, {target.imag:+.5f}) m")
    split = 2.6 if runup.duration_s > 2.6 else runup.duration_s / 2
    for name, rec in (("no balancing", ref), (f"{setup.strategy}", bal)):
        p1, p2 = rec.peak(0, split)[0], rec.peak(split)[0]
        print(f"  {name:13s}: max|v| t<{split:g} s {p1 * 1e3:.3f} mm, t>={split:g} s "
              f"{p2 * 1e3:.3f} mm, RMS {rec.rms * 1e3:.3f} mm")
    plot_rigid_runs(args.out / "balance.png", bal, ref, err, sched.times)
    print(f"wrote {args.out / 'balance.png'}")
    grade = dataclasses.replace(setup.grade, speed_rad_s=runup.top_speed_rad_s)
    _grades(args.out, grade.balancer_grades(runup.true_amplitudes(), block.estimator.amplitudes(),
                                            block.law.corrections(bal.position[-1])),
            grade.speed_rad_s)
    return 0


def _grades(out, grades: dict, speed_rad_s: float) -> None:
    note = service_speed_note(speed_rad_s)
    print(f"ISO 21940-11 balance grade at the end of the run-up ({note}):")
    for name, label in (("true", "true unbalance"), ("estimate", "balancer's estimate"),
                        ("residual", "residual after correction")):
        print(f"  {label:26s} {grade_text(grades[name])}")
    print(f"wrote {write_grades(out, grades, note)}")


def _machine(machine, args) -> int:
    setup = machine_setup(machine)
    strategies = CORRECTION_STRATEGIES[1:]
    records = dict(zip(strategies, run_each(
        [lambda s=s: simulate_machine_runup(setup.runup, setup.signals, setup.objective,
                                            setup.plane, setup.block(s), setup.actuator())
         for s in strategies], "runs")))
    envelopes = {s: np.abs(rec.response).max(axis=1) for s, rec in records.items()}
    rec = records[setup.strategy if setup.strategy != "none" else "least_squares"]
    none = np.abs(rec.response_none).max(axis=1)
    table = resonance_comparison(rec.speed, none, envelopes)
    u = np.array(setup.runup.unbalance)
    err = np.abs(rec.estimate - u) / np.abs(u)
    path, table_path = write_machine_runs(args.out, rec, none, envelopes, u, err, table)
    print(f"wrote {path} and {table_path}")
    print("peak objective amplitude per resonance (max over "
          + ", ".join(setup.objective.channels) + "), reduction vs no balancing [dB]:")
    for row in table:
        print(f"  {row['speed_hz']:7.2f} Hz: none {row['none']:.3e}  "
              + "  ".join(f"{k} {row[k + '_reduction_db']:+.1f}" for k in envelopes))
    plot_machine_runs(args.out / "balance.png", rec, none, envelopes, err)
    print(f"wrote {args.out / 'balance.png'}")
    estimate = dict(zip(("static", "moment"), rec.estimate[-1]))
    _grades(args.out, setup.grade.balancer_grades(dict(zip(("static", "moment"), u)), estimate,
                                                  setup.plane.corrections(rec.position[-1])),
            setup.grade.speed_rad_s)
    return 0
