"""Recording throughput: messages per second written to an MCAP bag (rosbag2 profile, zstd).

The same messages in the same run -- the topic set of the Werner 2021 graph at 5 kHz (clock, shaft
joint state, acceleration and force of four feet, the labelled observables), already serialised
to CDR -- written by

* baseline: the ``rosbags`` rosbag2 writer (MCAP storage), message by message;
* ``mcap``'s own Writer (what mcap-ros2-support writes through), message by message;
* ours, ``BagWriter.write_raw`` (the recorder node's path), message by message;
* ours, ``BagWriter.write_streams`` from the arrays (the simulator's path; CDR encoding included).

The arms run interleaved (A B C D A B C D ...), each figure the best of the repeats. Prints CPU
and wall microseconds per message, messages/s (CPU), the ratio to the baseline (CPU) and the
file sizes, and checks that our bags and the baseline's hold the same values.

Run: ``python bench/bench_bag.py [--seconds 2] [--repeats 3]``.
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

import numpy as np

from timing import interleaved, load_line, result
from rotor_avc.bag import BagReader, BagWriter, topics as T, write_bag

FS = 5000.0
DURATION_S = 2.0
CONFIG = {"machine": {"model": "foot_mount_3d"}}


def streams(t: np.ndarray, rng) -> list:
    """The topic set at the times ``t`` (s), random values from ``rng``."""
    speed = np.full(t.size, 2 * np.pi * 50)
    out = [T.clock(t), T.joint_state(t, speed * t, speed)]
    for foot in T.FOOT_IDS:
        out.append(T.foot_acceleration(foot, t, rng.standard_normal(t.size)))
        out.append(T.actuator_force(foot, t, rng.standard_normal(t.size)))
    out.append(T.labelled_array("plant/observables", t, [f"q{i}" for i in range(9)],
                                rng.standard_normal((t.size, 9))))
    return out


def make_streams(duration_s: float = DURATION_S) -> list:
    """``duration_s`` of the topic set at FS."""
    return streams(np.arange(int(FS * duration_s)) / FS, np.random.default_rng(0))


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
    shutil.rmtree(folder / "rosbags_bag", ignore_errors=True)     # the writer refuses to overwrite
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
    with BagWriter(path, CONFIG, overwrite=True) as w:
        for topic, _, t_ns, data in messages:
            w.write_raw(topic, data, t_ns)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=DURATION_S, help="recorded seconds at 5 kHz")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (best of)")
    args = ap.parse_args()
    run_streams = make_streams(args.seconds)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        messages = serialised_messages(run_streams, folder)
        n = len(messages)
        paths = {}
        writers = {
            "rosbags Writer (baseline)": lambda: rosbags_writer(messages, folder),
            "mcap Writer": lambda: mcap_writer(messages, folder),
            "ours: write_raw": lambda: ours_raw(messages, folder),
            "ours: write_streams": lambda: write_bag(folder / "ours_streams.mcap", run_streams,
                                                     CONFIG, overwrite=True)}
        best = interleaved({name: (lambda name=name: paths.__setitem__(name, writers[name]()))
                            for name in writers}, args.repeats)
        base = best["rosbags Writer (baseline)"][0]
        print(f"{n} messages ({len(run_streams)} topics, {args.seconds:g} s at {FS:g} Hz), best "
              f"of {args.repeats} interleaved rounds; {load_line()}")
        print(f"{'writer':28} {'CPU us/msg':>10} {'wall us/msg':>11} {'messages/s':>12} "
              f"{'ratio':>7} {'MB':>6}")
        for name, (cpu, wall) in best.items():
            size = Path(paths[name]).stat().st_size / 1e6
            print(f"{name:28} {cpu / n * 1e6:10.2f} {wall / n * 1e6:11.2f} {n / cpu:12,.0f} "
                  f"{cpu / base:6.2f}x {size:6.1f}")
        for name, what in (("ours: write_raw", "BagWriter.write_raw (the recorder's path)"),
                           ("ours: write_streams", "BagWriter.write_streams (the simulator's)")):
            cpu, wall = best[name]
            result(what, cpu / n, wall / n, "message", "rosbags rosbag2 Writer (MCAP, zstd)",
                   cpu / base)
        reference = paths["rosbags Writer (baseline)"]
        topic = "/avc/foot/DL/acceleration"
        with BagReader(reference) as ref:
            want = ref.series(topic)["accel.linear.z"]
        for name in ("ours: write_raw", "ours: write_streams"):
            with BagReader(paths[name]) as bag:
                assert bag.message_count == n
                assert np.array_equal(bag.series(topic)["accel.linear.z"], want), name
        print("values: our bags equal the baseline's")


if __name__ == "__main__":
    main()
