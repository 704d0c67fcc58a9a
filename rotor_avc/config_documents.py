"""The documents written from the configuration language's declarations
(rotor_avc.config_schema: one tree of :class:`~rotor_avc.config_schema.Node` per model family):
the reference (``docs/config-reference.md``), the commented starting config of ``rotor-avc config
new``, and the resolved configuration of a file with each value's origin (``config check``).
"""
from __future__ import annotations

import dataclasses
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from . import config as _config
from .config_schema import (ALWAYS_READ, BY_MODEL, HEAD, LIST, NAME, NAMED, NO_DEFAULT,
                            NOT_DECLARED, OPEN, SECTION, UNION, UNION_KEY, VALUE, Node, declared,
                            description, family, include_schema, json_value, language,
                            model_module, shared_parts)
from .errors import ConfigError
from .machine import MODELS
from .yaml_reading import LimitedLoader, read_text

#: the placeholder ``config new`` writes for a required mapping (``null`` would read as empty)
REQUIRED_MAPPING = "REQUIRED"

# -- the reference -----------------------------------------------------------------------------
def _default_text(node: Node) -> str:
    if node.required:
        return "required"
    if node.default is NO_DEFAULT:
        return ""
    return "none" if node.default is None else f"`{yaml_text(node.default)}`"


def _kind_text(node: Node) -> str:
    entry = node.children.get(NAME)
    if node.kind == VALUE:
        return node.type_name
    if node.kind == NAMED:
        return "mapping of names" + (f" to {entry.type_name}" if entry.kind == VALUE else "")
    if node.kind == LIST:
        return "list of mappings"
    if node.kind == UNION:
        return f"mapping by `{UNION_KEY}`: " + " \\| ".join(f"`{t}`" for t in node.children)
    return "any" if node.kind == OPEN and "type" not in node.schema else "mapping"


def _rows(node: Node, prefix: str, note: str = ""):
    for key, child in node.children.items():
        path = f"{prefix}.{key}" if prefix else key
        meaning = (note + description(child) if child.kind == OPEN else note + child.doc)
        yield (f"| `{path}` | {_kind_text(child)} | {child.unit} | {_default_text(child)} | "
               f"{meaning.replace('|', chr(92) + '|')} |")
        entry = child.children.get(NAME)
        if child.kind == SECTION:
            yield from _rows(child, path, note)
        elif entry is not None and entry.kind == SECTION:
            yield from _rows(entry, f"{path}.{NAME}" if child.kind == NAMED else f"{path}[]", note)
        elif child.kind == UNION:
            for name, variant in child.children.items():
                rest = {k: c for k, c in variant.children.items() if k != UNION_KEY}
                yield from _rows(dataclasses.replace(variant, children=rest), path,
                                 f"{note}(`{UNION_KEY}: {name}`) ")


def _table(node: Node, prefix: str) -> list[str]:
    return ["| key | type | unit | default | meaning |", "|---|---|---|---|---|",
            *_rows(node, prefix)]


def _part_text(title: str, node: Node, prefix: str) -> list[str]:
    lines = [f"### {title}", ""]
    if not declared(node):
        keys = ", ".join(f"`{k}`" for k in node.children)
        return lines + [(f"{node.doc} " if node.doc else "") + "Not declared yet"
                        + (f" (keys {keys})" if keys else "")
                        + (f"; read by `{node.reader}`." if node.reader else "."), ""]
    return lines + ([node.doc, ""] if node.doc else []) + _table(node, prefix) + [""]


