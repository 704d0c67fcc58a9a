"""A node parameter of the wrong type -- a string where a double is declared, an integer where a
string or a double is, a double where an integer is, an array, a word where a bool is -- is
refused in one line naming the parameter, the type it must have and a value of that type to
give (``-p name:=value``), with exit status 2 and no traceback, on the command line and as a
programmatic override."""
import os
import subprocess
import sys

import pytest

from ros_helpers import ROOT, params, rclpy  # noqa: F401  (skips without rclpy)

from rotor_avc.nodes.foot_controller import FootController
from rotor_avc.nodes.plant_simulator import PlantSimulator
from rotor_avc.nodes.recorder import Recorder
from rotor_avc.nodes.runtime import ParameterError

pytestmark = pytest.mark.ros
SCENARIO = "scenario_case3_steady"


@pytest.fixture(scope="module", autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


@pytest.mark.parametrize("node,overrides,expected", [
    (FootController, {"max_stamp_jump_s": "abc"},
     "parameter 'max_stamp_jump_s' must be a double (got the string 'abc') -- fix: "
     "-p max_stamp_jump_s:=1.0 (a number with a decimal point;"),
    (FootController, {"max_stamp_jump_s": 2},
     "parameter 'max_stamp_jump_s' must be a double (got the integer 2) -- fix: "
     "-p max_stamp_jump_s:=2.0"),
    (FootController, {"foot_id": 5},
     "parameter 'foot_id' must be a string (got the integer 5) -- fix: -p foot_id:=\"'5'\" "
     "(quoted, or ROS reads it as an integer;"),
    (FootController, {"imu_sign": 1.5},
     "parameter 'imu_sign' must be an integer (got the double 1.5) -- fix: -p imu_sign:=1 "
     "(a whole number;"),
    (FootController, {"resync_samples": [1, 2]},
     "parameter 'resync_samples' must be an integer (got the array [1, 2]) -- fix: "
     "-p resync_samples:=10"),
    (FootController, {"measurement_qos": 3},
     "parameter 'measurement_qos' must be a string (got the integer 3) -- fix: "
     "-p measurement_qos:=auto (one of: auto, sensor_data, reliable, lockstep;"),
    (PlantSimulator, {"exit_when_done": "abc"},
     "parameter 'exit_when_done' must be a bool (got the string 'abc') -- fix: "
     "-p exit_when_done:=true (true or false;"),
    (Recorder, {"chunk_size_bytes": "big"},
     "parameter 'chunk_size_bytes' must be an integer (got the string 'big') -- fix: "
     "-p chunk_size_bytes:=1048576 (a whole number;"),
])
def test_wrong_type_is_refused_by_name_type_and_fix(node, overrides, expected):
    base = {"scenario": SCENARIO, "foot_id": "DL", "path": "/nonexistent/never_written.mcap"}
    names = {FootController: ("scenario", "foot_id"), PlantSimulator: ("scenario",),
             Recorder: ("scenario", "path")}[node]
    values = {k: base[k] for k in names} | overrides
    with pytest.raises(ParameterError) as info:
        node("param_types", parameter_overrides=params(**values))
    text = str(info.value)
    assert text.startswith("param_types: ") and expected in text, text
    assert "\n" not in text


@pytest.mark.parametrize("module,args,expected", [
    ("foot_controller", ["-p", "foot_id:=DL", "-p", "max_stamp_jump_s:=abc"],
     "parameter 'max_stamp_jump_s' must be a double (got the string 'abc')"),
    ("foot_controller", ["-p", "foot_id:=5"],
     "parameter 'foot_id' must be a string (got the integer 5) -- fix: -p foot_id:=\"'5'\""),
    ("plant_simulator", ["-p", "duration_s:=1"],
     "parameter 'duration_s' must be a double (got the integer 1) -- fix: -p duration_s:=1.0"),
])
def test_command_line_type_error_is_one_line_and_exit_status_2(module, args, expected):
    proc = subprocess.run([sys.executable, "-m", f"rotor_avc.nodes.{module}", "--ros-args",
                           "-p", f"scenario:={SCENARIO}", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=300, env=dict(os.environ, PYTHONUNBUFFERED="1"))
    lines = [line for line in (proc.stdout + proc.stderr).splitlines() if line.strip()]
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert len(lines) == 1 and lines[0].startswith(f"error: {module}: "), lines
    assert expected in lines[0] and "Traceback" not in lines[0], lines
