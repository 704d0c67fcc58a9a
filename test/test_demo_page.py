"""The demo's overview page: the 1x of both cases with their model curves, the reduction table,
the counts of every run, the pole tables and links that resolve -- and it renders in a browser."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from browser_check import check_report
from rotor_avc.analysis.poles import machine_poles
from rotor_avc.bag import BagReader
from rotor_avc.cli.demo import BEARINGS, reductions
from rotor_avc.compare.comparison import compare_bag
from rotor_avc.interactive.page import PLOTLY_FILE, write_page
from rotor_avc.machine import load_machine
from rotor_avc.reports.demo_page import write_demo_page

REFERENCE_BAG = Path(__file__).resolve().parents[1] / "bags" / "reference" / "case3_stepped.mcap"


@pytest.fixture(scope="module")
def comparison():
    return compare_bag(REFERENCE_BAG)


def test_overview_page_holds_every_part(tmp_path, comparison):
    comps = {"case2": comparison, "case3": comparison}
    rows = reductions(comparison, comparison)
    with BagReader(REFERENCE_BAG) as reader:
        counts = {"case3": reader.counts}
    machine = load_machine("foot_mount_case3")
    poles = {"foot_mount_case3": {10.0: machine_poles(machine, 2 * math.pi * 10.0)}}
    report = tmp_path / "compare_case3" / "index.html"
    report.parent.mkdir()
    write_page(report, "case 3", [])                   # with its plotly.min.js beside it
    path = write_demo_page(tmp_path / "index.html", comps, rows, counts, poles,
                           [report, REFERENCE_BAG], BEARINGS)
    text = path.read_text()
    measured = [ch for ch in BEARINGS if ch in comparison.one_x.measured]
    assert measured and all(f'id="onex-{ch}"' in text for ch in measured)
    assert text.count("<tr>") >= 1 + len(rows) + 1 + len(counts["case3"]) + 1 + 6
    for row in rows:
        assert f"{row['speed_hz']:.5g}" in text
    for topic, c in counts["case3"].items():
        assert re.search(rf"<td[^>]*>{re.escape(topic)}</td><td[^>]*>{c['published']}</td>"
                         rf"<td[^>]*>{c['recorded']}</td>", text)
    hrefs = re.findall(r'<li><a href="([^"#][^"]*)"', text)   # files, not the contents' anchors
    assert len(hrefs) == 2
    for href in hrefs:
        assert (tmp_path / href).resolve().exists(), href
    # a linked report names the plotly.min.js it loads, which is there
    (script,) = re.findall(r"\(and ([^,]+), which it loads\)", text)
    assert script == f"compare_case3/{PLOTLY_FILE}" and (tmp_path / script).is_file()
    assert check_report(path) == len(measured)
