"""The ``balancer:`` and ``harmonic:`` sections are declared (rotor_avc.balancing.scenario,
rotor_avc.harmonic.config): every key of the shipped configs has a declaration, a misspelt key
deep in a section gets the closest valid one, a value out of bounds is refused naming the field
and its unit, and the cross-field rules name the field and the fix."""
import dataclasses
import typing
from pathlib import Path

import pytest

from rotor_avc.balancing.scenario import (BALANCER_SETTINGS, PointMass, RigidBalancerSettings,
                                          plane_balancer_settings)
from rotor_avc.config import Section, load_yaml
from rotor_avc.errors import ConfigError
from rotor_avc.harmonic.config import HARMONIC_SETTINGS, RunoutEntry, harmonic_section
from rotor_avc.machine import CAPABILITIES
from rotor_avc.settings import _rows, read_settings

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted(ROOT.glob("config/*.yaml"))
#: declarations of the entries of a list (``tuple[Entry, ...]``) by the list's path
ENTRIES = {"balancer.run_up.unbalance": PointMass, "harmonic.runout": RunoutEntry}


def shipped(section: str) -> list[tuple[str, dict]]:
    """(name, merged YAML) of every shipped config with ``section``."""
    out = []
    for path in SHIPPED:
        data = load_yaml(path)
        if section in data:
            out.append((path.stem, data))
    return out


def rigid(data: dict) -> RigidBalancerSettings:
    return read_settings(RigidBalancerSettings, Section(data, "", "test").section("balancer"))


def plane(data: dict):
    return plane_balancer_settings(Section(data, "", "test").section("balancer"))


def harmonic(data: dict):
    return harmonic_section(Section(data, "", "test"))


def reader(data: dict):
    return rigid if data.get("model") == "rigid_rotor" else plane


def declared_paths(cls, prefix: str) -> set[str]:
    paths = {path for path, *_ in _rows(cls, prefix)}
    for path, entry in ENTRIES.items():
        if path in paths:
            paths |= {p for p, *_ in _rows(entry, path + "[]")}
    return paths


