"""The package is a proper ament_python package and installs with pip; its config is found in
every layout (colcon, pip install ., editable, source tree)."""
import configparser
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from rotor_avc import config as config_mod

ROOT = Path(__file__).resolve().parents[1]


def test_package_xml_is_valid_format3():
    catkin_pkg = pytest.importorskip("catkin_pkg.package")
    pkg = catkin_pkg.parse_package(str(ROOT / "package.xml"))
    pkg.validate()
    assert pkg.package_format == 3 and pkg.name == "rotor_avc"
    deps = {d.name for d in pkg.exec_depends}
    assert {"rclpy", "std_msgs", "geometry_msgs", "sensor_msgs", "rosgraph_msgs", "diagnostic_msgs",
            "python3-numpy", "python3-scipy", "python3-yaml"} <= deps
    assert any("mcap" in d for d in deps)
    assert pkg.get_build_type() == "ament_python"


def test_ament_layout_files():
    assert (ROOT / "resource" / "rotor_avc").is_file()
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    assert cfg["develop"]["script_dir"] == "$base/lib/rotor_avc"
    assert cfg["install"]["install_scripts"] == "$base/lib/rotor_avc"
    for d in ("rotor_avc", "config", "test", "bags", "bench"):
        assert (ROOT / d).is_dir()


def test_config_lookup_order(tmp_path, monkeypatch):
    """ament prefix first, then <sys.prefix>/share/rotor_avc, then the source tree."""
    src = config_mod.find_config("foot_mount_case3")
    assert src.parent == ROOT / "config"
    share = tmp_path / "prefix" / "share" / "rotor_avc" / "config"
    share.mkdir(parents=True)
    (share / "foot_mount_case3.yaml").write_text(src.read_text())
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "prefix"))
    assert config_mod.find_config("foot_mount_case3") == share / "foot_mount_case3.yaml"
    ament = tmp_path / "ament" / "share" / "rotor_avc" / "config"
    ament.mkdir(parents=True)
    (ament / "foot_mount_case3.yaml").write_text(src.read_text())
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "ament"))
    assert config_mod.find_config("foot_mount_case3") == ament / "foot_mount_case3.yaml"


def test_pip_install_finds_installed_config(tmp_path):
    """`pip install .` (not editable) puts config under <prefix>/share/rotor_avc and the console
    script in bin/; the installed package finds its config there, away from the source tree."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    # dependencies come from this interpreter's site-packages (no network, no nested .pth hooks)
    Path(site, "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    # build the wheel with this interpreter (nothing is installed here), install it in the venv
    wheels = tmp_path / "wheels"
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps",
                        "--no-build-isolation", "-w", str(wheels), str(ROOT)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    wheel = next(wheels.glob("rotor_avc-*.whl"))
    r = subprocess.run([str(py), "-m", "pip", "install", "--quiet", "--no-deps", "--no-index",
                        str(wheel)], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (venv / "share" / "rotor_avc" / "config" / "foot_mount_case3.yaml").is_file()
    assert (venv / "share" / "rotor_avc" / "package.xml").is_file()
    assert (venv / "bin" / "rotor-avc").is_file()
    env = dict(os.environ, AMENT_PREFIX_PATH="")
    r = subprocess.run([str(py), "-c", "import rotor_avc.config as c; print(c.__file__); "
                        "print(c.find_config('foot_mount_case3'))"],
                       capture_output=True, text=True, cwd=tmp_path, env=env, check=True)
    module_file, found = r.stdout.split()
    assert str(venv) in module_file
    assert Path(found) == venv / "share" / "rotor_avc" / "config" / "foot_mount_case3.yaml"
    r = subprocess.run([str(venv / "bin" / "rotor-avc"), "poles", "foot_mount_case1", "--json"],
                       capture_output=True, text=True, cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
