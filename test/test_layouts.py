"""The Foxglove and PlotJuggler layouts ``rotor-avc layouts`` generates from a scenario, and the
shipped ones under layouts/ (generated from the demo's closed-loop scenario, installed):

* the shipped files are current: generated again, byte for byte;
* they parse as each tool reads them (Foxglove: ``configById`` and a mosaic whose leaves are the
  panels; PlotJuggler: tabs of plots, plugins, custom series linked to a parser series); every
  topic is one of the package's and every field path a number of that topic's message type
  (rotor_avc.bag.msgdefs), as each tool spells paths -- Foxglove ``/topic.field.sub[i]``,
  PlotJuggler ``/topic/field/sub[i]`` with its own series for JointState
  (``/topic/<joint>/<position|velocity>``);
* every plotted series reads a number from a run of that scenario recorded in-process
  (rotor_avc.recording): topic present, field present, an array's index within it and its
  label the array's own label for that element (test_layouts_graph.py: the same against a bag
  the ROS graph recorded, with the balancer's and the harmonic controller's arrays);
* what the panels hold, against lists made by hand from the configs: Werner 2021's machine
  publishes ``time_s``, three signals at each of its three actuators (DL, DR, NL; no actuator at
  NR), then the bearing housings D and N in z, y, x (data[10..15]); the harmonic status of
  harmonic_bearings.yaml (harmonic 1, sensors bearing_D_vz, bearing_N_vz, actuators DL, DR,
  NL) is ``time_s, mode, updates, E1 x 2, U1 x 3, fallbacks``."""
import json
import re
import runpy
import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path
from unittest import mock

import pytest
import yaml

from rotor_avc.bag import BagError, BagReader, topics as T
from rotor_avc.bag.msgdefs import PRIMITIVE_TYPE_IDS, known_specs
from rotor_avc.cli import main
from rotor_avc.config import find_config
from rotor_avc.recording import write_run_bag
from rotor_avc.reports.layout_panels import graph_topics
from rotor_avc.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
FOXGLOVE = ROOT / "layouts" / "rotor_avc.foxglove.json"
PLOTJUGGLER = ROOT / "layouts" / "rotor_avc.plotjuggler.xml"
SHIPPED_SCENARIO = "scenario_demo_case3"
REGENERATE = f"rotor-avc layouts {SHIPPED_SCENARIO} --out layouts --name rotor_avc"
SPECS = known_specs()
NUMERIC = set(PRIMITIVE_TYPE_IDS) - {"string", "wstring"}
ARRAY = "std_msgs/msg/Float64MultiArray"
JOINT_STATE = "sensor_msgs/msg/JointState"
#: the joint the package's rotor/joint_state names (rotor_avc.bag.topics.joint_state)
JOINT = T.joint_state([0.0], [0.0], [0.0]).template["name"][0]


def combined_scenario(folder: Path, duration_s: float = 0.3) -> Path:
    """A short run of every kind of block on the Werner 2021 machine: case 3's feedback
    controllers, harmonic control from t = 0 (scenario_harmonic_case3_steady) and the balancer of
    balancer_foot_mount.yaml."""
    balancer = yaml.safe_load(find_config("balancer_foot_mount").read_text())["balancer"]
    path = folder / "combined.yaml"
    path.write_text(yaml.safe_dump({
        "include": str(find_config("scenario_harmonic_case3_steady")), "balancer": balancer,
        "harmonic": {"start_s": 0.0},
        "simulation": {"duration_s": duration_s, "balancer": True}}))
    return path


def short(folder: Path, base: str, duration_s: float) -> Path:
    path = folder / f"{base}_short.yaml"
    path.write_text(yaml.safe_dump({"include": str(find_config(base)),
                                    "simulation": {"duration_s": duration_s}}))
    return path


# -- the paths as each tool spells them ---------------------------------------------------------
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


def custom_series(path: Path) -> dict[str, str]:
    """PlotJuggler custom series of a layout: name -> its linked source series."""
    root = ET.parse(path).getroot()
    return {s.get("name"): s.findtext("linked_source")
            for s in root.iter("snippet") if s.findtext("linked_source")}


@lru_cache(maxsize=None)
def _shipped_aliases() -> dict:
    return custom_series(PLOTJUGGLER)


def _plotjuggler_series(name: str, aliases: dict | None = None) -> tuple[str, str, list[str]]:
    """(topic, its type, the rest of the series name) of a PlotJuggler curve; a custom series
    of ``aliases`` (default: the shipped layout's) by its linked source."""
    name = (_shipped_aliases() if aliases is None else aliases).get(name, name)
    parts = name.split("/")
    for cut in range(len(parts), 1, -1):
        topic = "/".join(parts[:cut])
        try:
            return topic, T.message_type(topic), parts[cut:]
        except BagError:
            continue
    raise AssertionError(f"curve {name!r} names no topic of the package")


def foxglove_series(path: Path) -> list[tuple[str, list[str], str]]:
    """``(topic, field parts, label)`` of every plotted path of a Foxglove layout."""
    panels = json.loads(path.read_text())["configById"]
    out = []
    for key, config in panels.items():
        for p in config.get("paths", []) if key.startswith("Plot!") else []:
            topic, *parts = p["value"].split(".")
            out.append((topic, parts, p["label"]))
    return out


