"""Malformed bags and bad writer input give a BagError naming the problem (never a traceback),
and a recording killed with SIGKILL is recovered up to its last complete chunk."""
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rotor_avc.bag import BagError, BagReader, BagWriter, recover_bag, topics as T
from rotor_avc.bag.cdr import CdrCodec
from rotor_avc.bag.mcap_writer import MESSAGE_HEADER, McapSink
from rotor_avc.bag.msgdefs import full_text, known_specs
from rotor_avc.errors import RotorAvcError

ROOT = Path(__file__).resolve().parents[1]
CONFIG = {"machine": {"model": "foot_mount_3d"}}
TOPIC = "/avc/foot/DL/acceleration"


def small_bag(path, n=3000, chunk_size=4096, config=CONFIG):
    t = np.arange(n) * 1e-3
    with BagWriter(path, config, chunk_size=chunk_size) as w:
        w.write_streams([T.foot_acceleration("DL", t, np.arange(n, dtype=float))])
    return path


def test_bag_error_is_a_rotor_avc_error():
    assert issubclass(BagError, RotorAvcError)


def test_missing_empty_and_foreign_files(tmp_path):
    with pytest.raises(BagError, match="no such bag file"):
        BagReader(tmp_path / "nope.mcap")
    (tmp_path / "empty.mcap").write_bytes(b"")
    with pytest.raises(BagError, match=r"empty file \(0 bytes\)"):
        BagReader(tmp_path / "empty.mcap")
    (tmp_path / "junk.mcap").write_bytes(os.urandom(200))
    with pytest.raises(BagError, match="not an MCAP file"):
        BagReader(tmp_path / "junk.mcap")


@pytest.mark.parametrize("keep", [0.02, 0.5, 0.97])
def test_truncated_bag_is_refused_then_recovered(tmp_path, keep):
    full = small_bag(tmp_path / "full.mcap")
    raw = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(raw[:int(len(raw) * keep)])
    with pytest.raises(BagError, match="truncated.*recover_bag"):
        BagReader(cut)
    result = recover_bag(cut)
    assert result.path == tmp_path / "cut.recovered.mcap"
    assert (result.dropped_bytes > 0) == (result.messages < 3000)   # a cut summary loses nothing
    with BagReader(result.path, require_config=True) as r:
        assert r.config["machine"] == CONFIG["machine"]
        if result.messages:
            z = r.series(TOPIC)["accel.linear.z"]
            np.testing.assert_array_equal(z, np.arange(result.messages))   # an exact prefix
    if keep > 0.9:
        assert result.messages > 2900      # only the tail (summary, last chunk) was cut


def test_recovering_a_complete_bag_keeps_everything(tmp_path):
    full = small_bag(tmp_path / "full.mcap")
    result = recover_bag(full, tmp_path / "copy.mcap")
    assert result.messages == 3000 and result.dropped_bytes == 0
    with BagReader(result.path) as a, BagReader(full) as b:
        np.testing.assert_array_equal(a.series(TOPIC)["accel.linear.z"],
                                      b.series(TOPIC)["accel.linear.z"])
    with pytest.raises(BagError, match="must be a new file"):
        recover_bag(full, full)


CRASH_SCRIPT = """
import sys, time
from rotor_avc.bag import BagWriter
w = BagWriter(sys.argv[1], {"machine": {"model": "crash"}}, chunk_size=4096)
w.add_topic("/avc/foot/DL/acceleration")
for k in range(5000):
    w.write("/avc/foot/DL/acceleration", {"accel": {"linear": {"z": float(k)}}}, k * 1000)
print("written", flush=True)
time.sleep(120)
"""


def test_sigkill_loses_at_most_the_last_chunk(tmp_path):
    path = tmp_path / "killed.mcap"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-c", CRASH_SCRIPT, str(path)], env=env,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "written"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    with pytest.raises(BagError, match="truncated"):
        BagReader(path)
    result = recover_bag(path)
    codec = CdrCodec("geometry_msgs/msg/AccelStamped", known_specs())
    record_bytes = MESSAGE_HEADER.size + len(codec.encode({}))   # one message record
    per_chunk = 4096 // record_bytes + 1
    assert 5000 - per_chunk <= result.messages < 5000
    with BagReader(result.path, require_config=True) as r:
        assert r.config["machine"] == {"model": "crash"}
        np.testing.assert_array_equal(r.series(TOPIC)["accel.linear.z"],
                                      np.arange(result.messages, dtype=float))


def _foreign_bag(path, schemas):
    with open(path, "wb") as f:
        sink = McapSink(f, "ros2", "test")
        for topic, (name, encoding, text, payload) in schemas.items():
            sid = sink.add_schema(name, encoding, text.encode())
            cid = sink.add_channel(topic, "cdr", sid, {})
            sink.add_message(cid, 5, 5, 1, payload)
        sink.finish()
    return path


