"""``rotor-avc active-bearing``: Sci. Rep. 2023's quantified force and phase, RMS and insertion loss.

Prints force, phase, stroke, RMS before/after and IL for each case speed (analogues of the
paper's Tables 2 and 3), the speed where IL first drops below 0 dB and the piezo stroke-limit
report; writes ``cases.csv``, ``il_over_speed.csv``, ``summary.json`` and IL-over-speed plots
(Fig. 7 analogue).
"""
from __future__ import annotations

import numpy as np

from ..analysis.active_bearing_ff import (METHODS, feedforward_method, il_zero_crossing,
                                          saturated_forces, saturation_onset, side_table,
                                          solve_feedforward)
from ..machine import load_machine
from ..model_config.active_bearing import piezo_from_config, unbalance_kg_m
from ..models.active_bearing import PLANES
from ..reports.active_bearing_files import write_active_bearing_files
from .common import add_speed_option, output_folder, speed_range_hz

NAME = "active-bearing"
HELP = ("Sci. Rep. 2023 active bearings: quantified actuator force and phase, RMS and insertion loss "
        "at the case speeds and over speed, IL zero crossing and piezo stroke limits.")
EXAMPLE = "rotor-avc active-bearing active_bearing --out out/active_bearing"
TWO_PI = 2 * np.pi


def add_arguments(p) -> None:
    p.add_argument("config", help="machine config: a YAML path or a shipped name (active_bearing)")
    add_speed_option(p, speed_range_hz, "IL sweep in Hz (default: the config's "
                     "analysis.il_speed_hz)", metavar="START:STOP:N")
    p.add_argument("--out", type=output_folder, default=None, help="output folder for CSV, JSON and plots")


def _hz(speed_rad_s):
    return None if speed_rad_s is None else speed_rad_s / TWO_PI


def _fmt_hz(f_hz) -> str:
    return "none in the sweep" if f_hz is None else f"{f_hz:.1f} Hz ({60 * f_hz:.0f} rpm)"


