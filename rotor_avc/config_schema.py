"""The configuration language, read from its declarations: one tree per model family and its
JSON Schema (draft 2020-12); rotor_avc.config_documents writes the reference, starting configs
and the resolved configuration of a file from the same tree (``rotor-avc config``).

The declarations (rotor_avc.settings) are the shared sections (:data:`rotor_avc.settings.SECTIONS`),
each model family's ``MODEL_SETTINGS`` (the modules of :data:`rotor_avc.machine.MODELS`) and the
parts other modules declare (:data:`DECLARED_ELSEWHERE`). A part without a declaration yet is
described as open ("not declared yet") and picked up as soon as its module exports one::

    rotor-avc config schema --out config.schema.json
    rotor-avc config reference --out docs/config-reference.md

Everything derives from one tree of :class:`Node` per model family (:func:`language`), so the
schema, the reference, the template of ``config new`` and the resolution of ``config check``
cannot disagree.
"""
from __future__ import annotations

import dataclasses
import importlib
import re
import typing
from dataclasses import dataclass, field
from typing import Any

from .machine import CAPABILITIES, COMMON_KEYS, MODELS
from .settings import SECTIONS, _options, _settings_class, _type_name

#: parts of a config declared outside rotor_avc.settings: path -> (module, exported name). A
#: declaration is a settings class; ``{type: class}`` (the section's ``type`` selects its keys);
#: or ``{capability: class}`` (rotor_avc.machine.CAPABILITIES: the model's ``SUPPORTS`` selects)
DECLARED_ELSEWHERE = {
    "controllers": ("rotor_avc.control.spec", "CONTROLLER_SETTINGS"),     # one entry per actuator
    "balancer": ("rotor_avc.balancing.scenario", "BALANCER_SETTINGS"),
    "harmonic": ("rotor_avc.harmonic.config", "HARMONIC_SETTINGS"),
    "simulation.speed": ("rotor_avc.sim.speed_profile", "PROFILE_SETTINGS"),
}
#: top-level sections every machine reads, given or not (their defaults always apply)
ALWAYS_READ = ("analysis", "control")
#: top-level keys that are not sections
HEAD = ("model", "name", "description")
NOT_DECLARED = "not declared yet"
#: the key of a section whose value selects the declaration of its other keys
UNION_KEY = "type"
#: a named entry in key paths (``controllers.<name>.kp``); ``[]``: an entry of a list
NAME = "<name>"
SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"

#: node kinds (:class:`Node`)
VALUE, SECTION, NAMED, LIST, UNION, BY_MODEL, OPEN, REFUSED = (
    "value", "section", "named", "list", "union", "by_model", "open", "refused")
NO_DEFAULT = object()


@dataclass(frozen=True)
class Node:
    """One key of the language: a ``value``; a ``section`` (a settings class: ``children`` are
    its fields); ``named`` entries or a ``list`` of entries (``children[NAME]`` is the entry); a
    ``union`` of sections by ``type``, or ``by_model`` capability (``children`` by type or
    capability); an ``open`` part, not declared yet; a part the model ``refused``."""

    kind: str
    doc: str = ""
    unit: str = ""
    required: bool = False
    #: JSON-ready default, or NO_DEFAULT (required, or a sub-section: see ``filled``)
    default: Any = NO_DEFAULT
    nullable: bool = False
    #: an absent section is read with its defaults (a settings class as default)
    filled: bool = False
    type_name: str = ""
    #: JSON Schema of a value, a list (without its items) or an open part
    schema: dict = field(default_factory=dict)
    cls: type | None = None
    children: dict = field(default_factory=dict)
    #: the module that reads a part not declared yet
    reader: str = ""


def json_value(value):
    return [json_value(v) for v in value] if isinstance(value, (tuple, list)) else value


def _first_paragraph(doc: str | None) -> str:
    """A docstring's first paragraph on one line, its reStructuredText roles as markdown code."""
    text = " ".join((doc or "").strip().split("\n\n")[0].split())
    return re.sub(r":\w+:`~?([^`]+)`", r"`\1`", text).replace("``", "`")


def declared(node: Node) -> bool:
    return node.kind not in (OPEN, REFUSED) and not (node.kind == SECTION and node.cls is None)


# -- the tree ----------------------------------------------------------------------------------
def _number_schema(meta: dict, integer: bool = False) -> dict:
    out: dict = {"type": "integer" if integer else "number"}
    if meta.get("positive"):
        out["exclusiveMinimum"] = 0
    lows = [m for m in (0 if meta.get("nonnegative") else None, meta.get("minimum")) if m is not None]
    if lows:
        out["minimum"] = max(lows)
    if meta.get("maximum") is not None:
        out["maximum"] = meta["maximum"]
    return out


