"""`rotor-avc bag check` on the bags the project writes and on an independent writer's.

Every kind of bag the package writes passes every check: `rotor-avc simulate`'s bag (the same
writer path the ROS graph's recording test also checks), the recorder's raw path
(``BagWriter.write_raw``), a recovered bag, and a rosbag2 directory written by the ``rosbags``
library (split into two files, its own ``metadata.yaml``). Each pitfall, planted one at a time,
is reported on its own line with exit status 4.
"""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from rotor_avc.bag import BagReader, BagWriter, recover_bag
from rotor_avc.bag.cdr import CdrCodec
from rotor_avc.bag.check import check_bag
from rotor_avc.bag.mcap_writer import McapSink
from rotor_avc.bag.metadata import DEFAULT_QOS, qos_yaml
from rotor_avc.bag.msgdefs import full_text, known_specs, type_hash
from rotor_avc.cli import main
from rotor_avc.config import find_config

ACCEL = "/avc/foot/DL/acceleration"


def problems(path) -> dict[str, str]:
    return {line.name: line.detail for line in check_bag(path) if not line.ok}


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("check")
    scenario = folder / "short.yaml"
    scenario.write_text(yaml.safe_dump({"include": str(find_config("scenario_case3_steady")),
                                        "simulation": {"duration_s": 0.2}}))
    bag = folder / "sim.mcap"
    assert main(["simulate", str(scenario), "--out", str(bag)]) == 0
    return bag


def test_simulated_and_recovered_bags_pass(simulated, tmp_path, capsys):
    assert main(["bag", "check", str(simulated)]) == 0
    out = capsys.readouterr().out
    assert "PROBLEM" not in out and "samples:" in out and "integrity:" in out
    recovered = recover_bag(simulated, tmp_path / "recovered.mcap")
    assert recovered.lost == {} and problems(recovered.path) == {}


def test_the_recorders_raw_path_passes(tmp_path):
    path = tmp_path / "raw.mcap"
    with BagWriter(path, {"machine": {"model": "x"}}) as w:
        w.add_topic(ACCEL)
        for k in range(500):
            w.write(ACCEL, {"header": {"stamp": {"sec": 0, "nanosec": k * 1000}},
                            "accel": {"linear": {"z": k}}}, k * 1000)
    assert problems(path) == {}


def planted(tmp_path, *, encoding="cdr", schema_text=None, qos=None):
    """A bag of one topic with one pitfall planted (written with the low-level sink)."""
    path = tmp_path / "planted.mcap"
    with open(path, "wb") as f:
        sink = McapSink(f, "ros2", "test", "zstd")
        sid = sink.add_schema("geometry_msgs/msg/AccelStamped", "ros2msg",
                              (schema_text or full_text("geometry_msgs/msg/AccelStamped")).encode())
        cid = sink.add_channel(ACCEL, encoding, sid, {"offered_qos_profiles": qos_yaml(
            [qos or DEFAULT_QOS])})
        data = CdrCodec("geometry_msgs/msg/AccelStamped", known_specs()).encode({})
        for k in range(50):
            sink.add_message(cid, k * 1000, k * 1000, k, data)
        sink.finish()
    return path


@pytest.mark.parametrize("pitfall, kwargs", [
    ("message encoding", dict(encoding="json")),
    ("schemas", dict(schema_text="std_msgs/Header header\nAccel accel\n")),   # no dependencies
    ("offered_qos_profiles", dict(qos={**DEFAULT_QOS, "depth": -1})),
    ("offered_qos_profiles", dict(qos={**DEFAULT_QOS, "history": "keep_latest"})),
    ("offered_qos_profiles", dict(qos={**DEFAULT_QOS, "deadline": 5})),
])
def test_each_pitfall_is_one_problem_line(tmp_path, pitfall, kwargs):
    found = problems(planted(tmp_path, **kwargs))
    assert pitfall in found, found
    assert main(["bag", "check", str(tmp_path / "planted.mcap")]) == 4


def test_a_clean_planted_bag_passes(tmp_path):
    found = problems(planted(tmp_path))
    assert set(found) <= {"metadata.yaml"}, found      # a bare sink writes no rosbag2 record


