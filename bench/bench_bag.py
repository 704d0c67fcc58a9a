"""Recording throughput: messages per second written to an MCAP bag (rosbag2 profile, zstd).

The same messages in the same run -- the topic set of the Werner 2021 graph at 5 kHz (clock, shaft
joint state, acceleration and force of four feet, the labelled observables), already serialised
to CDR -- written by

* baseline: the ``rosbags`` rosbag2 writer (MCAP storage), message by message;
* ``mcap``'s own Writer (what mcap-ros2-support writes through), message by message;
* ours, ``BagWriter.write_raw`` (the recorder node's path), message by message;
* ours, ``BagWriter.write_streams`` from the arrays (the simulator's path; CDR encoding included).

Prints messages/s and the ratio to the baseline, and checks that our bags and the baseline's
hold the same values. Run: ``python bench/bench_bag.py``.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from rotor_avc.bag import BagReader, BagWriter, topics as T, write_bag

FS = 5000.0
DURATION_S = 2.0
CONFIG = {"machine": {"model": "foot_mount_3d"}}


def make_streams():
    rng = np.random.default_rng(0)
    t = np.arange(int(FS * DURATION_S)) / FS
    speed = np.full(t.size, 2 * np.pi * 50)
    streams = [T.clock(t), T.joint_state(t, speed * t, speed)]
    for foot in T.FOOT_IDS:
        streams.append(T.foot_acceleration(foot, t, rng.standard_normal(t.size)))
        streams.append(T.actuator_force(foot, t, rng.standard_normal(t.size)))
    streams.append(T.labelled_array("plant/observables", t, [f"q{i}" for i in range(9)],
                                    rng.standard_normal((t.size, 9))))
    return streams


def serialised_messages(streams, folder):
    """(topic, type, time_ns, cdr bytes) in time order, via our own (tested) encoder."""
    path = write_bag(folder / "source.mcap", streams, CONFIG)
    with BagReader(path) as bag:
        types = {name: info.msg_type for name, info in bag.topics.items()}
        return [(m.topic, types[m.topic], m.time_ns, bytes(m.data)) for m in bag.raw_messages()]


def rosbags_writer(messages, folder):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    w = Writer(folder / "rosbags_bag", version=9, storage_plugin=StoragePlugin.MCAP)
    w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)     # zstd chunks
    with w:
        conns = {}
        for topic, msg_type, t_ns, data in messages:
            conn = conns.get(topic)
            if conn is None:
                conn = conns[topic] = w.add_connection(topic, msg_type, typestore=store)
            w.write(conn, t_ns, data)
    return next((folder / "rosbags_bag").glob("*.mcap"))


def mcap_writer(messages, folder):
    from mcap.writer import Writer
    from rotor_avc.bag.msgdefs import full_text
    path = folder / "mcap_writer.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="bench")
        channels = {}
        for topic, msg_type, t_ns, data in messages:
            cid = channels.get(topic)
            if cid is None:
                sid = w.register_schema(msg_type, "ros2msg", full_text(msg_type).encode())
                cid = channels[topic] = w.register_channel(topic, "cdr", sid)
            w.add_message(cid, t_ns, data, t_ns)
        w.finish()
    return path


def ours_raw(messages, folder):
    path = folder / "ours_raw.mcap"
    with BagWriter(path, CONFIG) as w:
        for topic, _, t_ns, data in messages:
            w.write_raw(topic, data, t_ns)
    return path


def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def main() -> None:
    streams = make_streams()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        messages = serialised_messages(streams, folder)
        n = len(messages)
        runs = {}
        runs["rosbags Writer (baseline)"] = timed(rosbags_writer, messages, folder)
        runs["mcap Writer"] = timed(mcap_writer, messages, folder)
        runs["ours: write_raw"] = timed(ours_raw, messages, folder)
        runs["ours: write_streams"] = timed(write_bag, folder / "ours_streams.mcap", streams,
                                            CONFIG)
        base = runs["rosbags Writer (baseline)"][1]
        print(f"{n} messages ({len(streams)} topics, {DURATION_S:g} s at {FS:g} Hz), same run")
        print(f"{'writer':28} {'messages/s':>12} {'ratio':>7} {'MB':>6}")
        for name, (path, dt) in runs.items():
            size = Path(path).stat().st_size / 1e6
            print(f"{name:28} {n / dt:12,.0f} {base / dt:6.1f}x {size:6.1f}")
        reference = runs["rosbags Writer (baseline)"][0]
        topic = "/avc/foot/DL/acceleration"
        with BagReader(reference) as ref:
            want = ref.series(topic)["accel.linear.z"]
        for name in ("ours: write_raw", "ours: write_streams"):
            with BagReader(runs[name][0]) as bag:
                assert bag.message_count == n
                assert np.array_equal(bag.series(topic)["accel.linear.z"], want), name
        print("values: our bags equal the baseline's")


if __name__ == "__main__":
    main()
