"""The bags the project writes decode with Foxglove's own libraries -- the code Foxglove uses to
open a file: npm ``@mcap/core`` (indexed reader, CRCs checked), ``@foxglove/rosmsg`` (the schema
text of the file, parsed as ROS 2) and ``@foxglove/rosmsg2-serialization`` (CDR), run by
test/js/decode.mjs under node. Every message of every channel is decoded there, and the topics,
types, counts, log times and every decoded value equal what rotor_avc's BagReader reads; no
message leaves bytes the schema does not account for. Bags: the committed reference bag, a fresh
``rotor-avc simulate`` bag with the balancer, a bag recorded by the ROS graph (recorder node,
diagnostics) and a recovered truncated recording. The layouts' paths (layouts/) read numbers
from these decoded messages. Skipped where node or npm is missing; the libraries are installed
once with ``npm ci`` into test/js/node_modules (package-lock.json)."""
import json
import math
import re
import shutil
import xml.etree.ElementTree as ET
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml

from test_layouts import FOXGLOVE, PLOTJUGGLER, _foxglove_paths, _plotjuggler_series

from rotor_avc.bag import BagReader, recover_bag
from rotor_avc.cli import main
from rotor_avc.config import find_config

ROOT = Path(__file__).resolve().parents[1]
JS = ROOT / "test" / "js"
NPM_CI_TIMEOUT_S = 300
DECODE_TIMEOUT_S = 300


def _npm_ci() -> None:
    """``npm ci`` into test/js/node_modules, unless it already holds this lock file's packages."""
    installed = JS / "node_modules" / ".package-lock.json"
    lock = JS / "package-lock.json"
    if installed.is_file() and installed.stat().st_mtime >= lock.stat().st_mtime:
        return
    try:
        r = subprocess.run(["npm", "ci", "--no-audit", "--no-fund", "--prefer-offline"], cwd=JS,
                           capture_output=True, text=True, timeout=NPM_CI_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        pytest.skip(f"npm ci did not finish within {NPM_CI_TIMEOUT_S} s")
    if r.returncode != 0:
        pytest.skip("npm ci could not install Foxglove's libraries: " + r.stderr.strip()[-400:])


@pytest.fixture(scope="module")
def foxglove():
    """decode(paths) -> what decode.mjs prints, per bag."""
    if shutil.which("node") is None or shutil.which("npm") is None:
        pytest.skip("node and npm are not installed")
    _npm_ci()

    def decode(paths):
        r = subprocess.run(["node", "decode.mjs", *map(str, paths)], cwd=JS, capture_output=True,
                           text=True, timeout=DECODE_TIMEOUT_S)
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout)
    return decode


def _short(tmp_path: Path, base: str, **simulation) -> str:
    path = tmp_path / f"{base}_short.yaml"
    path.write_text(yaml.safe_dump({"include": str(find_config(base)),
                                    "simulation": simulation}))
    return str(path)


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    """name -> path of the bags to decode."""
    tmp = tmp_path_factory.mktemp("foxglove")
    balance = _short(tmp, "scenario_balance_runup",
                     speed={"type": "ramp", "start_hz": 5.0, "stop_hz": 8.0, "duration_s": 0.3})
    out = {"reference": ROOT / "bags" / "reference" / "case3_stepped.mcap",
           "simulate": tmp / "simulate.mcap"}
    assert main(["simulate", balance, "--out", str(out["simulate"])]) == 0
    raw = out["simulate"].read_bytes()
    (tmp / "cut.mcap").write_bytes(raw[:int(len(raw) * 0.6)])
    out["recovered"] = recover_bag(tmp / "cut.mcap").path
    return out


@pytest.fixture(scope="module")
def decoded(foxglove, bags) -> dict:
    return foxglove(bags.values())


@pytest.fixture(scope="module")
def graph_bag(tmp_path_factory):
    """A bag written by the recorder node in a (composed, short) graph run with the balancer."""
    pytest.importorskip("rclpy")
    from rotor_avc.nodes.graph import run_graph
    tmp = tmp_path_factory.mktemp("foxglove_graph")
    sc = _short(tmp, "scenario_balance_runup",
                speed={"type": "ramp", "start_hz": 5.0, "stop_hz": 8.0, "duration_s": 0.2})
    return run_graph(sc, tmp / "graph.mcap", tmp / "logs", layout="composed", timeout_s=600).bag