def _value_schema(kinds: list, meta: dict) -> dict:
    """The JSON Schema of a declared value's type (``kinds``: its alternatives but None)."""
    if str in kinds and float in kinds:                 # a number or one of the named choices
        return {"anyOf": [_number_schema(meta), {"enum": list(meta["choices"])}]}
    kind = kinds[0]
    if kind in (float, int):
        return _number_schema(meta, integer=kind is int)
    if kind is bool:
        return {"type": "boolean"}
    if kind is str:
        return {"enum": list(meta["choices"])} if meta["choices"] else {"type": "string"}
    item = typing.get_args(kind)[0]                    # tuple[X, ...]
    items = {float: {"type": "number"}, str: {"type": "string"}}.get(item, {"type": "object"})
    return {"type": "array", "items": items, **_min_items(meta)}


def _min_items(meta: dict) -> dict:
    return {"minItems": meta["min_length"]} if meta["min_length"] else {}


def _entry(item, meta: dict, path: str) -> Node:
    """The entry of named entries or of a list: a section, an open mapping or a value."""
    if _settings_class(item):
        return _section(item, path)
    if item is dict:
        return Node(OPEN, schema={"type": "object"})
    return Node(VALUE, unit=meta["unit"], type_name=_type_name(item, dict(meta, unit="")),
                schema=_value_schema([item], meta))


def _field(tp, f: dataclasses.Field, path: str) -> Node:
    meta, default = f.metadata, f.default
    filled = f.default_factory is not dataclasses.MISSING
    common = dict(doc=meta["doc"], unit=meta["unit"],
                  required=default is dataclasses.MISSING and not filled,
                  default=NO_DEFAULT if default is dataclasses.MISSING else json_value(default),
                  nullable=type(None) in _options(tp) or default is None, filled=filled)
    kinds = [t for t in _options(tp) if t is not type(None)]
    kind, origin, args = kinds[0], typing.get_origin(kinds[0]), typing.get_args(kinds[0])
    if _settings_class(kind):
        return _section(kind, path, **common)
    if origin is dict:                                  # named entries: name -> X
        return Node(NAMED, children={NAME: _entry(args[1], meta, f"{path}.{NAME}")}, **common)
    if origin is tuple and _settings_class(args[0]):    # a list of sections
        return Node(LIST, schema={"type": "array", **_min_items(meta)},
                    children={NAME: _entry(args[0], meta, f"{path}[]")}, **common)
    if kind is dict:
        return _declared_at(path, **common)
    return Node(VALUE, type_name=_type_name(tp, dict(meta, unit="")),
                schema=_value_schema(kinds, meta), **common)


def _section(cls, path: str, **common) -> Node:
    hints = typing.get_type_hints(cls)
    children = {f.name: _field(hints[f.name], f, f"{path}.{f.name}" if path else f.name)
                for f in dataclasses.fields(cls)}
    common.setdefault("doc", _first_paragraph(cls.__doc__))
    return Node(SECTION, cls=cls, children=children, **common)


def _declared_at(path: str, **common) -> Node:
    """The part at ``path``: its declaration (:data:`DECLARED_ELSEWHERE`), or open."""
    module, name = DECLARED_ELSEWHERE.get(path, ("", ""))
    decl = getattr(importlib.import_module(module), name, None) if module else None
    if decl is None:
        return Node(OPEN, reader=module, schema={"type": "object"}, **common)
    if not isinstance(decl, dict):
        return _section(decl, path, **common)
    kind = BY_MODEL if set(decl) <= set(CAPABILITIES) else UNION
    return Node(kind, children={key: _section(cls, path) for key, cls in decl.items()}, **common)


def shared_parts() -> dict[str, Node]:
    """The top-level keys every config shares (rotor_avc.machine.COMMON_KEYS), as nodes."""
    parts = {}
    for key in COMMON_KEYS:
        if key == "model":
            parts[key] = Node(VALUE, doc="the model family: selects the other top-level keys",
                              required=True, type_name=" \\| ".join(f"`{m}`" for m in MODELS),
                              schema={"enum": list(MODELS)})
        elif key in SECTIONS:
            parts[key] = _section(SECTIONS[key], key, filled=key in ALWAYS_READ)
        elif key == "controllers":
            entry = _declared_at(key)
            parts[key] = (entry if entry.kind == OPEN else
                          Node(NAMED, doc="one entry per actuator id", children={NAME: entry}))
        elif key in DECLARED_ELSEWHERE:
            parts[key] = _declared_at(key)
        else:
            parts[key] = Node(OPEN)
    return parts


def model_module(model: str):
    return importlib.import_module(MODELS[model])


def _for_model(node: Node, model: str, key: str) -> Node:
    """A ``by_model`` part as the model's capabilities (``SUPPORTS``) select it."""
    if node.kind != BY_MODEL:
        return node
    supports = getattr(model_module(model), "SUPPORTS", ())
    chosen = [c for c in node.children if c in supports]
    if chosen:
        return node.children[chosen[0]]
    models = [m for m in MODELS if set(getattr(model_module(m), "SUPPORTS", ())) & set(node.children)]
    return Node(REFUSED, doc=f"model {model} supports no `{key}:` (models that do: "
                             f"{', '.join(models)})")


