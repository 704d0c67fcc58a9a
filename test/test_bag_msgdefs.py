"""Message definitions: vendored text, rosbag2 full text and RIHS01 hashes against independent
sources -- the installed ROS 2 Jazzy interface packages (.msg and type-description .json files)
and the `rosbags` type store."""
import json
import os
import re
import sys
from pathlib import Path

import pytest

from rotor_avc.bag import msgdefs
from rotor_avc.bag.msgdefs import MsgDefError, full_text, parse_msg, parse_schema, type_hash

PREFIXES = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
SHARE = next((Path(p) / "share" for p in PREFIXES + [sys.prefix]
              if (Path(p) / "share" / "sensor_msgs" / "msg").is_dir()), Path(sys.prefix) / "share")
needs_share = pytest.mark.skipif(not (SHARE / "sensor_msgs" / "msg").is_dir(),
                                 reason="ROS 2 interface packages (share/<pkg>/msg) not installed")


def _installed_msg(name: str) -> str:
    pkg, _, typ = name.split("/")
    return (SHARE / pkg / "msg" / f"{typ}.msg").read_text()


def _installed_hash(name: str) -> str:
    pkg, _, typ = name.split("/")
    data = json.loads((SHARE / pkg / "msg" / f"{typ}.json").read_text())
    return next(h["hash_string"] for h in data["type_hashes"] if h["type_name"] == name)


def _installed_specs(root: str) -> dict:
    """Specs of a type and its dependencies, parsed from the installed .msg files."""
    specs, todo = {}, [root]
    while todo:
        name = todo.pop()
        if name not in specs:
            specs[name] = parse_msg(name, _installed_msg(name))
            todo.extend(f.type for f in specs[name].fields if f.nested)
    return specs


@needs_share
@pytest.mark.parametrize("name", sorted(msgdefs.DEFINITIONS))
def test_vendored_text_is_the_installed_msg_without_comments(name):
    def norm(text):
        lines = (re.sub(r"\s+", " ", ln.split("#", 1)[0]).strip() for ln in text.splitlines())
        return [ln for ln in lines if ln]
    assert norm(msgdefs.DEFINITIONS[name]) == norm(_installed_msg(name))


@needs_share
@pytest.mark.parametrize("name", sorted(msgdefs.DEFINITIONS))
def test_type_hash_matches_installed_type_description(name):
    assert type_hash(name) == _installed_hash(name)


@needs_share
@pytest.mark.parametrize("name", [
    "sensor_msgs/msg/Imu",                       # fixed arrays float64[9]
    "sensor_msgs/msg/CameraInfo",                # fixed arrays of several sizes
    "shape_msgs/msg/SolidPrimitive",             # constants, bounded float64[<=3]
    "rcl_interfaces/msg/ParameterDescriptor",    # bounded nested sequences
    "rmw_dds_common/msg/NodeEntitiesInfo",       # bounded strings
    "visualization_msgs/msg/MarkerArray",        # deep nesting
    "std_msgs/msg/Empty",                        # no fields
])
def test_type_hash_of_other_installed_types(name):
    """The hash is general: any type parsed from its installed .msg files hashes as rosidl does."""
    assert type_hash(name, _installed_specs(name)) == _installed_hash(name)


def test_type_hash_matches_rosbags():
    typesys = pytest.importorskip("rosbags.typesys")
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    for name in msgdefs.DEFINITIONS:
        assert type_hash(name) == store.hash_rihs01(name), name


def test_full_text_layout_is_rosbag2s():
    """Root text, then each dependency once, depth-first in sorted order, after
    '\\n' + 80 '=' + '\\nMSG: pkg/Type\\n' (rosbag2 LocalMessageDefinitionSource)."""
    text = full_text("diagnostic_msgs/msg/DiagnosticArray")
    sections = text.split("\n" + "=" * 80 + "\n")
    assert sections[0] == msgdefs.DEFINITIONS["diagnostic_msgs/msg/DiagnosticArray"]
    heads = [s.split("\n", 1)[0] for s in sections[1:]]
    assert heads == ["MSG: diagnostic_msgs/DiagnosticStatus", "MSG: diagnostic_msgs/KeyValue",
                     "MSG: std_msgs/Header", "MSG: builtin_interfaces/Time"]
    for section in sections[1:]:
        head, body = section.split("\n", 1)
        assert body == msgdefs.DEFINITIONS[msgdefs.full_name(head[5:])]


@pytest.mark.parametrize("name", sorted(msgdefs.DEFINITIONS))
def test_full_text_parses_back_to_the_same_specs(name):
    specs = parse_schema(name, full_text(name))
    known = msgdefs.known_specs()
    assert specs[msgdefs.full_name(name)] == known[msgdefs.full_name(name)]
    for dep, spec in specs.items():
        assert spec == known[dep]


def test_full_text_equals_rosbags_generated_definition_semantically():
    typesys = pytest.importorskip("rosbags.typesys")
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    for name in msgdefs.DEFINITIONS:
        theirs, _ = store.generate_msgdef(name, ros_version=2)
        assert parse_schema(name, theirs) == parse_schema(name, full_text(name)), name


def test_mcap_ros2_parses_the_full_text():
    dynamic = pytest.importorskip("mcap_ros2._dynamic")
    for name in msgdefs.DEFINITIONS:
        assert name in dynamic.generate_dynamic(name, full_text(name))


def test_parser_details():
    spec = parse_msg("pkg/msg/T", "int32 A=1\nstring<=8[3] s  # c\nfloat64[<=2] v 0\nOther o\n"
                                  "uint8 B = 2\n")
    kinds = [(f.name, f.type, f.kind, f.size, f.string_bound) for f in spec.fields]
    assert kinds == [("s", "string", "array", 3, 8), ("v", "float64", "bounded", 2, 0),
                     ("o", "pkg/msg/Other", "scalar", 0, 0)]


@pytest.mark.parametrize("text, problem", [
    ("std_msgs/Header header\n", "lacks the definition of std_msgs/msg/Header"),
    ("int32 x\n" + "=" * 80 + "\nIDL: pkg/msg/T\nmodule pkg {};\n", "IDL"),
    ("int32\n", "expected `TYPE NAME`"),
    ("int32 9x\n", "cannot parse"),
])
def test_parse_schema_errors_name_the_problem(text, problem):
    with pytest.raises(MsgDefError, match=re.escape(problem)):
        parse_schema("pkg/msg/T", text)


def test_unknown_type_is_refused_with_the_known_list():
    with pytest.raises(MsgDefError, match="known: builtin_interfaces/msg/Time"):
        full_text("foo_msgs/msg/Bar")