def _plain(value):
    """A BagReader value as decode.mjs prints it (lists; non-finite floats as strings)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value).replace("inf", "Infinity").replace("nan", "NaN")
    return value


def assert_same_as_bag_reader(path: Path, decoded: dict) -> dict[str, int]:
    """Foxglove's decode of ``path`` equals BagReader's, message by message; per-topic counts."""
    assert decoded["profile"] == "ros2"
    topics = decoded["topics"]
    with BagReader(path) as reader:
        assert sorted(topics) == sorted(reader.topics)
        ours: dict[str, list] = {t: [] for t in reader.topics}
        for msg in reader.messages():
            ours[msg.topic].append([msg.time_ns, _plain(msg.data)])
        for topic, info in reader.topics.items():
            theirs = topics[topic]
            assert (theirs["type"], theirs["encoding"], theirs["schema_encoding"]) == (
                info.msg_type, "cdr", "ros2msg")
            assert theirs["count"] == info.count == len(ours[topic]) > 0, topic
            assert theirs["trailing"] == 0, f"{topic}: bytes after the message"
            got = [[int(t), m] for t, m in theirs["messages"]]
            assert got == ours[topic], f"{topic}: decoded values differ"
    return {t: topics[t]["count"] for t in topics}


def test_simulated_reference_and_recovered_bags_decode_alike(decoded, bags):
    counts = {name: assert_same_as_bag_reader(path, decoded[str(path)])
              for name, path in bags.items()}
    assert "/avc/balancer/command" in counts["simulate"]
    assert 0 < counts["recovered"]["/clock"] < counts["simulate"]["/clock"]
    for name, per_topic in counts.items():
        print(name, per_topic)


def test_graph_recorded_bag_decodes_alike(foxglove, graph_bag):
    decoded = foxglove([graph_bag])[str(graph_bag)]
    counts = assert_same_as_bag_reader(graph_bag, decoded)
    assert counts["/diagnostics"] > 0 and counts["/avc/balancer/estimate"] > 0
    statuses = {s["name"] for _, m in decoded["topics"]["/diagnostics"]["messages"]
                for s in m["status"]}
    assert "plant_simulator: loop" in statuses
    print("graph", counts)
    # PlotJuggler's series of /diagnostics (hardware id / status name / key) and of JointState
    # (joint name / position, velocity) are in the recorded messages, the values numbers
    values = {(s["hardware_id"], s["name"], kv["key"]): kv["value"]
              for _, m in decoded["topics"]["/diagnostics"]["messages"] for s in m["status"]
              for kv in s["values"]}
    joints = {n for _, m in decoded["topics"]["/avc/rotor/joint_state"]["messages"]
              for n in m["name"]}
    for curve in ET.parse(PLOTJUGGLER).getroot().iter("curve"):
        topic, msg_type, rest = _plotjuggler_series(curve.get("name"))
        if msg_type == "diagnostic_msgs/msg/DiagnosticArray":
            float(values[rest[0], "/".join(rest[1:-1]), rest[-1]])
        elif msg_type == "sensor_msgs/msg/JointState":
            assert rest[0] in joints


def _value(message, parts: list[str]):
    for part in parts:
        name, index = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", part).groups()
        message = message[name] if index is None else message[name][int(index)]
    return message


def test_layout_paths_give_numbers_in_the_decoded_bags(decoded, bags):
    """Every Foxglove plot path and every PlotJuggler curve of a plain field whose topic is in
    the reference or the simulate bag reads a number from each of its messages there."""
    topics = {}
    for name in ("reference", "simulate"):
        topics.update(decoded[str(bags[name])]["topics"])
    fields = [(path.split(".")[0], path.split(".")[1:])
              for path in _foxglove_paths(json.loads(FOXGLOVE.read_text())) if "." in path]
    for curve in ET.parse(PLOTJUGGLER).getroot().iter("curve"):
        topic, msg_type, rest = _plotjuggler_series(curve.get("name"))
        if msg_type not in ("sensor_msgs/msg/JointState", "diagnostic_msgs/msg/DiagnosticArray"):
            fields.append((topic, rest))
    checked = 0
    for topic, parts in fields:
        if topic in topics:
            values = [_value(m, parts) for _, m in topics[topic]["messages"]]
            assert all(isinstance(v, (int, float)) for v in values), (topic, parts)
            checked += 1
    assert checked >= 10
