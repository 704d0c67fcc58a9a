"""Corrupted and odd bags: every case ends in a clear error or a correct read.

A small bag of the package's topics (11 sampled topics, ~20 chunks) is damaged in two ways:

* seeded single-bit flips at random offsets inside every record kind, in the file as written
  and "resealed" (CRCs recomputed after the flip, as a writer that computes them over wrong
  records would do; then only the consistency checks can find the damage); each file as
  written is also recovered: a clear refusal, or a consistent bag of original messages only
  (anything else only with a note naming the altered record);
* the corruptions a hostile pass found passing a comparison: flipped bytes in message index
  records, a wrong statistics count, every message written twice, every other
  ``plant/observables`` message dropped, schema names renamed, the AccelStamped schema text
  replaced by Float64MultiArray's -- each written as a consistent file.

A case passes when opening with the integrity pass and reading every topic either raises a
:class:`RotorAvcError` (a clear, one-line error) or returns exactly the original numbers;
anything else (another exception, different numbers) fails it.
"""
from __future__ import annotations

import io
import struct
import time
import zlib

import numpy as np
import pytest

from rotor_avc.bag import BagReader, BagWriter, recover_bag, topics as T, write_bag
from rotor_avc.bag import records as R
from rotor_avc.bag.errors import CorruptBagError
from rotor_avc.bag.integrity import scan_bag
from rotor_avc.bag.mcap_writer import MAGIC, McapSink
from rotor_avc.bag.metadata import (COUNTS_RECORD, encode_counts, parse_qos_yaml,
                                     rosbag2_record)
from rotor_avc.bag.msgdefs import full_text
from rotor_avc.bag.sequence import IncompleteRecordingError, require_complete
from rotor_avc.errors import RotorAvcError

RATE_HZ = 1000.0
SAMPLES = 300
CONFIG = {"machine": {"model": "fuzz"}, "discretisation": {"sample_rate_hz": RATE_HZ}}
OBSERVABLES = "/avc/plant/observables"
ACCEL = "/avc/foot/DL/acceleration"
FLIPS_PER_KIND = 6
#: a case reading a ~100 kB bag for longer than this counts as a hang
CASE_LIMIT_S = 10.0
KIND_NAMES = {R.OP_HEADER: "header", R.OP_FOOTER: "footer", R.OP_SCHEMA: "schema",
              R.OP_CHANNEL: "channel", R.OP_CHUNK: "chunk", R.OP_MESSAGE_INDEX: "message_index",
              R.OP_CHUNK_INDEX: "chunk_index", R.OP_STATISTICS: "statistics",
              R.OP_METADATA: "metadata", R.OP_METADATA_INDEX: "metadata_index",
              R.OP_SUMMARY_OFFSET: "summary_offset", R.OP_DATA_END: "data_end"}


def make_bag(path):
    t = np.arange(SAMPLES) / RATE_HZ
    rng = np.random.default_rng(1)
    streams = [T.joint_state(t, 50 * t, np.full(SAMPLES, 50.0)), T.clock(t)]
    for fid in T.FOOT_IDS:
        streams.append(T.foot_acceleration(fid, t, rng.normal(size=SAMPLES)))
        streams.append(T.actuator_force(fid, t, rng.normal(size=SAMPLES)))
    streams.append(T.labelled_array("plant/observables", t, ["time_s", "a", "b"],
                                    np.column_stack([t, rng.normal(size=(SAMPLES, 2))])))
    return write_bag(path, streams, CONFIG, chunk_size=8192)


def read_all(path):
    """Everything a comparison reads: configuration, counts and every topic's numbers."""
    with BagReader(path, require_config=True, require_messages=True, integrity=True) as bag:
        out = {"config": bag.config, "counts": {k: v.count for k, v in bag.topics.items()}}
        for name in bag.topics:
            s = bag.series(name)
            out[name] = (s.time_ns, s.fields)
        require_complete(bag, SAMPLES)
    return out


def same(a, b) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, tuple):
        return all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return a.shape == np.shape(b) and np.array_equal(a, b)
    return a == b


