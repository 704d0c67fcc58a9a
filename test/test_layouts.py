"""The Foxglove and PlotJuggler layouts under layouts/: they parse, they are installed, and every
topic they name is one the graph publishes (rotor_avc.bag.topics), every field path exists in
that topic's message type (rotor_avc.bag.msgdefs) -- as each tool spells paths: Foxglove
``/topic.field.sub[i]``, PlotJuggler ``/topic/field/sub[i]`` with its own series for JointState
(``/topic/<joint>/<position|velocity>``) and DiagnosticArray
(``/topic/<hardware_id>/<status>/<key>``)."""
import json
import re
import runpy
import xml.etree.ElementTree as ET
from pathlib import Path
from unittest import mock

import pytest

from rotor_avc.bag import BagError, topics as T
from rotor_avc.bag.msgdefs import PRIMITIVE_TYPE_IDS, known_specs
from rotor_avc.nodes.timing import LoopTiming

ROOT = Path(__file__).resolve().parents[1]
FOXGLOVE = ROOT / "layouts" / "rotor_avc.foxglove.json"
PLOTJUGGLER = ROOT / "layouts" / "rotor_avc.plotjuggler.xml"
SPECS = known_specs()
NUMERIC = set(PRIMITIVE_TYPE_IDS) - {"string", "wstring"}
#: what the nodes put in /diagnostics (rotor_avc.nodes.messages.diagnostics, plant_simulator)
HARDWARE_ID = "rotor_avc"
PLANT_LOOP_KEYS = {"sample", "samples_total", "resends"}
#: the joint the package's rotor/joint_state names (rotor_avc.bag.topics.joint_state)
JOINT = T.joint_state([0.0], [0.0], [0.0]).template["name"][0]


def field_type(msg_type: str, parts: list[str]) -> str:
    """The primitive type at ``parts`` (``accel``, ``linear``, ``z`` / ``data[3]``) in
    ``msg_type``; AssertionError naming the part that does not exist."""
    spec = SPECS[msg_type]
    for i, part in enumerate(parts):
        name, index = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", part).groups()
        fields = {f.name: f for f in spec.fields}
        assert name in fields, f"{msg_type} has no field {name!r}"
        field = fields[name]
        assert (index is not None) == (field.kind != "scalar"), f"{part}: index a sequence only"
        if index is not None:
            assert int(index) < T.MAX_ARRAY_ELEMENTS
        if field.type in SPECS:
            spec = SPECS[field.type]
        else:
            assert i == len(parts) - 1, f"{part} is a {field.type}, not a message"
            return field.type
    raise AssertionError(f"{'.'.join(parts)} is a message, not a value")


def topic_type(topic: str) -> str:
    try:
        return T.message_type(topic)
    except BagError as exc:
        raise AssertionError(str(exc)) from None


def installed(monkeypatch) -> list[str]:
    captured = {}
    monkeypatch.chdir(ROOT)
    with mock.patch("setuptools.setup", lambda **kw: captured.update(kw)):
        runpy.run_path(str(ROOT / "setup.py"))
    return dict(captured["data_files"])["share/rotor_avc/layouts"]


def test_layouts_are_installed(monkeypatch):
    assert set(installed(monkeypatch)) == {"layouts/rotor_avc.foxglove.json",
                                           "layouts/rotor_avc.plotjuggler.xml"}


def _foxglove_paths(node):
    if isinstance(node, dict):
        for key, value in node.items():
            if key in ("value", "topicPath", "topicToRender") and isinstance(value, str):
                yield value
            else:
                yield from _foxglove_paths(value)
    elif isinstance(node, list):
        for item in node:
            yield from _foxglove_paths(item)


def _mosaic_leaves(node):
    if isinstance(node, str):
        return [node]
    assert set(node) >= {"direction", "first", "second"}
    return _mosaic_leaves(node["first"]) + _mosaic_leaves(node["second"])


def test_foxglove_layout():
    layout = json.loads(FOXGLOVE.read_text())
    panels = layout["configById"]
    assert sorted(_mosaic_leaves(layout["layout"])) == sorted(panels)
    paths = list(_foxglove_paths(panels))
    topics = set()
    for path in paths:
        topic, *parts = path.split(".")
        topics.add(topic)
        msg_type = topic_type(topic)
        if parts:
            assert field_type(msg_type, parts) in NUMERIC, path
    feet = {f"/avc/foot/{f}/{kind}" for f in T.FOOT_IDS for kind in ("acceleration",
                                                                     "actuator_force")}
    assert feet | {"/avc/rotor/joint_state", "/avc/plant/observables", "/diagnostics",
                   "/avc/balancer/estimate", "/avc/harmonic/status"} <= topics
    shaft = {"/avc/rotor/joint_state.velocity[0]", "/avc/rotor/joint_state.position[0]"}
    assert shaft <= set(paths)
    kinds = {key.split("!")[0] for key in panels}
    assert {"Plot", "RawMessages", "DiagnosticSummary"} <= kinds


def _plotjuggler_series(name: str) -> tuple[str, str, list[str]]:
    """(topic, its type, the rest of the series name) of a PlotJuggler curve."""
    parts = name.split("/")
    for cut in range(len(parts), 1, -1):
        topic = "/".join(parts[:cut])
        try:
            return topic, T.message_type(topic), parts[cut:]
        except BagError:
            continue
    raise AssertionError(f"curve {name!r} names no topic of the package")


def test_plotjuggler_layout():
    root = ET.parse(PLOTJUGGLER).getroot()
    assert root.tag == "root" and root.find("tabbed_widget") is not None
    curves = [c.get("name") for c in root.iter("curve")]
    assert curves and all(curves)
    timing = LoopTiming(None)
    timing.start()
    timing.stop()
    loop_keys = PLANT_LOOP_KEYS | set(timing.summary())
    topics = set()
    for name in curves:
        topic, msg_type, rest = _plotjuggler_series(name)
        topics.add(topic)
        if msg_type == "sensor_msgs/msg/JointState":
            assert rest[0] == JOINT and rest[1:] in (["position"], ["velocity"]), name
        elif msg_type == "diagnostic_msgs/msg/DiagnosticArray":
            hardware, status, key = rest[0], "/".join(rest[1:-1]), rest[-1]
            assert hardware == HARDWARE_ID and status == "plant_simulator: loop", name
            assert key in loop_keys, name
        else:
            assert field_type(msg_type, rest) in NUMERIC, name
    feet = {f"/avc/foot/{f}/{kind}" for f in T.FOOT_IDS for kind in ("acceleration",
                                                                     "actuator_force")}
    assert feet | {"/avc/rotor/joint_state", "/avc/plant/observables", "/diagnostics"} <= topics
    assert {p.get("ID") for p in root.iter("plugin")} >= {"DataLoad MCAP"}


@pytest.mark.parametrize("bad", ["/avc/foot/DL/acceleration.accel.linear.w",
                                 "/avc/plant/observables.data", "/avc/rotor/speed"])
def test_path_check_catches_mistakes(bad):
    topic, *parts = bad.split(".")
    with pytest.raises(AssertionError):
        field_type(topic_type(topic), parts) if parts else topic_type(topic)
