"""`rotor-avc config`: the JSON Schema of the configuration language, judged by an independent
validator (jsonschema) on every shipped config and on broken ones (which the product refuses
too); check, show, new; parts not declared yet stay open; docs/config-reference.md is the
generated reference."""
import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from jsonschema import Draft202012Validator

from rotor_avc import config_schema
from rotor_avc.cli import main
from rotor_avc.cli.config_cmd import load_resolved
from rotor_avc.config_documents import REQUIRED_MAPPING, nested, reference_document
from rotor_avc.config_schema import SECTION, VALUE, declared, family, language, schema
from rotor_avc.machine import MODELS, load_machine, machine_from_config
from rotor_avc.scenario import scenario_from_machine

ROOT = Path(__file__).resolve().parents[1]
#: shipped files that are not configs of their own: parts to include, and ROS parameters
FRAGMENTS = ("foot_mount_common", "harmonic_bearings", "ros_case3")
SHIPPED = sorted(p.stem for p in (ROOT / "config").glob("*.yaml") if p.stem not in FRAGMENTS)
#: one shipped config per model family, the values `config new`'s template is filled from
FILL_FROM = {"foot_mount_3d": "foot_mount_case1", "roller_bearing_rotor": "roller_bearing_stability",
             "active_bearing": "active_bearing", "rigid_rotor": "balancer_rigid_rotor",
             "sleeve_bearing_motor": "sleeve_bearing_motor"}
#: configs broken on purpose: every family, a scenario, the balancer and harmonic sections
BROKEN = ("foot_mount_case3", "scenario_case3_steady", "balancer_rigid_rotor",
          "sleeve_bearing_motor_velocity", "scenario_active_bearing", "roller_bearing_stability",
          "scenario_harmonic_case2_steady")
REGENERATE = "rotor-avc config reference --out docs/config-reference.md"


@pytest.fixture(scope="module")
def validator():
    return Draft202012Validator(schema())


def resolved(name: str) -> dict:
    return json.loads(json.dumps(nested(load_resolved(name)[1])))


def check(path, capsys) -> tuple[int, str, str]:
    status = main(["config", "check", str(path)])
    out, err = capsys.readouterr()
    return status, out, err


def test_schema_is_a_valid_draft_2020_12_schema():
    Draft202012Validator.check_schema(schema())
    assert set(FILL_FROM) == set(MODELS)


@pytest.mark.parametrize("name", SHIPPED)
def test_a_shipped_config_resolved_is_valid_and_builds_the_same_machine(name, validator):
    doc = resolved(name)
    errors = [f"{e.json_path}: {e.message}" for e in validator.iter_errors(doc)]
    assert not errors, errors
    again = machine_from_config(doc, "resolved")            # the defaults filled are the product's
    if "simulation" in doc:
        scenario_from_machine(again)
    plant = load_machine(name).plant
    arrays = {k: v for k, v in vars(plant).items() if isinstance(v, np.ndarray)}
    assert arrays and all(np.array_equal(v, getattr(again.plant, k)) for k, v in arrays.items())


@pytest.mark.parametrize("name", FRAGMENTS)
def test_a_fragment_is_refused_by_check_in_one_line(name, capsys):
    status, out, err = check(name, capsys)
    assert status == 2 and out == "" and err.count("\n") == 1 and "missing" in err


# -- broken documents: the schema and the product refuse them alike ---------------------------
def _misspelt(key: str) -> str:
    return key[:-2] + key[-1] + key[-2]


def _target(name: str, doc: dict):
    """The part broken: the family's keys where declared, else the shared `analysis:`."""
    lang = language(doc["model"])
    fam = family(doc["model"])
    keys = list(fam.children) if declared(fam) else ["analysis"]
    return [(k, lang.children[k]) for k in keys if k in doc and lang.children[k].kind == SECTION]


def _numbers(node, doc, path=()):
    for key, child in node.children.items():
        if key in doc and child.kind == SECTION and isinstance(doc[key], dict):
            yield from _numbers(child, doc[key], path + (key,))
        elif key in doc and child.kind == VALUE and child.schema.get("type") in ("number",
                                                                                  "integer"):
            yield path + (key,), child