def family(model: str) -> Node:
    """The top-level keys of ``model:`` (its MODEL_SETTINGS): a section node, without a class
    and with every key open while the family is not declared yet."""
    module = model_module(model)
    decl = getattr(module, "MODEL_SETTINGS", None)
    doc = _first_paragraph(module.__doc__)
    if decl is None:
        return Node(SECTION, doc=doc, reader=module.__name__, children={
            key: Node(OPEN, reader=module.__name__) for key in module.MODEL_KEYS})
    return _section(decl, "", doc=doc, filled=True)


def language(model: str) -> Node:
    """The whole language of one model family: its keys and the shared ones."""
    shared = {k: _for_model(n, model, k) for k, n in shared_parts().items()}
    head = {k: shared.pop(k) for k in HEAD}
    fam = family(model)
    return dataclasses.replace(fam, children={**head, **fam.children, **shared})


# -- JSON Schema -------------------------------------------------------------------------------
def description(node: Node) -> str:
    text = node.doc + (f" [{node.unit}]" if node.unit else "")
    if node.kind == OPEN:
        text += f" ({NOT_DECLARED}" + (f": read by {node.reader})" if node.reader else ")")
    return text.strip()


def _nullable(schema: dict) -> dict:
    if isinstance(schema.get("type"), str):
        return {**schema, "type": [schema["type"], "null"]}
    if list(schema) == ["enum"]:
        return {"enum": schema["enum"] + [None]}
    return {"anyOf": [schema, {"type": "null"}]}


def _object_schema(node: Node, defs: dict) -> dict:
    out = {"type": "object", "description": _first_paragraph(node.cls.__doc__),
           "properties": {k: _schema(c, defs) for k, c in node.children.items()},
           "additionalProperties": False}
    required = [k for k, c in node.children.items() if c.required]
    return {**out, "required": required} if required else out


def _schema(node: Node, defs: dict) -> dict:
    """The JSON Schema of a node (each settings class once, in ``defs``)."""
    if node.kind == SECTION:
        name = f"{node.cls.__module__.removeprefix('rotor_avc.')}.{node.cls.__qualname__}"
        if name not in defs:
            defs[name] = {}                              # reserved while its fields are built
            defs[name] = _object_schema(node, defs)
        out = {"$ref": f"#/$defs/{name}"}
    elif node.kind == NAMED:
        out = {"type": "object", "additionalProperties": _schema(node.children[NAME], defs)}
    elif node.kind == LIST:
        out = {**node.schema, "items": _schema(node.children[NAME], defs)}
    elif node.kind == UNION:
        out = {"type": "object", "required": [UNION_KEY],
               "properties": {UNION_KEY: {"enum": list(node.children)}},
               "allOf": [{"if": {"properties": {UNION_KEY: {"const": name}},
                                 "required": [UNION_KEY]},
                          "then": _schema(variant, defs)}
                         for name, variant in node.children.items()]}
    elif node.kind == BY_MODEL:                          # the model's branch gives the keys
        out = {"type": "object", "description": "its keys depend on the model's capabilities: "
                                                + ", ".join(node.children)}
    elif node.kind == REFUSED:
        out = {"not": {}}
    else:
        out = dict(node.schema)
    if node.nullable:
        out = _nullable(out)
    if description(node):
        out["description"] = description(node)
    if node.default is not NO_DEFAULT:
        out["default"] = node.default
    return out


def include_schema() -> dict:
    name = {"type": "string", "minLength": 1}
    return {"description": "files loaded first, relative to this one; this file's values "
                           "override theirs mapping by mapping (rotor_avc/config.py)",
            "anyOf": [name, {"type": "array", "items": name}]}


def _required_unless_include(keys: list[str]) -> dict:
    return {"if": {"required": ["include"]}, "else": {"required": keys}}


def schema() -> dict:
    """The JSON Schema (draft 2020-12) of a configuration file: ``model`` selects the family's
    keys; every declared section is closed (``additionalProperties: false``). A file with
    ``include:`` need not give the required top-level keys (its includes may)."""
    defs: dict = {}
    shared = shared_parts()
    properties = {"include": include_schema(),
                  **{k: _schema(n, defs) for k, n in shared.items()}}
    branches = [_required_unless_include([k for k, n in shared.items() if n.required])]
    for model in MODELS:
        fam = family(model)
        for key in fam.children:
            properties.setdefault(key, {"description": "a key of a model family (`model:`)"})
        parts = {**fam.children, **{k: _for_model(n, model, k) for k, n in shared.items()
                                    if n.kind == BY_MODEL}}
        then = {"description": fam.doc + ("" if declared(fam) else f" ({NOT_DECLARED})"),
                "properties": {k: _schema(c, defs) for k, c in parts.items()},
                "propertyNames": {"enum": ["include", *shared, *fam.children]}}
        required = [k for k, c in fam.children.items() if c.required]
        if required:
            then["allOf"] = [_required_unless_include(required)]
        branches.append({"if": {"properties": {"model": {"const": model}}, "required": ["model"]},
                         "then": then})
    return {"$schema": SCHEMA_DIALECT, "title": "rotor_avc configuration",
            "description": "A machine config or scenario of rotor_avc (README: Configuration; "
                           "docs/config-reference.md).",
            "type": "object", "properties": properties, "additionalProperties": False,
            "allOf": branches, "$defs": dict(sorted(defs.items()))}
