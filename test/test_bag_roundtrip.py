"""Write -> read with three readers: ours, the `mcap` package with mcap-ros2-support's decoder,
and the independent `rosbags` library. Values equal, metadata intact, rosbag2 profile fields
(profile, schema encoding and text, message encoding, QoS, type hash, rosbag2 record) present."""
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from rotor_avc.bag import BagReader, BagWriter, msgdefs, topics as T
from rotor_avc.bag.metadata import load_yaml

FS = 2000.0
N = 1500
FEET = ("DL", "DR", "NL")
CONFIG = {"machine": {"model": "foot_mount_3d", "machine": {"stator_mass_kg": 7200.0}},
          "controllers": {"DL": {"type": "I", "ki": 1.4e5}},
          "discretisation": {"sample_rate_hz": FS, "method": "tustin", "w_F": "speed"},
          "speed_profile": {"kind": "stepped", "speeds_hz": [10.0, 20.0]},
          "balancer": None, "unbalance": {"static": complex(1e-3, 2e-4)}}


def make_run(rng):
    t = np.arange(N) / FS
    speed = np.where(t < t[-1] / 2, 2 * np.pi * 10, 2 * np.pi * 20)
    angle = np.concatenate([[0.0], np.cumsum(speed[:-1] / FS)])
    data = {"t": t, "speed": speed, "angle": angle,
            "acc": {f: rng.standard_normal(N) for f in FEET},
            "force": {f: rng.standard_normal(N) * 100 for f in FEET},
            "obs": rng.standard_normal((N, 4)),
            "est": rng.standard_normal((N // 10, 2))}
    streams = [T.clock(t), T.joint_state(t, angle, speed)]
    for f in FEET:
        streams.append(T.foot_acceleration(f, t, data["acc"][f]))
        streams.append(T.actuator_force(f, t, data["force"][f]))
    streams.append(T.labelled_array("plant/observables", t,
                                    ["bearing_D_vz", "bearing_D_vy", "foundation_DL_vz",
                                     "actuator_DL_fz"], data["obs"]))
    streams.append(T.labelled_array("balancer/estimate", t[::10], ["static_re", "static_im"],
                                    data["est"]))
    return data, streams


DIAG_TIMES_NS = [0, 250_000_000, 500_000_000]


def diag(k):
    return {"header": {"stamp": {"sec": 0, "nanosec": DIAG_TIMES_NS[k]}},
            "status": [{"level": k, "name": "plant_simulator", "message": f"step {k}",
                        "hardware_id": "sim", "values": [{"key": "rtf", "value": str(1.5 + k)}]}]}


@pytest.fixture(scope="module", params=["zstd", "lz4", ""])
def bag(request, tmp_path_factory):
    rng = np.random.default_rng(3)
    data, streams = make_run(rng)
    path = tmp_path_factory.mktemp("bags") / f"run_{request.param or 'none'}.mcap"
    with BagWriter(path, CONFIG, compression=request.param, chunk_size=32 * 1024) as w:
        w.add_topic("/diagnostics", qos=[{"depth": 100, "durability": "transient_local"}])
        w.write_streams(streams)
        for k, t_ns in enumerate(DIAG_TIMES_NS):      # written after, out of file order
            w.write("/diagnostics", diag(k), t_ns)
    counts = {s.topic: len(s.time_ns) for s in streams}
    counts["/diagnostics"] = len(DIAG_TIMES_NS)
    return path, data, counts


def test_our_reader(bag):
    path, data, counts = bag
    with BagReader(path, require_config=True, require_messages=True) as r:
        assert {k: v.count for k, v in r.topics.items()} == counts
        assert r.message_count == sum(counts.values())
        assert r.time_range_ns == (0, int(round(data["t"][-1] * 1e9)))
        cfg = r.config
        assert cfg["machine"] == CONFIG["machine"] and cfg["controllers"] == CONFIG["controllers"]
        assert cfg["discretisation"] == CONFIG["discretisation"]
        assert cfg["unbalance"] == {"static": {"re": 1e-3, "im": 2e-4}}
        assert cfg["package_version"] and cfg["format"] == "rotor_avc.bag/1"
        js = r.series("/avc/rotor/joint_state")
        np.testing.assert_array_equal(js["position[0]"], data["angle"])
        np.testing.assert_array_equal(js["velocity"][:, 0], data["speed"])
        np.testing.assert_array_equal(js.time_ns, T.to_ns(data["t"]))
        np.testing.assert_array_equal(js["header.stamp.sec"] * 10**9 + js["header.stamp.nanosec"],
                                      js.time_ns)
        for f in FEET:
            np.testing.assert_array_equal(
                r.series(f"/avc/foot/{f}/acceleration")["accel.linear.z"], data["acc"][f])
            np.testing.assert_array_equal(
                r.series(f"/avc/foot/{f}/actuator_force")["wrench.force.z"], data["force"][f])
        obs = r.series("/avc/plant/observables")
        assert obs.labels == ["bearing_D_vz", "bearing_D_vy", "foundation_DL_vz", "actuator_DL_fz"]
        np.testing.assert_array_equal(obs["foundation_DL_vz"], data["obs"][:, 2])
        np.testing.assert_array_equal(r.series("/avc/balancer/estimate")["static_im"],
                                      data["est"][:, 1])
        msgs = list(r.messages("/diagnostics"))
        assert [m.time_ns for m in msgs] == DIAG_TIMES_NS
        assert msgs[2].data["status"][0]["values"][0]["value"] == "3.5"
        series = r.series("/diagnostics")          # varying structure: per-message path
        np.testing.assert_array_equal(series["status[0].level"], [0, 1, 2])
        times = [m.time_ns for m in r.raw_messages()]
        assert times == sorted(times) and len(times) == r.message_count


def test_mcap_reader_with_mcap_ros2_decoder(bag):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    path, data, counts = bag
    raw = path.read_bytes()
    op, length, summary_start, _, crc = struct.unpack("<BQQQI", raw[-8 - 29:-8])
    assert (op, length) == (0x02, 20) and zlib.crc32(raw[summary_start:-8 - 4]) == crc
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
            assert schema.data.decode() == msgdefs.full_text(schema.name)
            assert channel.metadata["topic_type_hash"] == msgdefs.type_hash(schema.name)
            qos = load_yaml(channel.metadata["offered_qos_profiles"])
            assert qos[0]["reliability"] == "reliable" and qos[0]["history"] == "keep_last"
        seen = {topic: 0 for topic in counts}
        acc = {f: [] for f in FEET}
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            seen[channel.topic] += 1
            assert message.log_time == message.publish_time
            if hasattr(decoded, "header") and channel.topic.endswith("acceleration"):
                stamp = decoded.header.stamp
                assert stamp.sec * 10**9 + stamp.nanosec == message.log_time
                acc[channel.topic.split("/")[3]].append(decoded.accel.linear.z)
            if channel.topic == "/avc/rotor/joint_state":
                assert list(decoded.name) == ["rotor"]
        assert seen == counts
        for f in FEET:
            np.testing.assert_array_equal(acc[f], data["acc"][f])
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        assert set(meta) == {"rotor_avc", "rotor_avc_counts", "rosbag2"}
        info = load_yaml(meta["rosbag2"]["serialized_metadata"])
        assert info["version"] == 9 and info["storage_identifier"] == "mcap"
        assert info["message_count"] == sum(counts.values())
        by_topic = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
        assert {k: v["message_count"] for k, v in by_topic.items()} == counts
        diag_meta = by_topic["/diagnostics"]["topic_metadata"]
        assert diag_meta["offered_qos_profiles"][0]["durability"] == "transient_local"
        assert diag_meta["type_description_hash"] == msgdefs.type_hash(
            "diagnostic_msgs/msg/DiagnosticArray")


def test_rosbags_anyreader(bag):
    highlevel = pytest.importorskip("rosbags.highlevel")
    path, data, counts = bag
    with highlevel.AnyReader([Path(path)]) as reader:
        assert {c.topic: c.msgcount for c in reader.connections} == counts
        by_topic = {c.topic: c for c in reader.connections}
        qos = by_topic["/diagnostics"].ext.offered_qos_profiles[0]
        assert qos.depth == 100 and qos.durability.name == "TRANSIENT_LOCAL"
        force, obs, n = [], [], 0
        for conn, t_ns, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)       # every message decodes
            n += 1
            if conn.topic == "/avc/foot/NL/actuator_force":
                force.append(msg.wrench.force.z)
                assert msg.header.frame_id == "foot_NL"
            elif conn.topic == "/avc/plant/observables":
                obs.append(msg.data)
                assert msg.layout.dim[0].label.split(",")[0] == "bearing_D_vz"
            elif conn.topic == "/diagnostics":
                assert msg.status[0].name == "plant_simulator"
        assert n == sum(counts.values())
        np.testing.assert_array_equal(force, data["force"]["NL"])
        np.testing.assert_array_equal(np.array(obs), data["obs"])


def test_raw_path_keeps_bytes_and_sequence(tmp_path):
    """write_raw stores the given CDR bytes unchanged (the recorder's path), in any order."""
    path = tmp_path / "raw.mcap"
    payloads = []
    with BagWriter(path, CONFIG) as w:
        w.add_topic("/avc/foot/DR/acceleration")
        codec = w._topics["/avc/foot/DR/acceleration"].codec
        for k in (3, 1, 2, 0):
            data = codec.encode({"header": {"frame_id": "foot_DR"}, "accel": {"linear": {"z": k}}})
            data += b"\x00\x00"                      # rmw may pad; bytes kept as given
            payloads.append((k, data))
            w.write_raw("/avc/foot/DR/acceleration", data, k * 1000, publish_time_ns=k * 1000 + 7,
                        sequence=100 + k)
    with BagReader(path) as r:
        got = list(r.raw_messages())
    assert [m.time_ns for m in got] == [0, 1000, 2000, 3000]
    assert [m.publish_time_ns for m in got] == [7, 1007, 2007, 3007]
    assert [m.sequence for m in got] == [100, 101, 102, 103]
    assert {m.time_ns // 1000: m.data for m in got} == dict(payloads)