def run(args) -> int:
    machine = load_machine(args.config)
    plant, cfg = machine.plant, machine.config
    u = unbalance_kg_m(cfg)
    piezo = piezo_from_config(cfg)
    method = feedforward_method(cfg)
    ana = machine.analysis
    required = {"cases_rpm": ana.cases_rpm} if args.speed_hz is not None else {
        "cases_rpm": ana.cases_rpm, "il_speed_hz": ana.il_speed_hz}
    for key, value in required.items():
        if value is None:
            raise cfg.section("analysis", {}).error(key, "missing", fix=f"add `{key}:` to analysis")
    cases_hz = np.array(ana.cases_rpm) / 60.0
    sweep_hz = args.speed_hz
    if sweep_hz is None:
        rng = ana.il_speed_hz
        sweep_hz = np.linspace(rng.start, rng.stop, rng.n)
    cases = {m: solve_feedforward(plant, TWO_PI * cases_hz, m, u) for m in METHODS}
    sweep = {m: solve_feedforward(plant, TWO_PI * sweep_hz, m, u) for m in METHODS}
    chosen = cases[method]
    ids = chosen.actuator_ids

    print(f"{plant.name}: unbalance m_o e = {u:.3g} kg m; quantified force by the {method} method")
    head = f"{'rpm':>7} {'f_un[N]':>9}" + "".join(f" {'|F_' + a + '|[N]':>11} {'phi':>7}" for a in ids)
    print(head + f" {'stroke[um]':>11} {'V_amp[V]':>9}")
    print("  (phi [deg]: relative to the unbalance force in the actuator's direction; stroke: "
          "largest piezo elongation after control; V_amp: largest lag-compensated piezo voltage)")
    stroke = np.abs(chosen.after()[:, chosen.outputs("stroke_")]).max(axis=1)
    volts = np.abs(piezo.voltage_phasor_v(chosen.forces, chosen.speed_rad_s)).max(axis=1)
    phase = chosen.force_phase_deg()
    f_un = np.abs(chosen.unbalance_force()[:, 0])
    for k, f in enumerate(cases_hz):
        cols = "".join(f" {abs(chosen.forces[k, i]):11.4g} {phase[k, i]:7.1f}" for i in range(len(ids)))
        print(f"{60 * f:7.0f} {f_un[k]:9.4g}{cols} {1e6 * stroke[k]:11.4g} {volts[k]:9.3g}")

    tables = {m: side_table(cases[m]) for m in METHODS}
    print("\nRMS averaged per side (L: bearing-1 side, R: bearing-2 side) [um] and IL (eq. 43) [dB]")
    print(f"{'rpm':>7} {'side':>4} {'plane':>5} {'before':>10}"
          + "".join(f" {'after ' + m:>12} {'IL ' + m:>10}" for m in METHODS))
    rows = []
    for k, f in enumerate(cases_hz):
        for (side, d), t in tables[method].items():
            entry = {"rpm": 60 * f, "side": side, "plane": d, "rms_before_m": t["rms_before"][k]}
            for m in METHODS:
                entry[f"rms_after_{m}_m"] = tables[m][(side, d)]["rms_after"][k]
                entry[f"il_{m}_db"] = tables[m][(side, d)]["il_db"][k]
            rows.append(entry)
            print(f"{60 * f:7.0f} {side:>4} {d:>5} {1e6 * entry['rms_before_m']:10.4g}"
                  + "".join(f" {1e6 * entry[f'rms_after_{m}_m']:12.4g} {entry[f'il_{m}_db']:10.2f}"
                            for m in METHODS))
    il_min = {m: cases[m].insertion_loss_db()[:, cases[m].outputs("shaft_")].min(axis=1) for m in METHODS}
    for m in METHODS:
        state = "positive at every shaft point" if np.all(il_min[m] > 0) else "NOT positive everywhere"
        print(f"IL ({m}) at the case speeds: min over shaft points "
              + ", ".join(f"{v:.1f}" for v in il_min[m]) + f" dB -- {state}")

    grid = TWO_PI * sweep_hz
    crossing = {m: {d: _hz(il_zero_crossing(plant, m, grid, (d,))) for d in PLANES} for m in METHODS}
    print("\nfirst IL < 0 dB at a shaft point (end of the control range, Fig. 7):")
    for m in METHODS:
        print(f"  {m:>5}: " + "; ".join(f"{d}: {_fmt_hz(crossing[m][d])}" for d in PLANES))

    onset = _hz(saturation_onset(plant, method, piezo, grid, u))
    alpha_sw, forces_sat = saturated_forces(sweep[method], piezo)
    il_sat = sweep[method].insertion_loss_db(forces_sat)[:, sweep[method].outputs("shaft_")].min(axis=1)
    alpha_c, forces_c = saturated_forces(chosen, piezo)
    il_sat_c = chosen.insertion_loss_db(forces_c)[:, chosen.outputs("shaft_")].min(axis=1)
    sat_zero = _hz(il_zero_crossing(plant, method, grid, PLANES, piezo, u))
    print(f"\npiezo stack: free stroke {1e6 * piezo.free_stroke_m:g} um, blocked force "
          f"{piezo.blocked_force_n:g} N (k_p {piezo.stiffness_n_per_m / 1e6:.3g} N/um), "
          f"{piezo.min_voltage_v:g}..{piezo.max_voltage_v:g} V, bandwidth {piezo.bandwidth_hz:g} Hz")
    print(f"{'rpm':>7} {'limit[N]':>9} {'max|F|[N]':>10} {'free stroke[um]':>16} {'alpha':>6} "
          f"{'IL sat[dB]':>10}")
    for k, f in enumerate(cases_hz):
        need = np.abs(chosen.forces[k]).max()
        print(f"{60 * f:7.0f} {piezo.force_limit_n(TWO_PI * f):9.4g} {need:10.4g} "
              f"{1e6 * piezo.free_stroke_amplitude_m(need):16.4g} {alpha_c[k]:6.3f} {il_sat_c[k]:10.2f}")
    print(f"the actuators saturate above {_fmt_hz(onset)}; with the force saturated the shaft IL "
          f"first drops below 0 dB at {_fmt_hz(sat_zero)}")

    if args.out is not None:
        write_active_bearing_files(args.out, sweep, method, alpha_sw, forces_sat, il_sat, piezo, rows, {
            "method": method, "unbalance_kg_m": u,
            "il_zero_crossing_hz": crossing, "saturation_onset_hz": onset,
            "saturated_il_zero_crossing_hz": sat_zero, "cases_rpm": (60 * cases_hz).tolist()})
    return 0