def _broken(name: str, case: str) -> tuple[dict, tuple]:
    """A resolved shipped config broken as ``case`` says, and the key path at fault."""
    doc = resolved(name)
    key, part = _target(name, doc)[0]
    if case == "misspelt_depth_1":
        doc[_misspelt(key)] = doc.pop(key)
        return doc, (_misspelt(key),)
    if case == "misspelt_depth_2":
        child = next(iter(doc[key]))
        doc[key][_misspelt(child)] = doc[key].pop(child)
        return doc, (key, _misspelt(child))
    numbers = [(path, node) for k, p in _target(name, doc) for path, node in _numbers(p, doc[k], (k,))]
    if case == "string_for_number":
        path, node = numbers[0]
        value = "12 " + (node.unit or "kg")
    else:
        path, node = next((p, n) for p, n in numbers if {"exclusiveMinimum", "minimum", "maximum"}
                          & set(n.schema))
        s = node.schema
        value = (s["maximum"] + 1 if "maximum" in s else
                 s.get("minimum", s.get("exclusiveMinimum", 0)) - 1)
    section = doc
    for k in path[:-1]:
        section = section[k]
    section[path[-1]] = value
    return doc, path


@pytest.mark.parametrize("case", ["misspelt_depth_1", "misspelt_depth_2", "string_for_number",
                                  "out_of_bounds"])
@pytest.mark.parametrize("name", BROKEN)
def test_a_broken_config_fails_the_schema_and_the_product(name, case, validator, tmp_path, capsys):
    doc, path = _broken(name, case)
    parent = path[:-1] if case.startswith("misspelt") else path
    errors = list(validator.iter_errors(doc))
    assert any(tuple(e.absolute_path)[:len(parent)] == parent for e in errors), \
        [f"{e.json_path}: {e.message}" for e in errors]
    file = tmp_path / "broken.yaml"
    file.write_text(yaml.safe_dump(doc))
    status, out, err = check(file, capsys)
    assert status == 2 and out == "" and err.count("\n") == 1
    assert ".".join(path) in err
    if case.startswith("misspelt"):
        assert "did you mean" in err


# -- check and show ----------------------------------------------------------------------------
def _line_of(file: str, key: str) -> int:
    lines = (ROOT / "config" / file).read_text().splitlines()
    return next(i for i, text in enumerate(lines, 1) if text.startswith(f"{key}:"))


def test_check_lists_every_key_with_its_unit_and_origin(capsys):
    status, out, _ = check(ROOT / "config" / "scenario_case3_steady.yaml", capsys)
    assert status == 0 and ": valid (" in out.splitlines()[0]
    rows = {line.split()[0]: line for line in out.splitlines()[2:]}
    assert rows["model"].split()[-1] == f"foot_mount_common.yaml:{_line_of('foot_mount_common.yaml', 'model')}"
    assert rows["name"].split()[-1] == f"foot_mount_case3.yaml:{_line_of('foot_mount_case3.yaml', 'name')}"
    assert rows["simulation.duration_s"].split()[1:] == [
        "2.0", "s", f"scenario_case3_steady.yaml:{_line_of('scenario_case3_steady.yaml', 'simulation') + 2}"]
    assert rows["analysis.stability.max_iter"].split()[1:] == ["50", "default"]
    assert rows["machine.stator_mass_kg"].split()[2] == "kg"


