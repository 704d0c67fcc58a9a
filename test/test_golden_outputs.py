"""Golden outputs: what the commands print and write for the shipped configurations, against the
files in ``test/golden/`` -- so a refactoring that should not change the physics shows that it
did not. Numbers agree to 1e-9 relative (the last bits may differ between LAPACK builds), text
exactly. After a deliberate change of the physics, regenerate with ``pytest
test/test_golden_outputs.py --update-golden`` and review the diff of ``test/golden/``.

Commands: ``poles --json`` of every shipped machine, ``config check --json`` (the resolved
configuration) of every shipped file, ``campbell --json``, ``api684 --json``, ``stability
--json``, the CSV of ``frf``, and ``metrics.json`` of ``compare`` on the committed reference bag
(its checks and 1x table)."""
import csv
import io
import json
import math
from contextlib import redirect_stdout
from pathlib import Path

import pytest

from rotor_avc.cli import main

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = Path(__file__).resolve().parent / "golden"
CONFIGS = sorted(p.stem for p in (ROOT / "config").glob("*.yaml"))
#: files that are not whole machines: parts included by others, ROS parameter files
PARTS = ("harmonic_bearings", "foot_mount_common", "ros_case3")
MACHINES = [c for c in CONFIGS if c not in PARTS]
RTOL = 1e-9


def _printed(args) -> dict:
    out = io.StringIO()
    with redirect_stdout(out):
        status = main(args)
    assert status == 0, args
    return json.loads(out.getvalue())


def _csv(path: Path) -> list[dict]:
    return list(csv.DictReader(path.open()))


def _close(a, b, where: str) -> None:
    if isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a) == sorted(b), (where, sorted(a), b)
        for key in a:
            _close(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), (where, len(a), b)
        for i, (x, y) in enumerate(zip(a, b)):
            _close(x, y, f"{where}[{i}]")
    elif isinstance(a, str) and isinstance(b, str):
        try:
            x, y = float(a), float(b)
        except ValueError:
            assert a == b, (where, a, b)
        else:
            _close(x, y, where)
    elif isinstance(a, (int, float)) and not isinstance(a, bool):
        assert isinstance(b, (int, float)), (where, a, b)
        if math.isnan(a) or math.isinf(a):
            assert str(a) == str(b), (where, a, b)
        else:
            assert math.isclose(a, b, rel_tol=RTOL, abs_tol=1e-300), (where, a, b)
    else:
        assert a == b, (where, a, b)


def check_golden(name: str, value, request) -> None:
    path = GOLDEN / f"{name}.json"
    if request.config.getoption("--update-golden"):
        GOLDEN.mkdir(exist_ok=True)
        path.write_text(json.dumps(value, indent=1, sort_keys=True) + "\n")
        return
    assert path.is_file(), f"no golden output {path.name}: run with --update-golden"
    _close(json.loads(path.read_text()), json.loads(json.dumps(value)), name)


@pytest.mark.parametrize("config", MACHINES)
def test_poles(config, request):
    check_golden(f"poles_{config}", _printed(["poles", config, "--json"]), request)


@pytest.mark.parametrize("config", CONFIGS)
def test_resolved_configuration(config, request):
    data = _printed(["config", "check", config, "--json"]) if config not in PARTS else None
    if data is not None:
        check_golden(f"config_{config}", data, request)


@pytest.mark.parametrize("args", [
    ["campbell", "foot_mount_case2", "--speed-hz", "0:100:11"],
    ["campbell", "sleeve_bearing_motor_velocity", "--speed-hz", "5:75:8"],
    ["api684", "foot_mount_case3", "--operating-hz", "40:60", "--speed-hz", "1:120:240"],
    ["api684", "sleeve_bearing_motor", "--operating-hz", "50:60", "--speed-hz", "5:75:141"],
    ["stability", "roller_bearing_stability"],
], ids=lambda a: "_".join(a[:2]))
def test_analysis_commands(args, request):
    check_golden("_".join(args[:2]), _printed(args + ["--json"]), request)


@pytest.mark.parametrize("config", ["foot_mount_case3", "sleeve_bearing_motor_velocity",
                                    "active_bearing"])
def test_frf_csv(config, tmp_path, request):
    assert main(["frf", config, "--speed-hz", "2:100:50", "--out", str(tmp_path / "frf")]) == 0
    check_golden(f"frf_{config}", _csv(tmp_path / "frf" / "frf.csv"), request)


def test_compare_of_the_reference_bag(tmp_path, request):
    bag = ROOT / "bags" / "reference" / "case3_stepped.mcap"
    assert main(["compare", str(bag), "--out", str(tmp_path / "c")]) == 0
    metrics = json.loads((tmp_path / "c" / "metrics.json").read_text())
    kept = {key: metrics[key] for key in ("checks", "verdict", "one_x") if key in metrics}
    check_golden("compare_case3_stepped", kept, request)
