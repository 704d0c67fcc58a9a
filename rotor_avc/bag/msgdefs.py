"""ROS 2 message definitions: parsing ``ros2msg`` schemas, rosbag2's full text, RIHS01 hashes.

The message types the package records (DESIGN.md section 4) are vendored here as their ``.msg``
text without comments, so bags are written without ROS installed. From them this module makes

* the **full dependency text** of a type exactly as rosbag2's ``LocalMessageDefinitionSource``
  concatenates it: the root definition, then every dependency depth-first in sorted order, each
  after ``"\\n" + "=" * 80 + "\\nMSG: pkg/Type\\n"`` (rosbag2 also keeps the comments; the fields,
  their order and the separators are identical);
* the **RIHS01 type hash** (REP-2011): SHA-256 of the compact JSON of the type description (the
  type and its sorted referenced types; fields with type id, capacity, string capacity and nested
  type name) as ``rosidl_generator_type_description.calculate_type_hash`` computes it. The tests
  check both against the ``share/<pkg>/msg/<Type>.json`` files of the installed ROS packages and
  against the ``rosbags`` type store.

:func:`parse_schema` reads any ``ros2msg`` full text (also bags recorded by others).
"""
from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass

#: type ids of the type description (rosidl_generator_type_description FIELD_TYPE_*)
PRIMITIVE_TYPE_IDS = {
    "int8": 2, "uint8": 3, "char": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7,
    "int64": 8, "uint64": 9, "float32": 10, "float64": 11, "bool": 15, "byte": 16,
    "string": 17, "wstring": 18,
}
NESTED_TYPE_ID = 1
_BOUNDED_STRING_ID = {"string": 21, "wstring": 22}
_ARRAY_OFFSET = {"scalar": 0, "array": 48, "bounded": 96, "sequence": 144}
SEPARATOR = "=" * 80

#: the vendored definitions (``.msg`` text, comments removed), keyed by full type name
DEFINITIONS = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort\n"),
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Accel": "Vector3  linear\nVector3  angular\n",
    "geometry_msgs/msg/AccelStamped": "std_msgs/Header header\nAccel accel\n",
    "geometry_msgs/msg/Wrench": "Vector3  force\nVector3  torque\n",
    "geometry_msgs/msg/Twist": "Vector3  linear\nVector3  angular\n",
    "geometry_msgs/msg/TwistStamped": "std_msgs/Header header\nTwist twist\n",
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/PointStamped": "std_msgs/Header header\nPoint point\n",
    "geometry_msgs/msg/WrenchStamped": "std_msgs/Header header\nWrench wrench\n",
    "rosgraph_msgs/msg/Clock": "builtin_interfaces/Time clock\n",
    "diagnostic_msgs/msg/DiagnosticArray": "std_msgs/Header header\nDiagnosticStatus[] status\n",
    "diagnostic_msgs/msg/DiagnosticStatus": (
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\n"
        "string message\nstring hardware_id\nKeyValue[] values\n"),
    "diagnostic_msgs/msg/KeyValue": "string key\nstring value\n",
    "std_msgs/msg/Float64MultiArray": "MultiArrayLayout  layout\nfloat64[]         data\n",
    "std_msgs/msg/MultiArrayLayout": "MultiArrayDimension[] dim\nuint32 data_offset\n",
    "std_msgs/msg/MultiArrayDimension": "string label\nuint32 size\nuint32 stride\n",
}

_TYPE_RE = re.compile(r"^([A-Za-z][A-Za-z0-9_/]*?)(?:<=(\d+))?(?:\[(<=)?(\d*)\])?$")
_SECTION_RE = re.compile(r"^=+\s*$", re.MULTILINE)


class MsgDefError(ValueError):
    """A message definition cannot be parsed or is incomplete (the reader wraps it)."""


@dataclass(frozen=True)
class Field:
    """One field: ``type`` is a primitive name or a full ``pkg/msg/Type``.

    ``kind`` is ``scalar``, ``array`` (fixed ``size``), ``bounded`` (sequence of at most
    ``size``) or ``sequence``; ``string_bound`` > 0 for ``string<=N``.
    """

    name: str
    type: str
    kind: str = "scalar"
    size: int = 0
    string_bound: int = 0

    @property
    def nested(self) -> bool:
        return self.type not in PRIMITIVE_TYPE_IDS


@dataclass(frozen=True)
class MsgSpec:
    name: str
    fields: tuple[Field, ...]


def full_name(name: str, package: str = "") -> str:
    """``pkg/Type`` or ``pkg/msg/Type`` (or ``Type`` inside ``package``) -> ``pkg/msg/Type``."""
    parts = name.split("/")
    if len(parts) == 1 and package:
        return f"{package}/msg/{name}"
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    if len(parts) == 3:
        return name
    raise MsgDefError(f"not a message type name: {name!r}")


def short_name(name: str) -> str:
    """``pkg/msg/Type`` -> ``pkg/Type`` (the form of the ``MSG:`` separators)."""
    pkg, _, typ = full_name(name).split("/")
    return f"{pkg}/{typ}"


