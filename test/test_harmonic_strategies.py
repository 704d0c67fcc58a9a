"""The strategy study (rotor_avc.harmonic.strategy_study): the dynamic feed-forward among the
strategies where it can run, its loop radius against the one-revolution analysis at a second
gain; the commissioned variant (commissioning first, then the Newton law on the identified
table) against the Newton law on the model's table, which is the machine here; a refused
commissioning said with its reason; one progress line per strategy started and finished, and
the report on the interactive page template (the same head as every other report, every plot
rendered in Chromium)."""
import copy
import csv
import io
import re

import numpy as np

from browser_check import check_report
from rotor_avc.config import load_config
from rotor_avc.harmonic.lti import excitation_loop_poles
from rotor_avc.harmonic.strategy_study import (COMMISSIONED, DYNAMIC, commission_speeds,
                                               commissioned, strategy_study, variants)
from rotor_avc.interactive.page import page
from rotor_avc.reports.strategy_report import write_report
from rotor_avc.scenario import scenario_from_config


def outputs_of(data):
    return [o.name for o in scenario_from_config(data, "test").machine.plant.outputs]


def test_dynamic_variant_only_where_it_can_run():
    data = copy.deepcopy(load_config("scenario_strategies_runup").data)
    outputs = outputs_of(data)
    dyn = variants(data, outputs)[DYNAMIC]["harmonic"]
    assert (dyn["feedforward"], dyn["adapt_in"], dyn["law"], dyn["refresh_samples"],
            dyn["gain"]) == ("dynamic", "excitations", "newton", 25, "auto")
    assert list(variants(data, outputs))[:7] == [
        "no control", "harmonic steepest descent", "harmonic Newton", "harmonic WLS", DYNAMIC,
        COMMISSIONED, "balancer"]
    com = variants(data, outputs)[COMMISSIONED]["harmonic"]     # the table comes with the run
    assert (com["law"], com["adapt_in"], com["feedforward"], "table" in com.get("influence", {})
            ) == ("newton", "forces", "quasi_static", False)
    assert DYNAMIC not in variants(data)                        # outputs unknown
    two = copy.deepcopy(data)
    two["harmonic"]["harmonics"] = [1, 2]
    assert DYNAMIC not in variants(two, outputs)                # 1x only
    feet = copy.deepcopy(data)
    feet["harmonic"]["sensors"] = ["bearing_D_vz", "foot_DL_dz"]
    assert DYNAMIC not in variants(feet, outputs)               # no disturbance model there
    learning = copy.deepcopy(data)
    learning["harmonic"]["identification"] = {}
    assert DYNAMIC not in variants(learning, outputs)           # its model error is declared


def test_run_up_commissioned_at_the_resonances_and_the_top_speed():
    resonances = [("D", 7.5), ("N", 7.52), ("D", 1.0), ("N", 20.7), ("D", 130.0)]
    assert commission_speeds(resonances, 2.0, 120.0) == [7.5, 20.7, 120.0]


def short_case3():
    """Case 3 at 50 Hz (far above the modes), harmonic control switched on at 0.4 s, 2 s; a
    short commissioning test (4 steps of 2 + 10 + 4 revolutions)."""
    data = copy.deepcopy(load_config("scenario_harmonic_case3_steady").data)
    data["harmonic"].update(min_speed_hz=40.0, start_s=0.4, commission={
        "ramp_revolutions": 2, "settle_revolutions": 10, "measure_revolutions": 4})
    data["simulation"].update(duration_s=2.0, speed={"type": "constant", "speed_hz": 50.0})
    return data


def test_refused_commissioning_gives_its_reason_and_no_table():
    data = short_case3()
    data["harmonic"]["commission"]["min_phase_margin_deg"] = 80.0
    cfg = variants(data)[COMMISSIONED]
    refusal = commissioned(cfg, scenario_from_config, "case 3", None)
    assert refusal.startswith("phase margin ") and "min_phase_margin_deg 80 deg" in refusal
    assert "table" not in cfg["harmonic"].get("influence", {})


def test_study_progress_dynamic_row_and_interactive_report(tmp_path):
    data = short_case3()
    stream = io.StringIO()
    results, sensors = strategy_study(data, scenario_from_config, "case 3", progress=True,
                                      stream=stream)
    names = [r.name for r in results]
    assert DYNAMIC in names and COMMISSIONED in names and len(names) == 8
    lines = stream.getvalue().splitlines()
    assert len(lines) == 2 * len(names)
    clock = []
    for i, name in enumerate(names):
        start, done = lines[2 * i], lines[2 * i + 1]
        assert start.startswith(f"{name}: started") and f" {i}/{len(names)} strategies" in start
        assert re.match(rf"{re.escape(name)}: done in \d+ s ", done)
        assert f" {i + 1}/{len(names)} strategies" in done
        assert ("ETA --:--" in start) == (i == 0)
        clock += [re.search(r"(\d+):(\d+) elapsed", line).groups() for line in (start, done)]
    seconds = [60 * int(m) + int(s) for m, s in clock]
    assert seconds == sorted(seconds)

    # the dynamic row: its estimate loop's radius is the one-revolution analysis's at the
    # block's gain, below 1 -- and above 1 at the gain times the reported margin x 1.2
    dyn = results[names.index(DYNAMIC)]
    scen = scenario_from_config(variants(data, outputs_of(data))[DYNAMIC], "test")
    block = scen.harmonic()
    w = 2 * np.pi * dyn.robustness["speed_hz"]
    from rotor_avc.analysis.sampled_loop import machine_sampled_loop
    loop = machine_sampled_loop(scen.machine, scen.sample_period_s)

    def radius(gain):
        return excitation_loop_poles(loop, w, w, block.sensors, block.schedule.disturbance_at(w),
                                     "newton", gain).max_abs_z

    gain = block.gain_at(w)
    assert dyn.robustness["max_abs_z_per_rev"] == radius(gain) < 1.0
    assert radius(gain * dyn.robustness["gain_margin"] * 1.2) > 1.0
    assert dyn.robustness["phase_limit_deg"] is None
    assert max(dyn.attenuation_db) < -3.0

    # the commissioned row: the machine is the model here, so the identified table is the
    # model's and the row the Newton law's (measured: -55.0 / -45.6 against -55.1 / -45.6 dB,
    # radius 0.996029 against 0.996019)
    com, newton = (results[names.index(n)] for n in (COMMISSIONED, "harmonic Newton"))
    assert np.allclose(com.attenuation_db, newton.attenuation_db, atol=1.0)
    assert max(com.attenuation_db) < -40.0 and com.time_to_20db_s == newton.time_to_20db_s
    assert abs(com.robustness["max_abs_z_per_rev"] - newton.robustness["max_abs_z_per_rev"]) \
        < 1e-4

    path = write_report(results, sensors, tmp_path, "case 3")
    with open(tmp_path / "strategies.csv") as fh:
        assert [row["strategy"] for row in csv.DictReader(fh)] == names
    assert (tmp_path / "one_x_vs_time.png").exists()
    text = path.read_text()
    head = page("x", [])
    assert text[:text.index("<title>")] == head[:head.index("<title>")]
    style = re.compile(r"<style>.*?</style>", re.S)
    assert style.search(text).group(0) == style.search(head).group(0)
    assert 'href="strategies.csv"' in text and 'href="one_x_vs_time.png"' in text
    assert check_report(path) == len(sensors)          # one 1x plot per sensor, all rendered
