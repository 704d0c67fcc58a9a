"""`rotor-avc bag recover` and `bag info` on damaged bags: clear errors, every intact chunk kept,
memory independent of the file's size, no output left by an interrupted recovery."""
from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from rotor_avc.bag import BagReader, BagWriter, recover_bag, topics as T, write_bag
from rotor_avc.bag import records as R
from rotor_avc.bag import recover as recover_module
from rotor_avc.bag.errors import CorruptBagError
from rotor_avc.bag.integrity import scan_bag
from rotor_avc.cli import main

TOPIC = "/avc/foot/DL/acceleration"
CONFIG = {"machine": {"model": "cli"}}


def bag_of(path, n: int, chunk_size: int = 8192):
    t = np.arange(n) * 1e-3
    return write_bag(path, [T.foot_acceleration("DL", t, np.arange(n, dtype=float))], CONFIG,
                     chunk_size=chunk_size)


def chunk_offsets(path):
    with BagReader(path) as r:
        return sorted((c.chunk_start_offset, c.chunk_length, c.message_start_time,
                       c.message_end_time) for c in r._summary.chunk_indexes)


def test_recover_keeps_every_chunk_but_the_damaged_first_one(tmp_path, capsys):
    source = bag_of(tmp_path / "run.mcap", 3000)
    first = chunk_offsets(source)[0]
    raw = bytearray(source.read_bytes())
    raw[first[0] + first[1] // 2] ^= 0x10                      # one bit inside chunk 1
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(raw))
    assert main(["bag", "info", "--integrity", str(bad)]) == 4
    assert "chunk at byte" in capsys.readouterr().out
    out_path = tmp_path / "fixed.mcap"
    assert main(["bag", "recover", str(bad), "--out", str(out_path)]) == 0
    out = capsys.readouterr().out
    lost = (first[3] - first[2]) // 1_000_000 + 1             # the first chunk's samples
    assert f"{TOPIC}: kept {3000 - lost}, lost {lost}" in out
    with BagReader(out_path, integrity=True) as r:
        z = r.series(TOPIC)["accel.linear.z"]
    np.testing.assert_array_equal(z, np.arange(lost, 3000))
    assert main(["bag", "check", str(out_path)]) == 4           # the loss is on record:
    problems = [line for line in capsys.readouterr().out.splitlines() if "PROBLEM" in line]
    assert len(problems) == 1 and f"the recording reports {lost} message(s) lost" in problems[0]


def test_a_damaged_length_field_is_skipped_to_the_next_chunk(tmp_path):
    source = bag_of(tmp_path / "run.mcap", 3000)
    chunks = chunk_offsets(source)
    raw = bytearray(source.read_bytes())
    raw[chunks[1][0] + 6] ^= 0x20                       # chunk 2's length: past the file end
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(raw))
    result = recover_bag(bad)
    lost = (chunks[1][3] - chunks[1][2]) // 1_000_000 + 1
    assert result.lost == {TOPIC: lost} and result.messages == 3000 - lost
    assert "runs past the end of the file" in result.lost_chunks[0][1]


def test_out_errors_are_one_line(tmp_path, capsys):
    source = bag_of(tmp_path / "run.mcap", 100)
    exists = tmp_path / "exists.mcap"
    exists.write_bytes(b"x")
    assert main(["bag", "recover", str(source), "--out", str(exists)]) == 2
    assert "output file exists" in capsys.readouterr().err and exists.read_bytes() == b"x"
    assert main(["bag", "recover", str(source), "--out", str(tmp_path / "no" / "x.mcap")]) == 2
    assert main(["bag", "recover", str(tmp_path / "none.mcap")]) == 2
    (tmp_path / "junk.mcap").write_bytes(b"junk" * 100)
    assert main(["bag", "recover", str(tmp_path / "junk.mcap")]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 3


def test_ctrl_c_leaves_no_output(tmp_path, monkeypatch, capsys):
    source = bag_of(tmp_path / "run.mcap", 2000)
    calls = {"n": 0}
    original = recover_module.McapSink.add_message

    def interrupted(self, *args):
        calls["n"] += 1
        if calls["n"] == 1000:
            raise KeyboardInterrupt
        return original(self, *args)

    monkeypatch.setattr(recover_module.McapSink, "add_message", interrupted)
    assert main(["bag", "recover", str(source), "--out", str(tmp_path / "new.mcap")]) == 130
    assert "no output file was written" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]


def peak_bytes(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_recovery_and_the_integrity_pass_stream(tmp_path):
    """Peak memory with a 4x longer file: the same (one chunk at a time), not 4x. Both files
    are longer than the 1 MiB chunk the recovered file is written in."""
    small = bag_of(tmp_path / "small.mcap", 20_000, chunk_size=1 << 16)
    large = bag_of(tmp_path / "large.mcap", 80_000, chunk_size=1 << 16)
    assert large.stat().st_size > 3.5 * small.stat().st_size
    for job in (lambda p: recover_bag(p, p.with_suffix(".r.mcap")), scan_bag):
        peaks = [peak_bytes(lambda p=p: job(p)) for p in (small, large)]
        print("peak bytes (1x, 4x file):", peaks)
        assert peaks[1] < 1.5 * peaks[0], peaks


def test_an_oversized_chunk_costs_that_chunk_only(tmp_path, monkeypatch):
    """A chunk claiming more uncompressed bytes than the limit (a 1 GiB message in a few kB of
    zstd, scaled down here) is refused, not allocated; the other chunks are kept."""
    path = tmp_path / "odd.mcap"
    with BagWriter(path, CONFIG, chunk_size=4096) as w:
        w.add_topic("/avc/plant/observables")
        for k in range(200):
            w.write("/avc/plant/observables", {"data": np.zeros(20_000 if k == 100 else 4)},
                    k * 1000)
    monkeypatch.setattr(R, "MAX_CHUNK_BYTES", 100_000)
    result = recover_bag(path)
    lost = result.lost["/avc/plant/observables"]
    assert 1 <= lost < 50 and result.messages == 200 - lost and len(result.lost_chunks) == 1
    assert "limit 100000" in result.lost_chunks[0][1]
    with pytest.raises(CorruptBagError, match="limit 100000"):
        BagReader(path, integrity=True)


def test_a_record_above_the_length_limit_is_refused_unread(tmp_path, monkeypatch):
    source = bag_of(tmp_path / "run.mcap", 3000)
    monkeypatch.setattr(R, "MAX_RECORD_BYTES", 300)             # every chunk is "too long"
    report = scan_bag(source)
    assert not report.ok and "above the limit of 300" in report.verdict()
    result = recover_bag(source)
    assert result.messages == 0 and result.lost_chunks
    assert all("above the limit" in why for _, why in result.lost_chunks)
