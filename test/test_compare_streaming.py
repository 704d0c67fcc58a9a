"""The streamed bag source gives the comparison exactly what the in-memory run gives: the same
1x phasors, broadband estimates, checks and notes, bit for bit, also when dwells span many read
blocks, change inside a block, and are longer than the samples kept per dwell (the analysis then
uses the dwell's last samples in both)."""
from pathlib import Path

import numpy as np
import pytest

from rotor_avc.compare import bag_source, recorded_run
from rotor_avc.compare.comparison import compare_bag

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "bags" / "reference" / "case3_stepped.mcap"


def assert_same(streamed, in_memory):
    assert streamed.verdict == in_memory.verdict
    assert streamed.notes == in_memory.notes
    assert [(c.name, c.value, c.passed) for c in streamed.checks] == \
        [(c.name, c.value, c.passed) for c in in_memory.checks]
    a, b = streamed.one_x, in_memory.one_x
    np.testing.assert_array_equal(a.speed_rad_s, b.speed_rad_s)
    assert list(a.measured) == list(b.measured)
    for ch in a.measured:
        np.testing.assert_array_equal(a.measured[ch], b.measured[ch])
    for x, y in zip(streamed.broadband, in_memory.broadband, strict=True):
        np.testing.assert_array_equal(x.estimate.h1, y.estimate.h1)


@pytest.mark.parametrize("block_s, max_samples", [(1.0, 2 ** 17), (0.037, 200)])
def test_streamed_equals_in_memory(monkeypatch, block_s, max_samples):
    monkeypatch.setattr(bag_source, "BLOCK_S", block_s)
    monkeypatch.setattr(bag_source, "MAX_DWELL_SAMPLES", max_samples)
    monkeypatch.setattr(recorded_run, "MAX_DWELL_SAMPLES", max_samples)
    streamed, in_memory = compare_bag(REFERENCE), compare_bag(REFERENCE, in_memory=True)
    assert_same(streamed, in_memory)
    kept = [d.time_s.size for d in in_memory.run.dwells()]
    assert max(kept) <= max_samples and (max(kept) == max_samples) == (max_samples < 250)
    assert streamed.verdict == "PASS"
