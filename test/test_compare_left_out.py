"""The points a comparison leaves out, counted in its verdict line and listed in its notes: the
committed reference bag (every point checked), and the same run with one channel zeroed (dead)
and one still growing within its dwells (not in steady state) -- counted against the checks'
own numbers (their checked points, the dead-channel check, the unsettled-points check); and a
resonance table with nothing to show says why."""
import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from rotor_avc.compare.comparison import compare_run
from rotor_avc.compare.left_out import left_out_points
from rotor_avc.compare.recorded_run import read_run
from rotor_avc.compare.report import metrics, verdict_text, write_html

REFERENCE = Path(__file__).resolve().parents[1] / "bags" / "reference" / "case3_stepped.mcap"
DEAD, GROWING = "bearing_N_vz", "foundation_DL_vy"


@pytest.fixture(scope="module")
def runs():
    run = read_run(REFERENCE)
    growth = 1.0 + 0.5 * (run.time_s / run.time_s[-1]) ** 4
    channels = {**run.channels, DEAD: np.zeros_like(run.channels[DEAD]),
                GROWING: run.channels[GROWING] * growth}
    return compare_run(run), compare_run(dataclasses.replace(run, channels=channels))


def _checked(comp) -> int:
    return sum(c.get("checked_points", 0) for c in comp.one_x.channels["sampled"].values())


def test_the_reference_run_leaves_no_point_out(runs):
    comp, _ = runs
    left = left_out_points(comp)
    assert left.points == 3 * len(comp.one_x.measured) == _checked(comp)
    assert left.n_points == 0 and verdict_text(comp, left) == "PASS"
    assert metrics(comp)["left_out"] == {"points": left.points, "bins": 0,
                                         "points_left_out": {}, "bins_left_out": {}}


def test_left_out_points_are_counted_by_reason_and_listed(runs, tmp_path):
    _, comp = runs
    left = left_out_points(comp)
    speeds = comp.one_x.speed_rad_s / (2 * np.pi)
    # every point is either checked or left out, and each reason names its points
    assert left.n_points + _checked(comp) == left.points == speeds.size * len(comp.one_x.measured)
    dead = next(c for c in comp.checks if c.name == "dead channels")
    assert dead.passed is False and DEAD in dead.detail
    (dead_points,) = [v for r, v in left.points_left_out.items() if r.startswith("dead channel")]
    assert dead_points == [f"{DEAD} at {f:.4g} Hz" for f in speeds]
    unsettled = next(c for c in comp.checks if c.name.startswith("1x points not in steady state"))
    n_unsettled = int(re.search(r"\((\d+)\)", unsettled.name).group(1))
    (steady,) = [v for r, v in left.points_left_out.items() if r.startswith("not in steady state")]
    assert len(steady) == n_unsettled >= 1 and all(p.startswith(GROWING) for p in steady)
    line = verdict_text(comp, left)
    assert line.startswith(f"FAIL, {left.n_points} of {left.points} 1x points left out (")
    page = write_html(comp, metrics(comp), [], tmp_path / "index.html").read_text()
    notes = re.search(r'<h2 id="sec-notes">Notes</h2><ul>(.*?)</ul>', page, re.S).group(1)
    assert "<li>none</li>" not in notes and notes.count("left out of the 1x checks") == len(
        left.points_left_out)
    assert f"{DEAD} at " + ", ".join(f"{f:.4g}" for f in speeds) + " Hz" in notes
    assert line.replace("'", "&#x27;") in page


def test_an_empty_resonance_table_says_why(runs, tmp_path):
    comp, _ = runs
    data = metrics(comp)
    data["one_x"]["resonances"] = []
    page = write_html(comp, data, [], tmp_path / "index.html").read_text()
    section = re.search(r'<h2 id="sec-resonances[^"]*">.*?</h2>(.*?)<h2', page, re.S).group(1)
    assert "<table>" not in section
    assert "No resonance compared: no resonance peak of the models lies within the measured " \
           "speeds (103 .. 107 Hz)" in section