def outcome(path, original) -> str:
    """'error' (a clear one), 'correct' (the original numbers) or what went wrong."""
    t0 = time.monotonic()
    try:
        result = read_all(path)
    except RotorAvcError:
        return "error" if time.monotonic() - t0 < CASE_LIMIT_S else "hang"
    except Exception as exc:                       # noqa: BLE001 -- a traceback is the failure
        return f"traceback {type(exc).__name__}: {exc}"
    if time.monotonic() - t0 > CASE_LIMIT_S:
        return "hang"
    return "correct" if same(result, original) else "WRONG NUMBERS"


def message_set(path) -> set:
    with BagReader(path) as bag:
        return {(m.topic, m.time_ns, m.data) for m in bag.raw_messages()}


def recovery_outcome(path, original: set) -> str:
    """'refused' (a clear error), 'recovered' (a consistent bag of original messages only),
    'recovered, noted' (anything else only with a note saying which record was altered) or
    what went wrong."""
    try:
        result = recover_bag(path, path.with_suffix(".recovered.mcap"))
    except RotorAvcError:
        return "refused"
    except Exception as exc:                       # noqa: BLE001 -- a traceback is the failure
        return f"traceback {type(exc).__name__}: {exc}"
    report = scan_bag(result.path)
    kept = message_set(result.path) if report.ok else set()
    if report.ok and kept <= original and len(kept) == result.messages:
        return "recovered"
    if result.notes:
        return "recovered, noted"
    return ("WRONG MESSAGES without a note" if report.ok
            else "inconsistent output without a note: " + report.verdict())


def layout(raw: bytes) -> list[R.Record]:
    return list(R.scan(io.BytesIO(raw), len(raw)))


def reseal(raw: bytearray) -> bytearray:
    """Recompute the data-section CRC and the summary CRC (a writer's own CRCs over records
    it got wrong)."""
    records = layout(bytes(raw))
    data_end = next(r for r in records if r.opcode == R.OP_DATA_END)
    struct.pack_into("<I", raw, data_end.offset + 9, zlib.crc32(raw[:data_end.offset]))
    footer = records[-1]
    summary_start, offset_start = struct.unpack_from("<QQ", raw, footer.offset + 9)
    start = summary_start or footer.offset
    crc = zlib.crc32(raw[start:footer.offset + 9 + 16])
    struct.pack_into("<I", raw, footer.offset + 9 + 16, crc)
    return raw


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    path = make_bag(tmp_path_factory.mktemp("fuzz") / "clean.mcap")
    return path, read_all(path)


def test_the_clean_bag_reads_and_is_consistent(bag):
    path, original = bag
    report = scan_bag(path)
    assert report.ok, report.verdict()
    assert report.crcs == {"data": "checked", "summary": "checked"}
    assert report.chunks > 10 and report.message_count == 11 * SAMPLES
    assert original["counts"][OBSERVABLES] == SAMPLES


@pytest.mark.parametrize("resealed", [False, True], ids=["as_written", "resealed"])
def test_random_flips_in_every_record_kind(bag, tmp_path, resealed):
    path, original = bag
    raw = path.read_bytes()
    rng = np.random.default_rng(20261201 + resealed)
    records = layout(raw)
    tally: dict[str, dict[str, int]] = {}
    recoveries: dict[str, int] = {}
    failures = []
    messages = message_set(path)
    targets = [(KIND_NAMES[r.opcode], r.offset, r.end) for r in records]
    targets += [("magic", 0, len(MAGIC)), ("magic", len(raw) - len(MAGIC), len(raw))]
    kinds = sorted({k for k, _, _ in targets})
    if resealed:          # without any CRC nothing can tell a flipped metadata value or
        kinds = [k for k in kinds if k not in ("metadata", "data_end", "magic")]   # header
    for kind in kinds:
        spans = [(a, b) for k, a, b in targets if k == kind]
        for _ in range(FLIPS_PER_KIND):
            a, b = spans[rng.integers(len(spans))]
            at = int(rng.integers(a, b))
            damaged = bytearray(raw)
            damaged[at] ^= 1 << int(rng.integers(8))
            if resealed and kind not in ("footer",):
                try:
                    damaged = reseal(damaged)
                except (StopIteration, R.RecordError, struct.error):
                    pass                          # the flip broke the structure itself
            case = tmp_path / f"{kind}_{at}.mcap"
            case.write_bytes(bytes(damaged))
            result = outcome(case, original)
            tally.setdefault(kind, {}).setdefault(result.split(":")[0], 0)
            tally[kind][result.split(":")[0]] += 1
            if result not in ("error", "correct"):
                failures.append(f"{kind} byte {at}: {result}")
            if not resealed:
                recovered = recovery_outcome(case, messages)
                recoveries[recovered.split(":")[0]] = recoveries.get(recovered.split(":")[0],
                                                                     0) + 1
                if recovered.split(":")[0] not in ("refused", "recovered", "recovered, noted"):
                    failures.append(f"{kind} byte {at}: recovery {recovered}")
    cases = sum(sum(v.values()) for v in tally.values())
    print(f"\n{'resealed' if resealed else 'as written'}: {cases} cases",
          {k: v for k, v in sorted(tally.items())}, "recovery:", recoveries)
    assert not failures, "\n".join(failures)
    assert cases == len(kinds) * FLIPS_PER_KIND


