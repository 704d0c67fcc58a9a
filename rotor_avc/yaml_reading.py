"""Reading a YAML file safely: bounded in size (:func:`max_yaml_bytes`), nesting
(:data:`MAX_YAML_DEPTH`) and alias expansion (:data:`MAX_YAML_NODES`, "billion laughs");
duplicate keys, tabs in indentation, control characters and non-UTF-8 bytes refused -- every
error a :class:`~rotor_avc.errors.ConfigError` naming the file and the line
(rotor_avc.config loads configs through it)."""
from __future__ import annotations

import math
import os
import re
from pathlib import Path

import yaml

from .errors import ConfigError, path_suggestion

#: refuse YAML files larger than this (bytes); ``ROTOR_AVC_MAX_YAML_MB`` overrides it
MAX_YAML_BYTES = 10 * 2**20
#: refuse a document whose aliases expand to more nodes than this ("billion laughs")
MAX_YAML_NODES = 200_000
#: refuse mappings and lists nested deeper than this
MAX_YAML_DEPTH = 64


def max_yaml_bytes() -> int:
    """The YAML size limit: ``ROTOR_AVC_MAX_YAML_MB`` (megabytes) or :data:`MAX_YAML_BYTES`."""
    text = os.environ.get("ROTOR_AVC_MAX_YAML_MB")
    if text is None:
        return MAX_YAML_BYTES
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and value > 0):
        raise ConfigError("ROTOR_AVC_MAX_YAML_MB", f"must be a number of megabytes > 0 (got {text!r})",
                          fix="set it to e.g. 10, or unset it")
    return int(value * 2**20)


class LimitedLoader(yaml.SafeLoader):
    """A safe loader that refuses deep nesting and duplicate keys, each with the line."""

    _depth = 0

    def compose_node(self, parent, index):
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise yaml.composer.ComposerError(
                    None, None, f"nested deeper than {MAX_YAML_DEPTH} levels",
                    self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        first: dict = {}
        for key_node, _ in node.value:
            if isinstance(key_node, yaml.ScalarNode) and key_node.tag != "tag:yaml.org,2002:merge":
                key = (key_node.tag, key_node.value)
                if key in first:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"duplicate key {key_node.value!r} (first at line "
                        f"{first[key] + 1})", key_node.start_mark)
                first[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep)


_FIXES = (("nested deeper", "flatten the structure (configs need a few levels)"),
          ("duplicate key", "keep one of the two entries"),
          ("undefined alias", "define the anchor (&name) before its alias (*name), or remove the alias"),
          ("aliases expanded", "remove the aliases (*name) that repeat large parts; a config "
                               "needs far fewer values"),
          ("refers to itself", "an anchor (&name) must not contain its own alias (*name)"))


def _yaml_error(exc: yaml.YAMLError, path: Path) -> ConfigError:
    """A YAML error as ``file: line N: problem -- fix: ...``."""
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    where = f"line {mark.line + 1}" if mark is not None else "(yaml)"
    problem = getattr(exc, "problem", None) or str(exc)
    context = getattr(exc, "context", None)
    text = f"{context}: {problem}" if context else problem
    fix = next((f for words, f in _FIXES if words in text), None)
    if fix is None:
        text, fix = f"not valid YAML: {text}", "correct the YAML syntax"
    return ConfigError(where, " ".join(text.split()), fix=fix, source=str(path))


def _check_expansion(node, path: Path) -> None:
    """Refuse alias graphs that expand to more than :data:`MAX_YAML_NODES` nodes or deeper than
    :data:`MAX_YAML_DEPTH` levels, or that contain themselves.

    Aliases share their anchor's node, so each node's expanded size and depth is computed once."""
    seen: dict[int, tuple[int, int]] = {}
    active: set[int] = set()

    def size_depth(n) -> tuple[int, int]:
        key = id(n)
        if key in seen:
            return seen[key]
        if key in active:
            raise yaml.composer.ComposerError(None, None, "an anchor refers to itself",
                                              n.start_mark)
        active.add(key)
        children = (n.value if isinstance(n, yaml.SequenceNode) else
                    [c for pair in n.value for c in pair] if isinstance(n, yaml.MappingNode) else [])
        total, depth = 1, 0
        for child in children:
            child_size, child_depth = size_depth(child)
            total, depth = total + child_size, max(depth, child_depth)
            if total > MAX_YAML_NODES:
                raise yaml.composer.ComposerError(
                    None, None, f"the document, its aliases expanded, holds more than "
                    f"{MAX_YAML_NODES} values", child.start_mark)
            if depth >= MAX_YAML_DEPTH:
                raise yaml.composer.ComposerError(
                    None, None, f"nested deeper than {MAX_YAML_DEPTH} levels through aliases",
                    child.start_mark)
        active.discard(key)
        seen[key] = total, depth + 1
        return seen[key]

    try:
        size_depth(node)
    except yaml.YAMLError as exc:
        raise _yaml_error(exc, path) from None


#: what YAML does not allow in a document (the complement of PyYAML's printable set): NUL and the
#: other control characters except tab, newline and carriage return, surrogates, U+FFFE/U+FFFF
_NOT_PRINTABLE = re.compile("[^\t\n\r\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd"
                            "\U00010000-\U0010ffff]")


def read_text(path: Path) -> str:
    """The file as text: size-limited, UTF-8, printable, no tabs in indentation (errors name
    the line; a file that does not exist, the closest existing path)."""
    limit = max_yaml_bytes()
    try:
        with open(path, "rb") as f:
            data = f.read(limit + 1)
    except OSError as exc:
        near = path_suggestion(path) if isinstance(exc, FileNotFoundError) else ""
        raise ConfigError(str(path), f"cannot read file ({exc.strerror}){near}",
                          fix="check the path") from None
    if len(data) > limit:
        raise ConfigError(str(path), f"larger than the limit of {limit / 2**20:g} MB for a "
                          "config file", fix="give the right file, or raise ROTOR_AVC_MAX_YAML_MB")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ConfigError(f"line {line}", f"not UTF-8 text (byte 0x{data[exc.start]:02x})",
                          fix="save the file as UTF-8", source=str(path)) from None
    bad = _NOT_PRINTABLE.search(text)
    if bad:
        line = text.count("\n", 0, bad.start()) + 1
        column = bad.start() - text.rfind("\n", 0, bad.start())
        raise ConfigError(f"line {line}", f"control character U+{ord(bad.group()):04X} at column "
                          f"{column}", fix="remove it (a config is printable text; tab, newline "
                          "and carriage return are allowed)", source=str(path))
    for number, line_text in enumerate(text.splitlines(), 1):
        indent = line_text[:len(line_text) - len(line_text.lstrip(" \t"))]
        if "\t" in indent:
            raise ConfigError(f"line {number}", "tab in the indentation",
                              fix="indent with spaces (YAML does not allow tabs)", source=str(path))
    return text


def parse(text: str, path: Path):
    loader = LimitedLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_expansion(node, path)
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        raise _yaml_error(exc, path) from None
    finally:
        loader.dispose()