def test_check_json_is_the_resolved_configuration(capsys, validator):
    assert main(["config", "check", "scenario_case3_steady", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc == resolved("scenario_case3_steady") and validator.is_valid(doc)
    assert doc["simulation"]["speed"] == {"type": "constant", "speed_hz": 20.0}
    assert doc["analysis"]["worst_case"]["max_iter"] == 20 and "include" not in doc


@pytest.mark.parametrize("path, shown", [("simulation.speed.type", "stepped"),
                                         ("simulation.speed.speeds_hz.1", "20.0"),
                                         ("analysis.worst_case", '{"n_modes": 6, '
                                          '"rel_change_tol": 0.05, "max_iter": 20}')])
def test_show_prints_one_resolved_value(path, shown, capsys):
    assert main(["config", "show", "scenario_case3_stepped", "--path", path]) == 0
    assert capsys.readouterr().out == shown + "\n"


def test_show_refuses_a_path_that_is_not_there(capsys):
    assert main(["config", "show", "scenario_case3_stepped", "--path", "simulation.sped"]) == 2
    err = capsys.readouterr().err
    assert "simulation.sped: no key 'sped' in simulation" in err and "use one of:" in err


# -- new ---------------------------------------------------------------------------------------
def _fill(template_data: dict, source: dict) -> None:
    for key, value in template_data.items():
        if value is None or value == REQUIRED_MAPPING:
            template_data[key] = source[key]
        elif isinstance(value, dict) and isinstance(source.get(key), dict):
            _fill(value, source[key])


def _set(doc: dict, path: list[str], source: dict) -> None:
    for key in path[:-1]:
        doc, source = doc.setdefault(key, {}), source[key]
    doc[path[-1]] = source[path[-1]]


@pytest.mark.parametrize("model", MODELS)
def test_new_writes_a_template_that_checks_once_its_required_values_are_filled(
        model, tmp_path, capsys, validator):
    out = tmp_path / "new.yaml"
    assert main(["config", "new", model, "--out", str(out)]) == 0
    text = out.read_text()
    assert "# REQUIRED" in text and "# yaml-language-server: $schema=" in text
    status, _, err = check(out, capsys)
    assert status == 2 and "must be" in err                 # the placeholders fail
    data = yaml.safe_load(text)
    source = resolved(FILL_FROM[model])
    _fill(data, source)
    for _ in range(5):   # keys an option's value needs (kind: soft -> stiffness): as check asks
        out.write_text(yaml.safe_dump(data, sort_keys=False))
        status, _, err = check(out, capsys)
        if "missing" not in err:
            break
        _set(data, re.search(r"new\.yaml: ([\w.]+): missing", err).group(1).split("."), source)
    assert status == 0, err
    assert validator.is_valid(data)
    assert main(["config", "new", model, "--out", str(out)]) == 2      # never overwrites
    assert "exists" in capsys.readouterr().err


# -- parts not declared yet --------------------------------------------------------------------
def test_a_family_not_declared_yet_is_open_and_has_no_template(monkeypatch, capsys):
    doc = resolved("balancer_rigid_rotor")
    module = __import__(MODELS["rigid_rotor"], fromlist=["MODEL_SETTINGS"])
    monkeypatch.delattr(module, "MODEL_SETTINGS")
    s = schema()
    Draft202012Validator.check_schema(s)
    v = Draft202012Validator(s)
    doc["rotor"]["lenght_m"] = doc["rotor"].pop("length_m")        # open: accepted
    assert v.is_valid(doc)
    doc["rotorr"] = doc.pop("rotor")                                # the keys are still known
    assert not v.is_valid(doc)
    assert "### `model: rigid_rotor`" in reference_document()
    assert "Not declared yet (keys `rotor`, `bearings`, `output`)" in reference_document()
    assert main(["config", "new", "rigid_rotor"]) == 2
    assert "not declared yet" in capsys.readouterr().err


@pytest.mark.parametrize("path", list(config_schema.DECLARED_ELSEWHERE))
def test_a_part_declared_elsewhere_is_an_open_mapping_until_declared(path, monkeypatch, validator):
    doc = resolved("scenario_case3_steady" if path == "controllers" else "scenario_strategies_runup")
    section = doc
    for key in path.split("."):
        section = section[key]
    (next(iter(section.values())) if path == "controllers" else section)["bogus_key"] = 1
    assert not validator.is_valid(doc)                      # declared: the key is refused
    module, name = config_schema.DECLARED_ELSEWHERE[path]
    monkeypatch.delattr(__import__(module, fromlist=[name]), name)
    s = schema()
    Draft202012Validator.check_schema(s)
    assert Draft202012Validator(s).is_valid(doc)            # not declared yet: open
    reference = reference_document()
    assert (f"not declared yet: read by {module})" in reference
            or f"Not declared yet; read by `{module}`." in reference)


# -- the schema and reference files ------------------------------------------------------------
def test_schema_command_writes_the_schema(tmp_path, capsys):
    out = tmp_path / "schema.json"
    assert main(["config", "schema", "--out", str(out)]) == 0
    assert json.loads(out.read_text()) == schema()


def test_the_reference_is_generated_from_the_declarations():
    text = (ROOT / "docs" / "config-reference.md").read_text()
    assert text == reference_document(), (
        f"docs/config-reference.md differs from the declarations; regenerate it: {REGENERATE}")