def rewrite(source, target, *, messages=lambda ms: ms, schema=lambda name, text: (name, text),
            counts_from=None):
    """A consistent copy (indexes, statistics, CRCs, metadata records all regenerated) with
    its messages and schemas passed through the given functions."""
    with BagReader(source) as r:
        summary = r._summary
        meta = {k: v for k, v in r.metadata.items() if k not in ("rosbag2", COUNTS_RECORD)}
        msgs = [(m.topic, m.time_ns, m.publish_time_ns, m.sequence, m.data)
                for m in r.raw_messages()]
        old_counts = r.metadata.get(COUNTS_RECORD)
    with open(target, "wb") as f:
        sink = McapSink(f, "ros2", "fuzz rewriter", "zstd", chunk_size=8192)
        for name, data in meta.items():
            sink.add_metadata(name, data)
        ids, types, qos = {}, {}, {}
        for cid, ch in sorted(summary.channels.items()):
            s = summary.schemas[ch.schema_id]
            name, text = schema(s.name, s.data.decode())
            sid = sink.add_schema(name, "ros2msg", text.encode())
            ids[ch.topic] = sink.add_channel(ch.topic, "cdr", sid, ch.metadata)
            types[ch.topic] = name
            qos[ch.topic] = parse_qos_yaml(ch.metadata["offered_qos_profiles"])
        written = {t: 0 for t in ids}
        for topic, t, p, seq, data in messages(msgs):
            sink.add_message(ids[topic], t, p, seq, data)
            written[topic] += 1
        sink.flush_chunk()
        counts = old_counts if counts_from == "original" else encode_counts(
            {t: {"published": n, "recorded": n, "lost": 0} for t, n in written.items()})
        sink.add_metadata(COUNTS_RECORD, counts)
        sink.add_metadata("rosbag2", rosbag2_record(
            "x.mcap", [{"name": t, "type": types[t], "qos": qos[t], "hash": "", "count": n}
                       for t, n in written.items()], sink.start_ns, sink.end_ns, "zstd"))
        sink.finish()
    return target


def twice(msgs):
    return [m for m in msgs for _ in (0, 1)]


def every_other_observable_dropped(msgs):
    kept, k = [], 0
    for m in msgs:
        if m[0] == OBSERVABLES:
            k += 1
            if k % 2:
                continue
        kept.append(m)
    return kept


def renamed(new_name):
    return lambda name, text: ((new_name, text) if name == "geometry_msgs/msg/AccelStamped"
                               else (name, text))


def accel_text_replaced(name, text):
    if name == "geometry_msgs/msg/AccelStamped":
        return name, full_text("std_msgs/msg/Float64MultiArray")
    return name, text


def flip_in_message_indexes(seed):
    def corrupt(raw: bytearray) -> bytearray:
        rng = np.random.default_rng(seed)
        indexes = [r for r in layout(bytes(raw)) if r.opcode == R.OP_MESSAGE_INDEX]
        rec = indexes[rng.integers(len(indexes))]
        entries = (len(rec.body) - 6) // 16
        at = rec.offset + 9 + 6 + 16 * int(rng.integers(entries)) + int(rng.integers(16))
        raw[at] ^= 1 << int(rng.integers(8))
        return reseal(raw)
    return corrupt


