"""The committed reference bag (bags/reference/case3_stepped.mcap): regenerating it from
config/scenario_reference.yaml gives the same messages (so it cannot go stale silently), and
`rotor-avc compare` passes on it and writes the report."""
import json
import re
from pathlib import Path

import numpy as np

from rotor_avc.bag import BagReader
from rotor_avc.cli import main
from rotor_avc.compare.figures import POLE_X0
from rotor_avc.recording import write_run_bag
from rotor_avc.scenario import load_scenario

from browser_check import check_report

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "bags" / "reference" / "case3_stepped.mcap"
SCENARIO = ROOT / "config" / "scenario_reference.yaml"
#: sections that name where and with which version the bag was written, not what it holds
PROVENANCE = ("source", "package_version")


def test_regenerating_the_reference_bag_gives_the_same_messages(tmp_path):
    sc = load_scenario(SCENARIO)
    fresh = write_run_bag(tmp_path / "fresh.mcap", sc, sc.run(progress=False))
    with BagReader(REFERENCE, require_config=True) as old, BagReader(fresh) as new:
        assert old.topics == new.topics                    # names, types, counts, QoS, hashes
        keep = lambda c: {k: v for k, v in c.items() if k not in PROVENANCE}  # noqa: E731
        assert keep(old.config) == keep(new.config)
        for topic in old.topics:
            a, b = old.series(topic), new.series(topic)
            np.testing.assert_array_equal(a.time_ns, b.time_ns, err_msg=topic)
            assert a.labels == b.labels and set(a.fields) == set(b.fields), topic
            for name, values in a.fields.items():
                # bit-identical on one machine; 1e-9 of the field's range absorbs another BLAS
                scale = max(np.abs(values).max(), 1e-300)
                np.testing.assert_allclose(b.fields[name], values, rtol=0, atol=1e-9 * scale,
                                           err_msg=f"{topic} {name}")
    assert REFERENCE.stat().st_size < 500_000


def test_compare_passes_on_the_reference_bag(tmp_path, capsys):
    out = tmp_path / "report"
    assert main(["compare", str(REFERENCE), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "-> PASS" in text and "pass  resonance frequency error" in text
    data = json.loads((out / "metrics.json").read_text())
    assert data["pass"] is True and data["sample_rate_hz"] == 1000.0
    names = {c["name"] for c in data["checks"]}
    assert {"1x magnitude error away from resonances", "1x magnitude error at resonances",
            "1x band RMS error", "resonance frequency error",
            "resonance peak level error"} <= names
    rated = [c for c in data["checks"] if c["passed"] is not None]
    assert len(rated) >= 5
    assert all(c["passed"] is True and c["value"] <= c["tolerance"] for c in rated)
    # points still drifting within their dwell are listed, not rated
    assert all(c["name"].startswith("1x points not in steady state") for c in data["checks"]
               if c["passed"] is None)
    assert np.allclose(data["one_x"]["speeds_hz"], [103.0, 105.0, 107.0], rtol=1e-12)
    # at 1 kHz the digital loop differs visibly from the continuous one (reported, not rated)
    ref = {c["name"]: c for c in data["reference_model_metrics"]}
    assert ref["1x band RMS error"]["value"] > 1.0 and ref["1x band RMS error"]["passed"] is None
    for name in ("index.html", "frf.csv", "metrics.json", "poles.png", "one_x_bearing.png",
                 "one_x_foundation.png", "one_x_foot.png", "one_x_actuator.png"):
        assert (out / name).stat().st_size > 0, name
    rows = (out / "frf.csv").read_text().splitlines()
    assert len(rows) == 1 + 3 * len(data["one_x"]["channels"])
    text = re.sub(r"<script>.*?</script>", "", (out / "index.html").read_text(), flags=re.S)
    assert "issue" not in text.lower()           # the report speaks of the run and the machine
    # the pole map's real parts on a symmetric-log axis; the page without plotly.js is small
    assert check_report(out / "index.html", max_bytes=200_000, symlog={"poles": POLE_X0}) >= 3
