"""The README's command blocks work as written: every `rotor-avc` line parses with the current
command line (options, choices, shipped config names), and the blocks that need nothing but this
repository run from top to bottom in a fresh folder (exit 0), as does the Python example."""
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from rotor_avc.cli import build_parser
from rotor_avc.config import find_config

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"

#: files a reader brings (their own machine, map and recordings): parsed, not run
USER_FILES = {"machine.yaml", "my_machine.yaml", "sensors.yaml", "recording/", "stepped/",
              "runup/", "out/calibration/calibrated.yaml", "bags/run.mcap"}
#: lines run end-to-end, in order, in one fresh folder (each needs only what a line above made)
RUN = ["rotor-avc simulate scenario_case3_stepped --out run.mcap",
       "rotor-avc compare run.mcap --out out/compare",
       "rotor-avc config check scenario_case3_steady",
       "rotor-avc config show scenario_case3_stepped --path simulation.speed.speeds_hz.1",
       "rotor-avc config new foot_mount_3d --out my_machine.yaml",
       "rotor-avc config schema --out rotor_avc.schema.json",
       "rotor-avc run scenario_case3_steady --list-params"]


def blocks(language: str) -> list[str]:
    """The README's fenced blocks of one language."""
    return re.findall(rf"^```{language}\n(.*?)^```", README.read_text(), re.S | re.M)


def command_lines() -> list[list[str]]:
    """Every command of the shell blocks: continuations joined, comments and `&` dropped."""
    out = []
    for block in blocks("sh") + blocks("bash"):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words and words[-1] == "&":
                words = words[:-1]
            if words:
                out.append(words)
    return out


def test_the_readme_has_the_commands_this_test_runs():
    lines = [" ".join(w) for w in command_lines()]
    missing = [r for r in RUN if r not in lines]
    assert not missing, f"README lines changed: {missing}"


@pytest.mark.parametrize("words", [w for w in command_lines() if w[0] == "rotor-avc"],
                         ids=lambda w: " ".join(w[1:4]))
def test_every_rotor_avc_line_parses(words):
    argv = words[1:]
    args = build_parser(argv[0]).parse_args(argv)          # SystemExit(2) on any drift
    for name in ("config", "scenario", "target"):
        value = getattr(args, name, None)
        if isinstance(value, str) and value not in USER_FILES and value not in (
                "robustness", "gains"):
            find_config(value)                               # a shipped name or a file


def test_the_self_contained_lines_run_in_a_fresh_folder(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    for line in RUN:
        argv = shlex.split(line)
        r = subprocess.run([sys.executable, "-m", "rotor_avc", *argv[1:]], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=900)
        assert r.returncode == 0, f"{line}\n{r.stderr[-2000:]}"
    assert (tmp_path / "out/compare/index.html").is_file()
    assert (tmp_path / "my_machine.yaml").is_file()


def test_the_python_example_runs(tmp_path):
    (code,) = blocks("python")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=600, env=dict(os.environ, MPLBACKEND="Agg"))
    assert r.returncode == 0, r.stderr[-2000:]
    assert re.fullmatch(r"-\d.*1/s \(600,\) \d+\n", r.stdout)