def reference_document() -> str:
    """docs/config-reference.md: one table per shared section and per model family."""
    shared = shared_parts()
    top = Node(SECTION, children={k: shared.pop(k) for k in HEAD})
    lines = ["# Configuration reference", "",
             "Generated from the declarations (`rotor_avc/settings.py` and the modules that "
             "declare their parts) by `rotor-avc config reference --out "
             "docs/config-reference.md`; do not edit by hand. `rotor-avc config schema` gives "
             "the same as a JSON Schema, `rotor-avc config check FILE` validates a file and "
             "lists every resolved key, `rotor-avc config new MODEL` writes a starting config.",
             "", f"Units are SI unless the key says otherwise; `{NAME}` stands for a named entry "
             "(an actuator id, an excitation, ...) and `[]` for an entry of a list; *required* "
             "keys have no default; *none*: absent unless given.", "",
             "### Top level", "", *_table(top, ""),
             f"| `include` | file name or list of names |  |  | "
             f"{include_schema()['description']} |", "", "## Shared sections", ""]
    for key, node in shared.items():
        if node.kind != BY_MODEL:
            lines += _part_text(f"`{key}:`", node, key)
            continue
        for capability, variant in node.children.items():
            models = [m for m in MODELS if capability in getattr(model_module(m), "SUPPORTS", ())]
            lines += _part_text(f"`{key}:` of a model with `{capability}` ({', '.join(models)})",
                                variant, key)
    lines += ["## Model families", ""]
    for model in MODELS:
        lines += _part_text(f"`model: {model}`", family(model), "")
    return "\n".join(lines).rstrip() + "\n"


# -- a starting config -------------------------------------------------------------------------
def yaml_text(value) -> str:
    """A value as YAML flow text (floats as YAML reads them back: ``1.0e-05``, not ``1e-05``)."""
    return yaml.safe_dump(value, default_flow_style=True, width=10**9).removesuffix("...\n").strip()


def _comment(node: Node) -> str:
    text = description(node)
    if node.kind == VALUE and "enum" in node.schema:
        text += "; one of: " + ", ".join(map(str, node.schema["enum"]))
    if node.kind == UNION:
        text += f"; `{UNION_KEY}` one of: " + ", ".join(node.children)
    return text


def _template_lines(key: str, node: Node, indent: int, off: bool) -> list[str]:
    """``key: value  # meaning`` of a node and its keys; ``off``: commented out."""
    optional = not node.required and node.default is None
    off = off or optional
    comment = ("REQUIRED: " if node.required else "optional: " if optional else "") + _comment(node)
    pad = " " * indent

    def line(text: str, note: str) -> str:
        return f"{pad}{('# ' if off else '') + text:<{max(40 - indent, 1)}} # {note}"

    if node.kind == SECTION:
        body = [text for name, child in node.children.items()
                for text in _template_lines(name, child, indent + 2, off)]
        if off or any(not text.lstrip().startswith("#") for text in body):
            return [line(f"{key}:", comment)] + body
        return [line(f"{key}: {{}}" if node.required else f"# {key}:", comment)] + body
    if node.kind in (VALUE, LIST):
        plain = node.default is NO_DEFAULT or node.default is None
        out = [line(f"{key}: {'null' if plain else yaml_text(node.default)}", comment)]
    else:
        out = [line(f"{key}:{f' {REQUIRED_MAPPING}' if node.required and not off else ''}",
                    comment)]
    entry = node.children.get(NAME)
    if node.kind == NAMED:
        out += _template_lines(NAME, dataclasses.replace(entry, required=False), indent + 2, True)
    elif node.kind == LIST:
        out += [f"{pad}  # -  (an entry:)"] + [
            text for name, child in entry.children.items()
            for text in _template_lines(name, child, indent + 4, True)]
    for name, variant in node.children.items() if node.kind == UNION else ():
        out.append(f"{pad}  # -- {UNION_KEY}: {name}: {variant.doc}")
        fixed = {UNION_KEY: dataclasses.replace(variant.children[UNION_KEY], required=False,
                                                default=name)}
        for child_key, child in {**variant.children, **fixed}.items():
            out += _template_lines(child_key, child, indent + 2, True)
    return out


def template(model: str) -> str:
    """A commented starting config of ``model``: every declared key with its meaning and unit,
    defaults as values, optional parts commented out, required values ``null`` (or
    :data:`REQUIRED_MAPPING`) marked ``# REQUIRED`` -- it fails ``config check`` until filled."""
    fam = family(model)
    if not declared(fam):
        raise ConfigError("model", f"the keys of model {model} are {NOT_DECLARED} "
                          f"({fam.reader} has no MODEL_SETTINGS)",
                          fix="start from a shipped config of that model "
                              f"(grep -l 'model: {model}' in the config folder)")
    head = (f"A starting config of model {model}: {fam.doc} Written by `rotor-avc config new "
            f"{model}`: every declared key with its meaning and unit, defaults as values. Fill "
            "the values marked REQUIRED, uncomment what you need, then run `rotor-avc config "
            "check FILE`. Reference: docs/config-reference.md. Editors (the YAML language "
            "server) check the file as you type with `rotor-avc config schema --out "
            "schema.json` and this line:")
    lines = [*textwrap.wrap(head, 98, initial_indent="# ", subsequent_indent="# "),
             "# yaml-language-server: $schema=schema.json", "", f"model: {model}"]
    for key, node in language(model).children.items():
        if key not in HEAD and declared(node):
            keep = key in fam.children or key in ALWAYS_READ
            lines += [""] + _template_lines(key, node, 0, not keep)
    return "\n".join(lines) + "\n"