def leaves(value, path: str):
    """Leaf paths of a YAML value; the entries of a list of mappings as ``path[]``."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from leaves(item, f"{path}.{key}")
    elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        yield path
        for item in value:
            yield from leaves(item, path + "[]")
    else:
        yield path


def test_declarations_are_exported_per_capability():
    assert set(BALANCER_SETTINGS) <= set(CAPABILITIES)
    for cls in (*BALANCER_SETTINGS.values(), HARMONIC_SETTINGS):
        assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen


@pytest.mark.parametrize("section", ["balancer", "harmonic"])
def test_every_shipped_key_is_declared(section):
    configs = shipped(section)
    assert configs, f"no shipped config has {section}:"
    for name, data in configs:
        if section == "harmonic":
            cls = HARMONIC_SETTINGS
        else:
            cls = BALANCER_SETTINGS["rigid_balancer" if reader(data) is rigid
                                    else "plane_balancer"]
        missing = set(leaves(data[section], section)) - declared_paths(cls, section)
        assert not missing, f"{name}: undeclared {sorted(missing)}"


@pytest.mark.parametrize("section", ["balancer", "harmonic"])
def test_every_declared_field_has_a_meaning(section):
    classes = (list(BALANCER_SETTINGS.values()) if section == "balancer"
               else [HARMONIC_SETTINGS])
    for cls in classes:
        rows = list(_rows(cls, section))
        for entry in ENTRIES.values():
            rows += list(_rows(entry, "entry"))
        assert all(doc for *_, doc in rows), [p for p, *_, doc in rows if not doc]
        assert not [p for p, *_, doc in rows if "|" in doc], "a | breaks the reference table"


def test_shipped_sections_read_and_fill_the_declared_defaults():
    for name, data in shipped("balancer"):
        s = reader(data)(data)
        assert s.run_up is not None, name
    s = rigid(config("balancer_rigid_rotor"))
    assert s.estimator.axes == "both" and s.supervisor.switching_weight == "paper"
    assert s.max_rate_m_per_s is None and s.run_up.imbalance.position_m == (0.1, -0.3, 0.05)
    s = plane(config("balancer_foot_mount"))
    assert [m.angle_deg for m in s.run_up.unbalance] == [0.0, 120.0]
    assert s.estimator.min_speed_hz == 1.0 and s.signals == ("DL", "DR", "NL")
    for name, data in shipped("harmonic"):
        h = harmonic(data)
        assert h.sensors and h.runout == () and h.fallback.mode == "fade" and h.supervisor.enabled, name
    h = harmonic(config("scenario_harmonic_dynamic_runup"))
    assert (h.gain, h.feedforward, h.feedforward_effort) == ("auto", "dynamic", 1e-2)


def change(data: dict, section: str, path: str, value) -> dict:
    """``data`` with ``section.path`` set to ``value`` (``key[i]`` indexes a list)."""
    node, keys = data[section], path.split(".")
    for key in keys[:-1]:
        key, _, index = key.partition("[")
        node = node.setdefault(key, {})
        if index:
            node = node[int(index.rstrip("]"))]
    node[keys[-1]] = value
    return data


def config(name: str) -> dict:
    return load_yaml(ROOT / "config" / f"{name}.yaml")


MISSPELT = [  # (config, section, misspelt path, the key it should be)
    ("balancer_rigid_rotor", "balancer", "run_up.imbalance.mas_kg", "mass_kg"),
    ("balancer_rigid_rotor", "balancer", "run_up.noise.sead", "seed"),
    ("balancer_rigid_rotor", "balancer", "estimator.forgeting_factor", "forgetting_factor"),
    ("balancer_foot_mount", "balancer", "run_up.unbalance[1].radus_m", "radius_m"),
    ("balancer_foot_mount", "balancer", "supervisor.estimate_untill_s", "estimate_until_s"),
    ("harmonic_bearings", "harmonic", "fallback.patiense", "patience"),
    ("harmonic_bearings", "harmonic", "identification.min_rel_chnge", "min_rel_change"),
]


@pytest.mark.parametrize("name, section, path, key", MISSPELT)
def test_misspelt_key_deep_in_a_section_gets_the_closest_one(name, section, path, key):
    data = change(config(name), section, path, 1.0)
    read = harmonic if section == "harmonic" else reader(data)
    with pytest.raises(ConfigError, match=rf"did you mean '{key}'\?") as err:
        read(data)
    assert err.value.field == f"{section}.{path}"


def test_misspelt_key_of_a_runout_entry_gets_the_closest_one():
    data = change(config("harmonic_bearings"), "harmonic", "runout",
                  [{"sensor": "bearing_D_vz", "order": 2, "magnitde": 1e-4}])
    with pytest.raises(ConfigError, match=r"did you mean 'magnitude'\?") as err:
        harmonic(data)
    assert err.value.field == "harmonic.runout[0].magnitde"


OUT_OF_BOUNDS = [  # (config, section, path, value, message)
    ("balancer_rigid_rotor", "balancer", "run_up.noise.displacement_m", -1e-5,
     r"must be >= 0 \(got -1e-05 m\)"),
    ("balancer_rigid_rotor", "balancer", "run_up.accel_rad_s2", 0.0,
     r"must be > 0 \(got 0.0 rad/s\^2\)"),
    ("balancer_rigid_rotor", "balancer", "supervisor.switching_weight", -0.5,
     r"must be > 0 \(got -0.5\)"),
    ("balancer_rigid_rotor", "balancer", "estimator.forgetting_factor", 1.5,
     r"must be <= 1.0 \(got 1.5\)"),
    ("balancer_foot_mount", "balancer", "run_up.unbalance[0].mass_kg", -0.05,
     r"must be >= 0 \(got -0.05 kg\)"),
    ("balancer_foot_mount", "balancer", "max_rate_kg_m_per_s", 0.0,
     r"must be > 0 \(got 0.0 kg m/s\)"),
    ("harmonic_bearings", "harmonic", "force_limit_n", -10.0, r"must be > 0 \(got -10.0 N\)"),
    ("harmonic_bearings", "harmonic", "identification", {"dither_n": -1.0},
     r"dither_n: must be >= 0 \(got -1.0 N\)"),
    ("harmonic_bearings", "harmonic", "influence", {"rel_step": 0.6},
     r"rel_step: must be <= 0.5 \(got 0.6\)"),
]


@pytest.mark.parametrize("name, section, path, value, message", OUT_OF_BOUNDS)
def test_value_out_of_bounds_is_refused_naming_field_and_unit(name, section, path, value,
                                                                message):
    data = change(config(name), section, path, value)
    read = harmonic if section == "harmonic" else reader(data)
    with pytest.raises(ConfigError, match=message) as err:
        read(data)
    assert err.value.field.startswith(f"{section}.{path}")


CROSS_FIELD = [  # (config, section, changes, field, words of the problem or fix)
    ("balancer_rigid_rotor", "balancer", {"initial_position_m": [0.0, 0.0, 0.0]},
     "balancer.initial_position_m", "must have 2 entries"),
    ("balancer_rigid_rotor", "balancer", {"run_up.imbalance.position_m": [0.1, 0.2, 0.3, 0.4]},
     "balancer.run_up.imbalance.position_m", "must have 3 entries"),
    ("balancer_rigid_rotor", "balancer", {"move_time_s": 0.0}, "balancer.move_time_s",
     "max_rate_m_per_s"),
    ("balancer_foot_mount", "balancer", {"move_time_s": 0.0, "max_rate_kg_m_per_s": None},
     "balancer.move_time_s", "max_rate_kg_m_per_s"),
    ("balancer_foot_mount", "balancer", {"run_up.unbalance": []}, "balancer.run_up.unbalance",
     "must be a list of at least 1"),
    ("harmonic_bearings", "harmonic", {"harmonics": [1, 1.5]}, "harmonic.harmonics",
     "distinct integers >= 1"),
    ("harmonic_bearings", "harmonic", {"sensor_weights": [1.0]}, "harmonic.sensor_weights",
     "must have 2 entries"),
    ("harmonic_bearings", "harmonic", {"law": "wls"}, "harmonic.effort_weight", "wls"),
    ("harmonic_bearings", "harmonic", {"adapt_in": "excitations", "harmonics": [1, 2]},
     "harmonic.adapt_in", "1x only"),
    ("harmonic_bearings", "harmonic", {"feedforward_effort": 1e-2},
     "harmonic.feedforward_effort", "feedforward: dynamic"),
    ("harmonic_bearings", "harmonic",
     {"feedforward": "dynamic", "adapt_in": "excitations", "refresh_samples": 25,
      "identification": {}}, "harmonic.identification", "not an identified influence"),
    ("harmonic_bearings", "harmonic", {"runout": [{"sensor": "bearing_N_vy", "magnitude": 1.0}]},
     "harmonic.runout[0].sensor", "bearing_D_vz, bearing_N_vz"),
]


@pytest.mark.parametrize("name, section, changes, field, words", CROSS_FIELD)
def test_cross_field_rules_name_the_field(name, section, changes, field, words):
    data = config(name)
    for path, value in changes.items():
        change(data, section, path, value)
    read = harmonic if section == "harmonic" else reader(data)
    with pytest.raises(ConfigError) as err:
        read(data)
    assert err.value.field == field and words in str(err.value), err.value


def test_a_list_of_entries_is_declared_by_its_entry_class():
    hints = typing.get_type_hints(HARMONIC_SETTINGS)
    assert typing.get_args(hints["runout"]) == (RunoutEntry, ...)
    run_up = typing.get_type_hints(BALANCER_SETTINGS["plane_balancer"])["run_up"]
    assert typing.get_args(typing.get_type_hints(run_up)["unbalance"]) == (PointMass, ...)
    with pytest.raises(ConfigError, match=r"harmonic.runout\[1\]: must be a mapping"):
        harmonic(change(config("harmonic_bearings"), "harmonic", "runout",
                        [{"sensor": "bearing_D_vz", "magnitude": 1.0}, 3]))