def rosbags_directory(path: Path, n: int = 400) -> Path:
    """A rosbag2 directory by the `rosbags` writer (MCAP storage), split into two files as
    `ros2 bag record --max-bag-size` leaves it: each half written as its own bag, then one
    metadata.yaml listing both (rosbag2's form: files, per-topic counts, QoS strings)."""
    rosbag2 = pytest.importorskip("rosbags.rosbag2")
    typesys = pytest.importorskip("rosbags.typesys")
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    Vector3 = store.types["geometry_msgs/msg/Vector3"]
    q = pytest.importorskip("rosbags.interfaces")
    forever = q.QosTime(sec=9223372036, nsec=854775807)
    qos = q.Qos(q.QosHistory.KEEP_LAST, 10, q.QosReliability.RELIABLE, q.QosDurability.VOLATILE,
                forever, forever, q.QosLiveliness.AUTOMATIC, forever, False)
    parts, infos = [], []
    for half in range(2):
        part = path.parent / f"part{half}"
        with rosbag2.Writer(part, version=9, storage_plugin=rosbag2.StoragePlugin.MCAP) as w:
            conn = w.add_connection("/imu/vector", "geometry_msgs/msg/Vector3", typestore=store,
                                    offered_qos_profiles=[qos])
            for k in range(half * n // 2, (half + 1) * n // 2):
                data = store.serialize_cdr(Vector3(x=float(k), y=0.0, z=1.0),
                                           "geometry_msgs/msg/Vector3")
                w.write(conn, 1_000_000_000 + k * 1_000_000, data)
        parts.append(part)
        infos.append(yaml.safe_load((part / "metadata.yaml").read_text()))
    path.mkdir()
    files, total = [], 0
    for half, (part, info) in enumerate(zip(parts, infos)):
        body = info["rosbag2_bagfile_information"]
        name = f"bag_{half}.mcap"
        shutil.move(next(part.glob("*.mcap")), path / name)
        files.append({**body["files"][0], "path": name})
        total += body["message_count"]
    body = infos[0]["rosbag2_bagfile_information"]
    body["relative_file_paths"] = [f["path"] for f in files]
    body["files"] = files
    body["message_count"] = total
    body["topics_with_message_count"][0]["message_count"] = total
    first, last = files[0], files[-1]
    body["starting_time"] = first["starting_time"]
    body["duration"] = {"nanoseconds": last["starting_time"]["nanoseconds_since_epoch"]
                        + last["duration"]["nanoseconds"]
                        - first["starting_time"]["nanoseconds_since_epoch"]}
    (path / "metadata.yaml").write_text(yaml.safe_dump(infos[0]))
    return path


def test_an_independent_writers_directory_passes_and_a_wrong_metadata_yaml_does_not(tmp_path):
    bag = rosbags_directory(tmp_path / "rec")
    assert problems(bag) == {}
    assert main(["bag", "info", str(bag)]) == 0                 # one block per file
    info = yaml.safe_load((bag / "metadata.yaml").read_text())
    body = info["rosbag2_bagfile_information"]
    body["topics_with_message_count"][0]["message_count"] += 1
    body["files"][1]["message_count"] -= 1
    (bag / "metadata.yaml").write_text(yaml.safe_dump(info))
    found = problems(bag)
    assert set(found) == {"metadata.yaml"}, found
    assert "/imu/vector: message_count is 401, the data holds 400" in found["metadata.yaml"]
    assert "files[1] (bag_1.mcap): message_count is 199, the file has 200" \
        in found["metadata.yaml"]
    (bag / "bag_1.mcap").unlink()
    assert "files" in problems(bag)
    assert main(["bag", "check", str(bag)]) == 4


def test_info_lists_topics_counts_and_rates(simulated, capsys):
    """From the summary, and with --integrity from the data: the same lines but the last."""
    assert main(["bag", "info", str(simulated)]) == 0
    out = capsys.readouterr().out
    assert main(["bag", "info", "--integrity", str(simulated)]) == 0
    checked = capsys.readouterr().out
    assert "profile 'ros2'" in out and "integrity: ok" in checked
    assert out.splitlines()[:-1] == checked.splitlines()[:-1]
    rate = [line for line in out.splitlines() if "/rotor/joint_state" in line][0]
    with BagReader(simulated) as r:
        rate_hz = r.config["discretisation"]["sample_rate_hz"]
    assert float(rate.split()[-2]) == pytest.approx(rate_hz, rel=1e-3)


def test_the_mcap_packages_own_writer_passes(tmp_path):
    """Another layout of the same format: the `mcap` package's Writer (its own chunking,
    empty summary-offset groups, no data-section CRC, no rosbag2 record)."""
    writer = pytest.importorskip("mcap.writer")
    codec = CdrCodec("geometry_msgs/msg/Vector3", known_specs())
    path = tmp_path / "mcap_writer.mcap"
    with open(path, "wb") as f:
        w = writer.Writer(f)
        w.start(profile="ros2", library="mcap-python")
        sid = w.register_schema("geometry_msgs/msg/Vector3", "ros2msg",
                                full_text("geometry_msgs/msg/Vector3").encode())
        cid = w.register_channel("/v", "cdr", sid, {
            "offered_qos_profiles": qos_yaml([DEFAULT_QOS]),
            "topic_type_hash": type_hash("geometry_msgs/msg/Vector3")})
        for k in range(20000):
            w.add_message(cid, k * 1000, codec.encode({"x": float(k)}), k * 1000, k)
        w.finish()
    assert set(problems(path)) == {"metadata.yaml"}
    with BagReader(path, integrity=True) as r:
        assert r.integrity.message_count == 20000 and r.integrity.chunks >= 2