# -- the resolved configuration ----------------------------------------------------------------
@dataclass(frozen=True)
class Resolved:
    """One key of a configuration as the product reads it: value, unit and origin (``file:line``
    of the file that gives it, or ``default``)."""

    path: tuple[str, ...]
    value: Any
    unit: str
    origin: str


def _key_lines(node, prefix=()):
    """``(key path, line)`` of every key of a composed YAML document (merge keys flattened)."""
    if isinstance(node, yaml.MappingNode):
        for key, value in node.value:
            path = prefix + (str(key.value),)
            yield path, key.start_mark.line + 1
            yield from _key_lines(value, path)


def origins(path) -> dict[tuple[str, ...], str]:
    """``file:line`` of every key of a config that :func:`rotor_avc.config.load_yaml` accepted:
    of the last file that gives it in the order load_yaml merges them (the includes first,
    recursively, then the including file); files named relative to the config's folder."""
    top = Path(path).resolve()
    out: dict = {}

    def visit(p: Path) -> None:
        text = read_text(p)
        loader = LimitedLoader(text)
        try:
            node = loader.get_single_node()
            data = loader.construct_document(node) if node is not None else {}
        finally:
            loader.dispose()
        for name in _config._include_list(data.get("include", []), text, p):
            visit(_config._include_path(name, text, p).resolve())
        label = str(p.relative_to(top.parent)) if p.is_relative_to(top.parent) else str(p)
        out.update({k: f"{label}:{line}" for k, line in _key_lines(node)})

    visit(top)
    return out


def _origin(path: tuple, where: dict) -> str:
    return next((where[path[:n]] for n in range(len(path), 0, -1) if path[:n] in where), "?")


def _resolve(node: Node, value, path: tuple, where: dict, out: list) -> None:
    if node.kind == SECTION and isinstance(value, dict):
        for key, child in node.children.items():
            if key in value:
                _resolve(child, value[key], path + (key,), where, out)
            elif child.filled:
                _resolve(child, {}, path + (key,), where, out)
            elif child.default is not NO_DEFAULT and child.default is not None:
                out.append(Resolved(path + (key,), child.default, child.unit, "default"))
    elif node.kind == NAMED and isinstance(value, dict):
        for key, item in value.items():
            _resolve(node.children[NAME], item, path + (str(key),), where, out)
    elif node.kind == UNION and isinstance(value, dict) and value.get(UNION_KEY) in node.children:
        _resolve(node.children[value[UNION_KEY]], value, path, where, out)
    elif node.kind == OPEN and isinstance(value, dict) and value:
        for key, item in value.items():
            _resolve(node, item, path + (str(key),), where, out)
    else:                                               # a value (a list as a whole)
        out.append(Resolved(path, json_value(value), node.unit, _origin(path, where)))


def resolve(cfg: _config.Section) -> list[Resolved]:
    """Every key of a valid loaded config (includes merged) with the defaults its declarations
    fill (in the sections always read, :data:`ALWAYS_READ`, and the family's keys even when
    absent; in the other parts when given). A key whose default is none stays absent."""
    where = origins(cfg.source) if Path(cfg.source).is_file() else {}    # else: a bag's record
    out: list[Resolved] = []
    _resolve(language(cfg.data["model"]), cfg.data, (), where, out)
    return out


def nested(entries: list[Resolved]) -> dict:
    """The resolved keys as one mapping (the document ``config check --json`` prints)."""
    root: dict = {}
    for entry in entries:
        node = root
        for key in entry.path[:-1]:
            node = node.setdefault(key, {})
        node[entry.path[-1]] = entry.value
    return root
