"""Every section of every shipped config refuses a misspelt key, naming it; the README's
configuration reference is the one generated from the settings declarations."""
import copy
from pathlib import Path

import pytest

from rotor_avc.analysis.active_bearing_ff import feedforward_method
from rotor_avc.analysis.stability_study import study_from_config, with_variants
from rotor_avc.balancing.scenario import machine_setup, rigid_setup
from rotor_avc.config import Section, load_yaml
from rotor_avc.errors import ConfigError
from rotor_avc.machine import machine_from_section
from rotor_avc.model_config.active_bearing import piezo_from_config, unbalance_kg_m
from rotor_avc.scenario import scenario_from_machine
from rotor_avc.settings import reference_markdown

ROOT = Path(__file__).resolve().parents[1]
#: one config per model and per kind of section (simulation, balancer, variants and studies)
CONFIGS = ("foot_mount_case1", "foot_mount_case3", "scenario_case3_stepped", "scenario_balance_runup",
           "sleeve_bearing_motor", "scenario_active_bearing", "roller_bearing_stability",
           "balancer_rigid_rotor")
MISSPELT = "damping_flor_hz"


def read_everything(data: dict, source: str) -> None:
    """Every reader of a config's sections, as the commands call them."""
    cfg = Section(data, "", source)
    for name in cfg.section("variants", {}).keys():
        machine_from_section(with_variants(cfg, [name]))
    for name in cfg.section("studies", {}).keys():
        machine_from_section(study_from_config(cfg, name)[0])
    machine = machine_from_section(cfg)
    if data["model"] == "rigid_rotor":
        rigid_setup(cfg)
        return
    if "simulation" in data:
        scenario_from_machine(machine)
    if "balancer" in data:
        machine_setup(machine)
    if data["model"] == "active_bearing":
        unbalance_kg_m(cfg), piezo_from_config(cfg), feedforward_method(cfg)


def mappings(data: dict, path=()):
    yield path
    for key, value in data.items():
        if isinstance(value, dict):
            yield from mappings(value, path + (key,))


def cases():
    for name in CONFIGS:
        data = load_yaml(ROOT / "config" / f"{name}.yaml")
        for path in mappings(data):
            if path in (("variants",), ("studies",)) or path[:1] == ("variants",):
                continue           # named entries, and config paths (their own test below)
            yield pytest.param(name, data, path, id=".".join((name,) + path))


@pytest.mark.parametrize("name, data, path", list(cases()))
def test_misspelt_key_is_refused_naming_it(name, data, path):
    bad = copy.deepcopy(data)
    section = bad
    for key in path:
        section = section[key]
    section[MISSPELT] = 1.0
    with pytest.raises(ConfigError, match=f"{MISSPELT}: unknown"):
        read_everything(bad, name)


@pytest.mark.parametrize("name", CONFIGS)
def test_shipped_configs_read_cleanly(name):
    read_everything(load_yaml(ROOT / "config" / f"{name}.yaml"), name)


def test_variant_with_misspelt_path_is_refused():
    data = load_yaml(ROOT / "config" / "roller_bearing_stability.yaml")
    variant = next(iter(data["variants"].values()))
    variant[f"analysis.{MISSPELT}"] = 1.0
    with pytest.raises(ConfigError, match=MISSPELT):
        read_everything(data, "roller_bearing_stability")


def test_readme_reference_is_generated_from_the_declarations():
    readme = (ROOT / "README.md").read_text()
    assert reference_markdown() in readme, (
        "README's configuration reference differs from rotor_avc.settings; regenerate it: "
        'python -c "from rotor_avc.settings import reference_markdown; print(reference_markdown())"')


def test_a_capability_the_model_lacks_is_refused_naming_the_models_that_have_it():
    sleeve = load_yaml(ROOT / "config" / "sleeve_bearing_motor.yaml")
    sleeve["balancer"] = load_yaml(ROOT / "config" / "balancer_foot_mount.yaml")["balancer"]
    with pytest.raises(ConfigError, match="balancer: model sleeve_bearing_motor has no one-plane.*"
                                          "fix: use it with model: foot_mount_3d"):
        machine_setup(machine_from_section(Section(sleeve, "", "sleeve")))
    feet = load_yaml(ROOT / "config" / "scenario_case3_steady.yaml")
    feet["simulation"]["feedforward"] = {"type": "synchronous"}
    with pytest.raises(ConfigError, match="feedforward.type: .*fix: use it with model: active_bearing"):
        scenario_from_machine(machine_from_section(Section(feet, "", "case3")))


def test_the_readmes_python_example_runs():
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("### Model your own machine"):]
    code = section[section.index("```python\n") + 10:section.index("```\n\n")]
    assert "load_machine" in code and len(code.splitlines()) <= 12
    exec(compile(code, "README.md (Python example)", "exec"), {})