def plotjuggler_series(path: Path) -> list[tuple[str, list[str], str]]:
    """``(topic, field parts, label)`` of every curve of a PlotJuggler layout: a JointState's
    ``<joint>/<field>`` as ``<field>[<the joint's index>]``; a custom series' label the last
    part of its name."""
    aliases = custom_series(path)
    out = []
    for curve in ET.parse(path).getroot().iter("curve"):
        name = curve.get("name")
        topic, msg_type, rest = _plotjuggler_series(name, aliases)
        if msg_type == JOINT_STATE:
            assert rest[0] == JOINT and rest[1:] in (["position"], ["velocity"]), name
            rest = [f"{rest[1]}[0]"]
        out.append((topic, rest, name.rsplit("/", 1)[1] if name in aliases else ""))
    return out


def _value(message, parts: list[str]):
    for part in parts:
        name, index = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", part).groups()
        message = message[name]
        if index is not None:
            assert int(index) < len(message), f"{part}: the message has {len(message)}"
            message = message[int(index)]
    return message


def assert_series_in_bag(series, bag: Path) -> set[str]:
    """Every ``(topic, parts, label)`` reads a number from the first message of its topic in
    ``bag``, an array element's label being the array's own; the topics."""
    with BagReader(bag) as reader:
        present = set(reader.topics)
        first = {}
        for topic, parts, label in series:
            assert topic in present, f"{topic} is not in {bag.name}: {sorted(present)}"
            if topic not in first:
                first[topic] = next(reader.messages([topic])).data
            message = first[topic]
            assert isinstance(float(_value(message, parts)), float), (topic, parts)
            if T.message_type(topic) == ARRAY:
                index = int(re.fullmatch(r"data\[(\d+)\]", parts[0]).group(1))
                assert T.labels_of(message)[index] == label, (topic, index, label)
    return {topic for topic, _, _ in series}


# -- fixtures --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """name -> (scenario config, Foxglove file, PlotJuggler file) of layouts generated here."""
    tmp = tmp_path_factory.mktemp("layouts")
    configs = {"combined": combined_scenario(tmp), "active_bearing": "scenario_active_bearing"}
    out = {}
    for name, config in configs.items():
        assert main(["layouts", str(config), "--out", str(tmp), "--name", name]) == 0
        out[name] = (config, tmp / f"{name}.foxglove.json", tmp / f"{name}.plotjuggler.xml")
    return out


def _layout_files(generated):
    return [(FOXGLOVE, PLOTJUGGLER)] + [(f, p) for _, f, p in generated.values()]


# -- tests -----------------------------------------------------------------------------------------
def test_shipped_layouts_are_generated_from_the_demo_scenario(tmp_path, capsys):
    assert main(["layouts", SHIPPED_SCENARIO, "--out", str(tmp_path), "--name", "rotor_avc"]) == 0
    printed = capsys.readouterr().out
    assert "bearing-housing velocity (m/s): bearing_D_vz" in printed
    for shipped in (FOXGLOVE, PLOTJUGGLER):
        assert (tmp_path / shipped.name).read_text() == shipped.read_text(), (
            f"layouts/{shipped.name} is not what the generator makes; regenerate: {REGENERATE}")


def test_layouts_are_installed(monkeypatch):
    captured = {}
    monkeypatch.chdir(ROOT)
    with mock.patch("setuptools.setup", lambda **kw: captured.update(kw)):
        runpy.run_path(str(ROOT / "setup.py"))
    assert set(dict(captured["data_files"])["share/rotor_avc/layouts"]) == {
        "layouts/rotor_avc.foxglove.json", "layouts/rotor_avc.plotjuggler.xml"}


def test_foxglove_layouts_have_foxgloves_shape(generated):
    for foxglove, _ in _layout_files(generated):
        layout = json.loads(foxglove.read_text())
        panels = layout["configById"]
        assert sorted(_mosaic_leaves(layout["layout"])) == sorted(panels)
        assert {key.split("!")[0] for key in panels} == {"Plot", "RawMessages",
                                                         "DiagnosticSummary"}
        for key, config in panels.items():
            if key.startswith("Plot!"):
                assert config["paths"] and all(
                    set(p) >= {"value", "enabled", "timestampMethod", "label"}
                    and p["label"] for p in config["paths"]), key
        for path in _foxglove_paths(panels):
            topic, *parts = path.split(".")
            msg_type = topic_type(topic)
            if parts:
                assert field_type(msg_type, parts) in NUMERIC, path