def wrong_statistics_count(raw: bytearray) -> bytearray:
    stats = next(r for r in layout(bytes(raw)) if r.opcode == R.OP_STATISTICS)
    # channel_message_counts: after the fixed fields (8+2+4+4+4+4+8+8) and its uint32 length
    at = stats.offset + 9 + 42 + 4 + 2
    count = struct.unpack_from("<Q", raw, at)[0]
    struct.pack_into("<Q", raw, at, count + 1)
    return reseal(raw)


CONSISTENT = {
    "messages_written_twice": dict(messages=twice),
    "every_other_observable_dropped_counts_kept": dict(messages=every_other_observable_dropped,
                                                       counts_from="original"),
    "schema_renamed_foreign": dict(schema=renamed("my_msgs/msg/AccelStamped")),
    "schema_renamed_known": dict(schema=renamed("geometry_msgs/msg/TwistStamped")),
    "accel_schema_text_of_float64multiarray": dict(schema=accel_text_replaced),
}
PATCHED = {f"message_index_flip_{seed}": flip_in_message_indexes(seed) for seed in range(20)}
PATCHED["wrong_statistics_count"] = wrong_statistics_count


@pytest.mark.parametrize("name", sorted(CONSISTENT) + sorted(PATCHED))
def test_known_corruptions_never_pass(bag, tmp_path, name):
    path, original = bag
    case = tmp_path / f"{name}.mcap"
    if name in CONSISTENT:
        rewrite(path, case, **CONSISTENT[name])
    else:
        case.write_bytes(bytes(PATCHED[name](bytearray(path.read_bytes()))))
    with pytest.raises(CorruptBagError) as err:
        read_all(case)
    assert err.value.exit_status == 4
    assert "\n" in str(err.value) and "fix:" in str(err.value)   # what, where, and the fix


def test_a_consistent_copy_passes_and_dropped_samples_are_incomplete(bag, tmp_path):
    """The rewriter itself makes a bag that passes: the checks above catch the corruption,
    not the rewriting. Samples dropped from a consistent file are missing samples (exit 3)."""
    path, original = bag
    assert same(read_all(rewrite(path, tmp_path / "copy.mcap")), original)
    dropped = rewrite(path, tmp_path / "dropped.mcap", messages=every_other_observable_dropped)
    with pytest.raises(IncompleteRecordingError, match="plant/observables: 150 sample"):
        read_all(dropped)
    assert IncompleteRecordingError.exit_status == 3


@pytest.mark.parametrize("compression", ["", "lz4"])
def test_odd_but_valid_bags_read_correctly(bag, tmp_path, compression):
    """Uncompressed and lz4 chunks, one message per chunk: the same numbers."""
    path, original = bag
    with BagReader(path) as r:
        streams_bag = tmp_path / f"odd_{compression or 'none'}.mcap"
        with BagWriter(streams_bag, CONFIG, compression=compression, chunk_size=1024) as w:
            for name, info in r.topics.items():
                w.add_topic(name, info.msg_type, info.qos)
            for m in r.raw_messages():
                w.write_raw(m.topic, m.data, m.time_ns)
    assert same(read_all(streams_bag), original)


def test_empty_truncated_and_headless_files_are_clear_errors(bag, tmp_path):
    path, original = bag
    raw = path.read_bytes()
    rng = np.random.default_rng(7)
    cuts = [0, len(MAGIC), len(MAGIC) + 5] + sorted(rng.integers(30, len(raw) - 1, 10).tolist())
    for cut in cuts:
        case = tmp_path / f"cut_{cut}.mcap"
        case.write_bytes(raw[:cut])
        assert outcome(case, original) == "error", cut
        result = recovery_outcome(case, message_set(path))
        assert result in ("refused", "recovered"), (cut, result)
    print(f"\n{len(cuts)} truncated files: clear errors, recovered as exact subsets or refused")
