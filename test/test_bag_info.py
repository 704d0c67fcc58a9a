"""`rotor-avc bag info` answers from the summary section without reading the data (a bag whose
every chunk is damaged gets the same lines; `--integrity` reads the data and finds the damage);
a missing or damaged summary is one line suggesting `--integrity` and `bag recover`, never a
traceback; a rosbag2 directory is described from its metadata.yaml and each file's summary."""
from __future__ import annotations

import struct

import numpy as np
import pytest
import yaml

from rotor_avc.bag import BagReader, BagWriter, topics as T, write_bag
from rotor_avc.bag import records as R
from rotor_avc.bag.rosbag2 import open_bag
from rotor_avc.bag.sequence import check_sequence
from rotor_avc.bag.summary import read_summary
from rotor_avc.cli import main

RATE_HZ = 1000.0
CONFIG = {"machine": {"model": "info"}, "discretisation": {"sample_rate_hz": RATE_HZ}}
ACCEL, CLOCK = "/avc/foot/DL/acceleration", "/clock"


def bag_of(path, first: int, n: int, chunk_size: int = 4096):
    t = (first + np.arange(n)) / RATE_HZ
    return write_bag(path, [T.clock(t), T.foot_acceleration("DL", t, np.sin(t))], CONFIG,
                     chunk_size=chunk_size)


def summary_records(raw: bytes):
    """(footer offset, summary start, [(opcode, offset, body)] of the summary)."""
    footer = len(raw) - len(R.MAGIC) - 29
    start = struct.unpack_from("<Q", raw, footer + 9)[0]
    out, pos = [], start
    while pos < footer:
        op, length = struct.unpack_from("<BQ", raw, pos)
        out.append((op, pos, raw[pos + 9:pos + 9 + length]))
        pos += 9 + length
    return footer, start, out


def info(capsys, *args):
    status = main(["bag", "info", *map(str, args)])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return status, out, err


def test_info_reads_the_summary_not_the_data(tmp_path, capsys):
    path = bag_of(tmp_path / "run.mcap", 0, 3000)
    status, out, _ = info(capsys, path)
    assert status == 0
    assert f"{ACCEL}  geometry_msgs/msg/AccelStamped" in out and "3000" in out
    assert "1000 Hz" in out and "duration 2.999 s, 6000 messages" in out
    assert "summary CRC checked" in out and "--integrity" in out
    raw = bytearray(path.read_bytes())
    with BagReader(path) as r:
        chunks = list(r._summary.chunk_indexes)
    for ci in chunks:                                         # every chunk's compressed data
        raw[ci.chunk_start_offset + ci.chunk_length - 20] ^= 0xFF
    path.write_bytes(bytes(raw))
    assert info(capsys, path)[:2] == (0, out)
    status, checked, _ = info(capsys, "--integrity", path)
    assert status == 4 and checked.count("does not decompress") > 10


def test_topic_spans_come_from_the_message_indexes_of_overlapping_chunks(tmp_path):
    """Chunks overlap in time (the clock's first samples written last, after most of the
    acceleration): each topic's first and last log time, and so its rate, are exact."""
    path = tmp_path / "overlap.mcap"
    order = ([(ACCEL, 0)] + [(CLOCK, k) for k in range(50, 2000)]
             + [(CLOCK, k) for k in range(10, 50)] + [(ACCEL, k) for k in range(1, 2000)])
    with BagWriter(path, CONFIG, chunk_size=2048) as w:
        for topic, k in order:
            w.write(topic, {}, k * 1_000_000)
    s = read_summary(path)
    spans = {t.topic: (t.start_ns, t.end_ns, t.count) for t in s.topics}
    assert spans == {ACCEL: (0, 1_999_000_000, 2000), CLOCK: (10_000_000, 1_999_000_000, 1990)}
    assert all(t.rate_hz == pytest.approx(RATE_HZ) for t in s.topics)
    assert s.statistics.chunk_count == len(s.chunk_indexes) > 2


@pytest.mark.parametrize("damage, status, words", [
    ("truncated", 2, "no summary: the file ends without the MCAP footer"),
    ("no summary", 2, "has no summary section"),
    ("summary bit", 4, "damaged summary: its CRC does not match"),
    ("count, no CRC", 4, "damaged summary: the statistics count 6001 messages, their "
                         "channels 6000"),
    ("record length, no CRC", 4, "damaged summary (record at byte"),
    ("index offset, no CRC", 4, "points at a damaged message index"),
])
def test_a_missing_or_damaged_summary_is_one_line(tmp_path, capsys, damage, status, words):
    path = bag_of(tmp_path / "run.mcap", 0, 3000)
    raw = bytearray(path.read_bytes())
    footer, start, records = summary_records(bytes(raw))
    stats = next(at for op, at, _ in records if op == R.OP_STATISTICS)
    index = next(at for op, at, _ in records if op == R.OP_CHUNK_INDEX)
    if "no CRC" in damage:
        raw[footer + 25:footer + 29] = bytes(4)
    if damage == "truncated":
        raw = raw[:len(raw) // 2]
    elif damage == "no summary":
        raw[footer + 9:footer + 29] = bytes(20)
    elif damage == "summary bit":
        raw[stats + 9] ^= 0x01
    elif damage == "count, no CRC":
        raw[stats + 9] += 1                                   # message_count, low byte
    elif damage == "record length, no CRC":
        raw[index + 8] = 0x7F                                 # a length far past the end
    elif damage == "index offset, no CRC":
        raw[index + 9 + 4 * 8 + 4 + 2] ^= 0x01    # the first chunk's first message-index offset
    path.write_bytes(bytes(raw))
    got, out, err = info(capsys, path)
    assert got == status and not out
    [line] = err.strip().splitlines()
    assert words in line and "--integrity" in line and "bag recover" in line


def test_a_rosbag2_directory_from_metadata_yaml_and_each_files_summary(tmp_path, capsys):
    """Two split files (the second starting where the first ends) read as one bag: info names
    the directory and each file; a count metadata.yaml gets wrong is noted; the sample check
    streams across the files."""
    folder = tmp_path / "rec"
    folder.mkdir()
    files = [bag_of(folder / "rec_0.mcap", 0, 1200), bag_of(folder / "rec_1.mcap", 1200, 800)]
    entries = [{"path": f.name, "message_count": n} for f, n in zip(files, (2400, 1599))]
    (folder / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": {
        "version": 9, "storage_identifier": "mcap", "message_count": 4000,
        "relative_file_paths": [f.name for f in files], "files": entries,
        "starting_time": {"nanoseconds_since_epoch": 0},
        "duration": {"nanoseconds": 1_999_000_000}}}))
    status, out, _ = info(capsys, folder)
    assert status == 0
    assert out.startswith(f"{folder}: rosbag2 directory, storage 'mcap', 2 file(s); "
                          "metadata.yaml: 4000 messages, start 0 ns, duration 1.999 s")
    assert "rec_0.mcap" in out and "rec_1.mcap" in out and out.count("1000 Hz") == 4
    assert "note: metadata.yaml lists 1599 message(s) for this file, its statistics 1600" in out
    with open_bag(folder) as bag:
        report = check_sequence(bag)
    assert report.ok and report.samples == 2000