def test_plotjuggler_layouts_have_plotjugglers_shape(generated):
    for _, plotjuggler in _layout_files(generated):
        root = ET.parse(plotjuggler).getroot()
        assert root.tag == "root" and root.find("tabbed_widget") is not None
        assert root.find("use_relative_time_offset").get("enabled") == "1"
        assert {p.get("ID") for p in root.iter("plugin")} >= {"DataLoad MCAP",
                                                              "ROS2 Topic Subscriber"}
        curves = [c.get("name") for c in root.iter("curve")]
        assert curves and all(curves) and len(set(curves)) == len(curves)
        aliases = custom_series(plotjuggler)
        for snippet in root.iter("snippet"):
            assert snippet.findtext("function") == "return value"
            assert snippet.get("name") in curves and snippet.get("language").lower() == "lua"
        for name in curves:
            topic, msg_type, rest = _plotjuggler_series(name, aliases)
            if msg_type != JOINT_STATE:
                assert field_type(msg_type, rest) in NUMERIC, name
            assert (name in aliases) == (msg_type == ARRAY), name


def test_the_demo_layout_holds_the_machines_signals():
    """The shipped layouts against the hand-made list (module docstring)."""
    housings = [f"bearing_{b}_v{a}" for b in "DN" for a in "zyx"]
    wanted = {("/avc/plant/observables", (f"data[{10 + i}]",), name)
              for i, name in enumerate(housings)}
    wanted |= {(f"/avc/foot/{f}/actuator_force", ("wrench", "force", "z"), f)
               for f in ("DL", "DR", "NL")}
    wanted.add(("/avc/rotor/joint_state", ("velocity[0]",), "speed"))
    got = {(t, tuple(p), label) for t, p, label in foxglove_series(FOXGLOVE)}
    assert wanted <= got
    assert {t for t, _, _ in got} == {t for t, _, _ in wanted} | {
        f"/avc/foot/{f}/acceleration" for f in ("DL", "DR", "NL")}
    pj = {(t, tuple(p), label) for t, p, label in plotjuggler_series(PLOTJUGGLER)}
    assert {(t, p, label) for t, p, label in wanted if t.endswith("observables")} <= pj
    assert not any("NR" in t or "balancer" in t or "harmonic" in t for t, _, _ in got | pj)


def test_the_combined_layout_names_the_blocks_arrays(generated):
    """Balancer and harmonic panels of the combined scenario against the hand-made lists."""
    config, foxglove, plotjuggler = generated["combined"]
    status = ["mode", "updates", "E1_bearing_D_vz", "E1_bearing_N_vz", "U1_DL", "U1_DR",
              "U1_NL", "fallbacks"]
    wanted = {("/avc/harmonic/status", (f"data[{1 + i}]",), name)
              for i, name in enumerate(status) if name != "updates"}
    wanted |= {("/avc/harmonic/forces", (f"data[{1 + i}]",), f"{a}_fz")
               for i, a in enumerate(("DL", "DR", "NL"))}
    wanted |= {(f"/avc/balancer/{part}", (f"data[{1 + i}]",), name) for part in
               ("estimate", "command")
               for i, name in enumerate(("static_re", "static_im", "moment_re", "moment_im"))}
    for got in (foxglove_series(foxglove), plotjuggler_series(plotjuggler)):
        got = {(t, tuple(p), label) for t, p, label in got}
        assert wanted <= got
        assert {t for t, _, _ in got} <= set(graph_topics(load_scenario(config)))


def test_layouts_read_a_run_of_their_scenario_recorded_in_process(tmp_path):
    """The shipped layouts against an in-process run of the demo's scenario: every series reads
    a number there; the run's topics are the graph's (the graph adds /diagnostics)."""
    scenario = load_scenario(short(tmp_path, SHIPPED_SCENARIO, 0.02))
    bag = write_run_bag(tmp_path / "demo.mcap", scenario, scenario.run())
    topics = assert_series_in_bag(foxglove_series(FOXGLOVE), bag)
    assert assert_series_in_bag(plotjuggler_series(PLOTJUGGLER), bag) <= topics
    with BagReader(bag) as reader:
        assert set(reader.topics) | {"/diagnostics"} == set(graph_topics(scenario))
    whole = [p for p in _foxglove_paths(json.loads(FOXGLOVE.read_text())) if "." not in p]
    assert set(whole) == {"/avc/plant/observables", "/diagnostics"}


@pytest.mark.parametrize("bad", ["/avc/foot/DL/acceleration.accel.linear.w",
                                 "/avc/plant/observables.data", "/avc/rotor/speed"])
def test_path_check_catches_mistakes(bad):
    topic, *parts = bad.split(".")
    with pytest.raises(AssertionError):
        field_type(topic_type(topic), parts) if parts else topic_type(topic)


def test_a_wrong_label_or_index_is_caught(tmp_path):
    scenario = load_scenario(short(tmp_path, SHIPPED_SCENARIO, 0.002))
    bag = write_run_bag(tmp_path / "demo.mcap", scenario, scenario.run())
    assert_series_in_bag([("/avc/plant/observables", ["data[10]"], "bearing_D_vz")], bag)
    for wrong in (["data[11]"], ["data[28]"]):
        with pytest.raises(AssertionError):
            assert_series_in_bag([("/avc/plant/observables", wrong, "bearing_D_vz")], bag)


def test_bad_file_name_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["layouts", SHIPPED_SCENARIO, "--out", str(tmp_path), "--name", "../x"])
    assert exc.value.code == 2 and "--name" in capsys.readouterr().err
