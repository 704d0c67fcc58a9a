"""Bad configurations each give a clear error naming the field and the fix -- never a traceback
from deep inside numpy and never silently wrong numbers."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from rotor_avc.config import find_config
from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.machine import load_machine
from rotor_avc.models.plant import LinearPlant


def _case3(tmp_path: Path) -> dict:
    cfg = {}
    for name in ("foot_mount_common.yaml", "foot_mount_case2.yaml", "foot_mount_case3.yaml"):
        data = yaml.safe_load(find_config(name).read_text())
        data.pop("include", None)
        cfg = _merge(cfg, data)
    return cfg


def _merge(a, b):
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _set(cfg, path, value):
    keys = path.split(".")
    for k in keys[:-1]:
        cfg = cfg[k]
    if value is _DELETE:
        del cfg[keys[-1]]
    else:
        cfg[keys[-1]] = value


_DELETE = object()

CASES = [
    # (path, value, field named in the message, words in the message)
    ("machine.stator_mass_kg", _DELETE, "machine.stator_mass_kg", "missing"),
    ("machine.rotor_mass_kg", -1900.0, "machine.rotor_mass_kg", "> 0"),
    ("machine.rotor_mass_kg", 0.0, "machine.rotor_mass_kg", "> 0"),
    ("foundation.stiffness_n_per_m.z", "1.44e9 N/m", "foundation.stiffness_n_per_m.z", "number"),
    ("foundation.stiffness_n_per_m.y", -2.05e7, "foundation.stiffness_n_per_m.y", "> 0"),
    ("foundation.tan_delta", 4.0, "foundation.tan_delta", "loss factor"),
    ("elements.actuator.stiffness_n_per_m.z", float("nan"), "elements.actuator.stiffness_n_per_m.z", "finite"),
    ("machine.foot_axial_arm_m", 0.7, "machine.foot_axial_arm_m", "mapping"),
    ("machine.stator_mass", 7200.0, "machine.stator_mass", "unknown key"),
    ("feet.NR", "spring", "feet.NR", "unknown value"),
    ("mounting", "glued", "mounting", "unknown value"),
    ("model", "no_such_model", "model", "unknown value"),
    ("controllers.XX", {"type": "I", "feedback": "acceleration", "ki": 1e5}, "controllers.XX", "unknown foot"),
    ("controllers.NR", {"type": "I", "feedback": "acceleration", "ki": 1e5}, "controllers.NR", "without an actuator"),
    ("controllers.DL", {"type": "I", "ki": 1e5}, "controllers.DL.feedback", "missing"),
    ("controllers.DL", {"type": "I", "feedback": "jerk", "ki": 1e5}, "controllers.DL.feedback", "unknown value"),
    ("controllers.DL", {"type": "tf", "feedback": "velocity", "num": [1.0, 2.0, 3.0], "den": [1.0, 5.0]},
     "controllers.DL", "improper"),
    ("controllers.DL", {"type": "PD", "feedback": "acceleration", "kp": 1.0, "kd": 1.0},
     "controllers.DL", "jerk"),
    ("controllers.DL", {"type": "tf", "feedback": "velocity", "num": [".nan"], "den": [1.0, 5.0]},
     "controllers.DL.num[0]", "number"),
    ("controllers.DL", {"type": "I", "feedback": "acceleration", "ki": 1e5, "kp": 3.0},
     "controllers.DL.kp", "unknown key"),
    ("controllers.DL", {"type": "I", "feedback": "acceleration", "ki": 1e5, "leak_hz": -0.5},
     "controllers.DL.leak_hz", "> 0"),
]


@pytest.mark.parametrize("path,value,field,words", CASES)
def test_bad_config_is_refused_clearly(tmp_path, path, value, field, words):
    cfg = _case3(tmp_path)
    _set(cfg, path, value)
    f = tmp_path / "bad.yaml"
    f.write_text(yaml.safe_dump(cfg))
    with pytest.raises(ConfigError) as info:
        load_machine(f)
    msg = str(info.value)
    assert field in msg and words in msg, msg
    assert "bad.yaml" in msg


def test_include_problems(tmp_path):
    (tmp_path / "a.yaml").write_text("include: missing.yaml\n")
    with pytest.raises(ConfigError, match="missing.yaml"):
        load_machine(tmp_path / "a.yaml")
    (tmp_path / "b.yaml").write_text("include: c.yaml\n")
    (tmp_path / "c.yaml").write_text("include: b.yaml\n")
    with pytest.raises(ConfigError, match="cycle"):
        load_machine(tmp_path / "b.yaml")
    (tmp_path / "d.yaml").write_text("model: [unclosed\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_machine(tmp_path / "d.yaml")


def test_singular_mass_matrix_is_refused():
    n = 2
    z = np.zeros((n, n))
    with pytest.raises(ModelError, match="mass matrix is singular"):
        LinearPlant("bad", ("a", "b"), np.diag([1.0, 0.0]), np.eye(n), z, z, z, z, (), (), (), 1.0)


def test_cli_reports_error_without_traceback(tmp_path):
    f = tmp_path / "bad.yaml"
    f.write_text("include: " + str(find_config("foot_mount_case2.yaml")) + "\n"
                 "machine: {rotor_mass_kg: -3}\n")
    r = subprocess.run([sys.executable, "-m", "rotor_avc", "poles", str(f)],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert "machine.rotor_mass_kg" in r.stderr and "Traceback" not in r.stderr


def test_a_misspelt_key_is_answered_with_the_closest_valid_key(tmp_path):
    from rotor_avc.config import load_yaml
    from rotor_avc.machine import machine_from_config
    data = load_yaml(find_config("foot_mount_case3"))
    data["foundation"]["stifness_n_per_m"] = data["foundation"].pop("stiffness_n_per_m")
    with pytest.raises(ConfigError, match=r"foundation.stifness_n_per_m: unknown key \(did you "
                                          r"mean 'stiffness_n_per_m'\?\)"):
        machine_from_config(data, "misspelt")
