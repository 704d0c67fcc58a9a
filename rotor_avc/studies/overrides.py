"""Dotted config paths: read and override values of a loaded config (``a.b.c`` -> data[a][b][c])."""
from __future__ import annotations

import copy

from ..section import Section
from ..errors import ConfigError


def set_path(data: dict, path: str, value, field: str) -> None:
    """Set ``data[a][b][c] = value`` for ``path = "a.b.c"``; every parent must exist."""
    keys = path.split(".")
    node = data
    for depth, key in enumerate(keys[:-1]):
        if not isinstance(node, dict) or key not in node or not isinstance(node[key], dict):
            raise ConfigError(field, f"{path!r}: the config has no section "
                                     f"{'.'.join(keys[:depth + 1])!r}",
                              fix="give a dotted path of the config file, e.g. "
                                  "foundation.stiffness_n_per_m.z")
        node = node[key]
    if not keys[-1]:
        raise ConfigError(field, f"{path!r} is not a dotted config path", fix="remove the stray dot")
    node[keys[-1]] = copy.deepcopy(value)


def get_path(data: dict, path: str, field: str):
    node = data
    for key in path.split("."):
        if not isinstance(node, dict) or key not in node:
            raise ConfigError(field, f"the config has no value at {path!r}",
                              fix="give the dotted path of an existing value (a factor `*=` needs one)")
        node = node[key]
    return node


def with_overrides(cfg: Section, overrides: dict, field: str) -> Section:
    """A copy of the config with dotted-path overrides applied in order."""
    data = copy.deepcopy(cfg.data)
    for path, value in overrides.items():
        set_path(data, str(path), value, field)
    return Section(data, "", cfg.source)
