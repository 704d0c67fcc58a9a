"""Shared checks of the model families' declarations (test_declared_*.py): every key of every
shipped config has its reference row, and MODEL_KEYS are the declared fields."""
import copy
import dataclasses
import re
from pathlib import Path

import pytest

from rotor_avc.config import load_yaml
from rotor_avc.errors import ConfigError
from rotor_avc.machine import machine_from_config
from rotor_avc.settings import _rows

ROOT = Path(__file__).resolve().parents[1]


def shipped(model: str) -> dict[str, dict]:
    """The shipped configs of ``model`` (includes resolved)."""
    configs = {p.stem: load_yaml(p) for p in sorted((ROOT / "config").glob("*.yaml"))}
    return {name: data for name, data in configs.items() if data.get("model") == model}


def leaves(data, path=()):
    if isinstance(data, dict):
        for key, value in data.items():
            yield from leaves(value, path + (str(key),))
    else:
        yield ".".join(path)


def assert_model_keys_are_the_declared_fields(modules) -> None:
    for module in modules:
        assert module.MODEL_KEYS == tuple(f.name for f in dataclasses.fields(module.MODEL_SETTINGS))


def assert_every_shipped_key_has_a_reference_row(module, model: str) -> None:
    """Every leaf has its row (``<name>`` a named entry), or lies below a row of named entries
    that are values, not declared mappings (``rotor.bearing_arm_m.1``, ``variants.b.<path>``)."""
    rows = [(path.lstrip("."), kind) for path, kind, *_ in _rows(module.MODEL_SETTINGS, "")]
    paths = [path for path, _ in rows]
    exact = [re.escape(r).replace(re.escape("<name>"), r"[^.]+") + "$" for r in paths]
    values = [re.escape(r) + r"\." for r, kind in rows if kind.startswith("mapping of names")
              and not any(p.startswith(f"{r}.<name>.") for p in paths)]
    patterns = [re.compile(p) for p in exact + values]
    configs = shipped(model)
    assert configs, f"no shipped config of model {model}"
    for name, data in configs.items():
        mine = {k: v for k, v in data.items() if k in module.MODEL_KEYS}
        for leaf in leaves(mine):
            assert any(p.match(leaf) for p in patterns), f"{name}: {leaf} has no reference row"
    for path, kind, default, what in _rows(module.MODEL_SETTINGS, ""):
        assert what, f"{path} has no meaning"


def loaded(config: str) -> dict:
    return copy.deepcopy(load_yaml(ROOT / "config" / f"{config}.yaml"))


def parent(data: dict, path: str) -> tuple[dict, str]:
    """The mapping holding the last key of the dotted ``path`` (each mapping on the way copied:
    a YAML alias may share one mapping between several places), and that key."""
    *parents, key = path.split(".")
    for k in parents:
        data[k] = dict(data[k])
        data = data[k]
    return data, key


def changed(config: str, path: str, value) -> dict:
    """The config with the value at ``path`` replaced (removed for ``None``)."""
    data = loaded(config)
    sub, key = parent(data, path)
    if value is None:
        del sub[key]
    else:
        sub[key] = value
    return data


def refused(data: dict) -> str:
    """The one-line error of building a machine of ``data``."""
    with pytest.raises(ConfigError) as info:
        machine_from_config(data, "bad.yaml")
    return str(info.value)