def test_unknown_schema_names_topic_type_and_reason(tmp_path):
    ok = (b"\x00\x01\x00\x00" + bytes(8))
    path = _foreign_bag(tmp_path / "foreign.mcap", {
        "/missing_dep": ("foo_msgs/msg/Bar", "ros2msg", "foo_msgs/Baz baz\n", ok),
        "/protobuf": ("foo.Bar", "protobuf", "syntax...", ok),
        "/clock": ("rosgraph_msgs/msg/Clock", "ros2msg", full_text("rosgraph_msgs/msg/Clock"),
                   ok),
    })
    with BagReader(path) as r:
        assert r.topics["/missing_dep"].msg_type == "foo_msgs/msg/Bar"
        with pytest.raises(BagError, match=r"/missing_dep: unknown schema 'foo_msgs/msg/Bar'.*"
                                           r"lacks the definition of foo_msgs/msg/Baz"):
            r.series("/missing_dep")
        with pytest.raises(BagError, match=r"/protobuf: unknown schema 'foo.Bar' with encoding "
                                           r"'protobuf'"):
            list(r.messages("/protobuf"))
        assert r.series("/clock")["clock.sec"].tolist() == [0]      # the rest still reads
        with pytest.raises(BagError, match="no topic /nope"):
            r.series("/nope")
        with pytest.raises(BagError, match="no run configuration"):
            r.config


def test_wrong_profile_and_bad_payload(tmp_path):
    path = tmp_path / "p.mcap"
    with open(path, "wb") as f:
        sink = McapSink(f, "", "test")
        sink.finish()
    with pytest.raises(BagError, match="MCAP profile is '', not 'ros2'"):
        BagReader(path)
    bad = _foreign_bag(tmp_path / "bad.mcap", {"/clock": (
        "rosgraph_msgs/msg/Clock", "ros2msg", full_text("rosgraph_msgs/msg/Clock"), b"\x00\x01")})
    with BagReader(bad) as r, pytest.raises(BagError, match="does not match its schema"):
        list(r.messages())


def test_missing_configuration_and_empty_bag(tmp_path):
    path = small_bag(tmp_path / "noconf.mcap", config=None)
    with BagReader(path) as r:
        assert r.message_count == 3000
        with pytest.raises(BagError, match="carries no run configuration"):
            r.config
    with pytest.raises(BagError, match="carries no run configuration"):
        BagReader(path, require_config=True)
    empty = tmp_path / "empty.mcap"
    with BagWriter(empty, CONFIG) as w:
        w.add_topic(TOPIC)
    with BagReader(empty) as r:
        assert r.message_count == 0 and r.topics[TOPIC].count == 0
        with pytest.raises(BagError, match=f"topic {TOPIC} has no messages"):
            r.series(TOPIC)
    with pytest.raises(BagError, match="holds no messages"):
        BagReader(empty, require_messages=True)


def test_writer_input_errors(tmp_path):
    with pytest.raises(BagError, match="must end in .mcap"):
        BagWriter(tmp_path / "x.bag", CONFIG)
    small_bag(tmp_path / "exists.mcap")
    with pytest.raises(BagError, match="file exists"):
        BagWriter(tmp_path / "exists.mcap", CONFIG)
    with pytest.raises(BagError, match="needs a `machine` mapping"):
        BagWriter(tmp_path / "a.mcap", {"controllers": {}})
    with pytest.raises(BagError, match=r"machine.when: object cannot be stored"):
        BagWriter(tmp_path / "b.mcap", {"machine": {"when": object()}})
    with BagWriter(tmp_path / "c.mcap", CONFIG) as w:
        with pytest.raises(BagError, match="'/foo' is not one of the package's topics"):
            w.write_raw("/foo", b"\x00\x01\x00\x00", 0)
        with pytest.raises(BagError, match="not one the package records"):
            w.add_topic("/foo", "foo_msgs/msg/Bar")
        with pytest.raises(BagError, match="bad time"):
            w.write_raw(TOPIC, b"\x00\x01\x00\x00", -5)
        stream = T.foot_acceleration("DL", [0.0, 1.0], [1.0, 2.0])
        stream.fields["accel.linear.q"] = stream.fields.pop("accel.linear.z")
        with pytest.raises(BagError, match="no numeric field 'accel.linear.q'"):
            w.write_streams([stream])
        with pytest.raises(BagError, match="not a list of float64|not a valid"):
            w.write(TOPIC, {"accel": {"linear": {"z": "high"}}}, 0)
    with pytest.raises(BagError, match="already closed"):
        w.write_raw(TOPIC, b"", 0)
    with pytest.raises(BagError, match="1 values for 2 times"):
        T.foot_acceleration("DL", [0.0, 1.0], [1.0])
    with pytest.raises(BagError, match="labels must be unique"):
        T.labelled_array("plant/observables", [0.0], ["a,b"], [[1.0]])
    with pytest.raises(BagError, match="non-negative seconds"):
        T.clock([-1.0])


def test_damaged_chunk_is_reported_and_recovery_keeps_every_other_chunk(tmp_path):
    path = small_bag(tmp_path / "full.mcap")
    raw = bytearray(path.read_bytes())
    with BagReader(path) as r:
        chunks = sorted(r._summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
        times = r.log_times(TOPIC)
    third = chunks[2]
    middle = third.chunk_start_offset + third.chunk_length // 2
    raw[middle:middle + 16] = bytes(16)                   # zero 16 bytes of compressed data
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(raw))
    with BagReader(bad) as r:
        with pytest.raises(BagError, match="damaged chunk"):
            r.series(TOPIC)
        with pytest.raises(BagError, match="damaged chunk"):
            list(r.messages(TOPIC))
    result = recover_bag(bad)
    with BagReader(result.path, integrity=True) as r:
        z = r.series(TOPIC)["accel.linear.z"]
    in_third = (times >= third.message_start_time) & (times <= third.message_end_time)
    assert result.messages == z.size == 3000 - in_third.sum()
    assert result.lost == {TOPIC: in_third.sum()} and len(result.lost_chunks) == 1
    np.testing.assert_array_equal(z, np.flatnonzero(~in_third))   # every other chunk, intact
