"""The package builds with colcon as an ament_python package, and every node is found the way
``ros2 run rotor_avc <node>`` finds it (ament index prefix + ``lib/rotor_avc/<exe>``) and starts,
with its config found in the colcon install layout; started together, each is ready (in the ROS
graph) and ends on SIGTERM with status 0."""
import ast
import os
import re
import shutil
import signal
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

pytest.importorskip("colcon_core", reason="colcon-core is not installed (pip install colcon-core)")
pytest.importorskip("colcon_ros", reason="colcon-ros is not installed (pip install colcon-ros)")
ament_packages = pytest.importorskip("ament_index_python.packages")
from ros_helpers import wait_for_nodes  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: the node list setup.py installs (read, not imported: importing setup.py would run setup())
NODES = ast.literal_eval(re.search(r"^NODES = (\[.*?\])", (ROOT / "setup.py").read_text(),
                                   re.M | re.S).group(1))

pytestmark = pytest.mark.ros

NODE_ARGS = {
    "plant_simulator": ["-p", "scenario:=scenario_case3_steady"],
    "foot_controller": ["-p", "scenario:=scenario_case3_steady", "-p", "foot_id:=DL"],
    "balancer": ["-p", "scenario:=scenario_balance_runup"],
    "synchronous_controller": ["-p", "scenario:=scenario_active_bearing"],
    "harmonic_controller": ["-p", "scenario:=scenario_harmonic_case2_steady"],
    "recorder": ["-p", "scenario:=scenario_case3_steady", "-p", "path:={tmp}/colcon.mcap"],
}


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    ws = tmp_path_factory.mktemp("colcon_ws")
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                           check=True).stdout.split()
    for rel in files:
        dst = ws / "src" / "rotor_avc" / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / rel, dst)
    colcon = shutil.which("colcon", path=str(Path(sys.executable).parent)) or shutil.which("colcon")
    r = subprocess.run([colcon, "build", "--base-paths", "src"], cwd=ws, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    return ws


def ros2_run_env(ws: Path) -> dict:
    prefix = ws / "install" / "rotor_avc"
    site = Path(sysconfig.get_paths()["purelib"]).relative_to(sys.prefix)
    return dict(os.environ, AMENT_PREFIX_PATH=str(prefix),
                PYTHONPATH=str(prefix / site) + os.pathsep + os.environ.get("PYTHONPATH", ""))


def test_install_layout(workspace):
    prefix = workspace / "install" / "rotor_avc"
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "rotor_avc").is_file()
    assert (prefix / "share" / "rotor_avc" / "package.xml").is_file()
    assert (prefix / "share" / "rotor_avc" / "config" / "foot_mount_case3.yaml").is_file()
    assert (prefix / "share" / "rotor_avc" / "launch" / "rotor_avc.launch.py").is_file()
    assert (prefix / "share" / "rotor_avc" / "layouts" / "rotor_avc.foxglove.json").is_file()
    assert (prefix / "share" / "rotor_avc" / "layouts" / "rotor_avc.plotjuggler.xml").is_file()
    env = ros2_run_env(workspace)
    r = subprocess.run([sys.executable, "-c", "import rotor_avc.config as c; print(c.__file__); "
                        "print(c.find_config('scenario_case3_steady'))"], cwd=workspace, env=env,
                       capture_output=True, text=True, check=True)
    module, config = r.stdout.split()
    assert module.startswith(str(prefix)) and config.startswith(str(prefix / "share"))


def test_every_node_is_found_by_ros2_run_lookup_and_starts(workspace, tmp_path):
    env = ros2_run_env(workspace)
    lookup = ("import sys; from ament_index_python.packages import get_package_prefix; "
              "print(get_package_prefix('rotor_avc'))")
    prefix = subprocess.run([sys.executable, "-c", lookup], env=env, capture_output=True,
                            text=True, check=True).stdout.strip()
    procs = {}
    for node in NODES:
        exe = Path(prefix) / "lib" / "rotor_avc" / node
        assert exe.is_file() and os.access(exe, os.X_OK), exe
        args = [a.format(tmp=tmp_path) for a in NODE_ARGS[node]]
        procs[node] = subprocess.Popen([str(exe), "--ros-args", *args], cwd=tmp_path, env=env,
                                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    ready = wait_for_nodes(NODES, timeout_s=180, procs=procs.values())
    outputs = {}
    for node, proc in procs.items():
        alive = proc.poll() is None
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=30)
        outputs[node] = (alive, proc.returncode, out)
    assert ready, {node: out for node, (_, _, out) in outputs.items()}
    for node, (alive, code, out) in outputs.items():
        assert alive, f"{node} exited early: {out}"
        assert code == 0 and "Traceback" not in out, f"{node}: {out}"
    assert (tmp_path / "colcon.mcap").stat().st_size > 0