def parse_msg(name: str, text: str) -> MsgSpec:
    """Parse one ``.msg`` body; constants are skipped, default values ignored."""
    package = full_name(name).split("/")[0]
    fields = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split(None, 1)
        if len(parts) < 2:
            raise MsgDefError(f"{name} line {lineno}: expected `TYPE NAME`, got {raw.strip()!r}")
        type_token, rest = parts
        field_name = re.split(r"[\s=]", rest, maxsplit=1)[0]
        if rest[len(field_name):].lstrip().startswith("="):
            continue                                         # a constant
        match = _TYPE_RE.match(type_token)
        if not match or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", field_name):
            raise MsgDefError(f"{name} line {lineno}: cannot parse {raw.strip()!r}")
        base, string_bound, bounded, size = match.groups()
        if base in PRIMITIVE_TYPE_IDS:
            ftype = base
        elif string_bound is not None:
            raise MsgDefError(f"{name} line {lineno}: only strings take a `<=N` bound")
        else:
            ftype = full_name(base, package)
        if match.group(0).endswith("]"):
            kind = "bounded" if bounded else ("array" if size else "sequence")
        else:
            kind = "scalar"
        fields.append(Field(field_name, ftype, kind, int(size or 0), int(string_bound or 0)))
    if not fields:   # rosidl gives an empty message one placeholder byte
        fields.append(Field("structure_needs_at_least_one_member", "uint8"))
    return MsgSpec(full_name(name), tuple(fields))


def parse_schema(root: str, text: str) -> dict[str, MsgSpec]:
    """Parse a ``ros2msg`` full text (root + ``MSG: pkg/Type`` sections) into specs by name.

    Raises :class:`MsgDefError` for IDL sections, a malformed section, or a nested type whose
    definition the text does not contain.
    """
    chunks = _SECTION_RE.split(text)
    specs = {full_name(root): parse_msg(root, chunks[0])}
    for chunk in chunks[1:]:
        head, _, body = chunk.lstrip("\n").partition("\n")
        if head.startswith("IDL:"):
            raise MsgDefError(f"{root}: IDL schema sections are not supported (ros2msg only)")
        if not head.startswith("MSG:"):
            raise MsgDefError(f"{root}: schema section without a `MSG: pkg/Type` line")
        name = full_name(head[4:].strip())
        specs[name] = parse_msg(name, body)
    missing = sorted({f.type for s in specs.values() for f in s.fields
                      if f.nested and f.type not in specs})
    if missing:
        raise MsgDefError(f"{root}: the schema lacks the definition of " + ", ".join(missing))
    return specs


def known_specs() -> dict[str, MsgSpec]:
    """Specs of every vendored type."""
    return {name: parse_msg(name, text) for name, text in DEFINITIONS.items()}


def _dependencies(name: str) -> list[str]:
    """Dependencies of a vendored type as rosbag2 names them (``pkg/Type``), sorted."""
    spec = parse_msg(name, DEFINITIONS[name])
    return sorted({short_name(f.type) for f in spec.fields if f.nested})


def full_text(type_name: str) -> str:
    """The rosbag2 ``ros2msg`` full text of a vendored type (see the module docstring)."""
    root = _require_known(type_name)
    seen: set[str] = set()

    def append(name: str) -> str:
        result = DEFINITIONS[name]
        for dep in _dependencies(name):
            if dep not in seen:
                seen.add(dep)
                result += f"\n{SEPARATOR}\nMSG: {dep}\n" + append(full_name(dep))
        return result

    return append(root)


def _field_description(field: Field) -> dict:
    if field.nested:
        base_id = NESTED_TYPE_ID
    elif field.string_bound:
        base_id = _BOUNDED_STRING_ID[field.type]
    else:
        base_id = PRIMITIVE_TYPE_IDS[field.type]
    return {"name": field.name,
            "type": {"type_id": base_id + _ARRAY_OFFSET[field.kind],
                     "capacity": field.size if field.kind in ("array", "bounded") else 0,
                     "string_capacity": field.string_bound,
                     "nested_type_name": field.type if field.nested else ""}}


def type_description(type_name: str, specs: dict[str, MsgSpec]) -> dict:
    """The type description (without default values) of ``type_name`` over ``specs``."""
    root = full_name(type_name)
    refs: set[str] = set()
    queue = [f.type for f in specs[root].fields if f.nested]
    while queue:
        name = queue.pop()
        if name not in refs:
            refs.add(name)
            queue.extend(f.type for f in specs[name].fields if f.nested)

    def describe(name: str) -> dict:
        return {"type_name": name, "fields": [_field_description(f) for f in specs[name].fields]}

    return {"type_description": describe(root),
            "referenced_type_descriptions": [describe(n) for n in sorted(refs)]}


def type_hash(type_name: str, specs: dict[str, MsgSpec] | None = None) -> str:
    """RIHS01 hash of a type (REP-2011), e.g. ``RIHS01_a13e...`` for sensor_msgs/JointState."""
    if specs is None:
        _require_known(type_name)
        specs = known_specs()
    text = json.dumps(type_description(type_name, specs), ensure_ascii=True, allow_nan=False,
                      separators=(", ", ": "), sort_keys=False)
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def _require_known(type_name: str) -> str:
    name = full_name(type_name)
    if name not in DEFINITIONS:
        raise MsgDefError(f"message type {type_name!r} is not one the package records; known: "
                          + ", ".join(sorted(DEFINITIONS)))
    return name
