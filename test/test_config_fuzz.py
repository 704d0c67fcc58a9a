"""Hostile configurations through the command line, in-process: malformed YAML (every construct
the loader refuses, each named with its file and line) and seeded mutations of the shipped
configs (wrong types, missing keys, huge numbers, NaN and infinity, negative values, deep
nesting). Each case ends in a clear one-line error with exit status 2 -- naming the file -- or in
a run whose output is finite; never in a traceback or a hang."""
import contextlib
import io
import math
import random
from pathlib import Path

import numpy as np
import pytest
import yaml

from rotor_avc.cli import main
from rotor_avc.config import load_yaml
from rotor_avc.yaml_reading import MAX_YAML_DEPTH
from rotor_avc.sim.timeseries import TimeSeries

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted((ROOT / "config").glob("*.yaml"))


def run_cli(argv):
    """``(exit status, stdout, stderr)`` of ``rotor-avc ARGV`` run in this process."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(argv)
        except SystemExit as exc:            # argparse: a usage error
            status = exc.code
    return status, out.getvalue(), err.getvalue()


def _bomb(levels=9, width=10):
    lines = ["  a0: &a0 [" + ", ".join(["x"] * width) + "]"]
    lines += [f"  a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]" for i in range(1, levels)]
    return "description:\n" + "\n".join(lines) + "\nmodel: foot_mount\n"


#: (name, file bytes, the line the error must name, or None for errors without a line)
MALFORMED = [
    ("duplicate key", b"model: foot_mount\nmachine:\n  a: 1\n  a: 2\n", 4),
    ("tab indentation", b"model: foot_mount\nmachine:\n\trotor_mass_kg: 1\n", 3),
    ("undefined alias", b"model: foot_mount\nmachine: *nothing\n", 2),
    ("include: 5", b"include: 5\nmodel: foot_mount\n", 1),
    ("include: [null]", b"model: foot_mount\ninclude: [null]\n", 2),
    ("include: {a: 1}", b"include: {a: 1}\n", 1),
    ("non-UTF-8", b"model: foot_mount\ndescription: \"caf\xe9\"\n", 2),
    ("3000-deep mapping", ("x: " + "{a: " * 3000 + "1" + "}" * 3000 + "\n").encode(), 1),
    ("5000-deep list", ("x: " + "[" * 5000 + "]" * 5000 + "\n").encode(), 1),
    ("200-deep block mapping",
     "".join(" " * i + f"k{i}:\n" for i in range(200)).encode() + b" " * 200 + b"v: 1\n",
     MAX_YAML_DEPTH),
    ("alias bomb under description", _bomb().encode(), None),
    ("deep through aliases", "".join(f"a{i}: &a{i} " + "[" * 40 + (f"*a{i - 1}" if i else "1")
                                     + "]" * 40 + "\n" for i in range(5)).encode(), 2),
    ("recursive anchor", b"model: &m [1, *m]\n", 1),
    ("unclosed flow list", b"model: [foot_mount\nmachine: {}\n", None),
    ("top level a list", b"- a\n- b\n", None),
    ("larger than the size limit", b"# " + b"x" * (2 << 20) + b"\nmodel: foot_mount\n", None),
]


@pytest.mark.parametrize("name,data,line", MALFORMED, ids=[c[0] for c in MALFORMED])
def test_malformed_yaml_gets_file_line_and_fix(tmp_path, monkeypatch, name, data, line):
    monkeypatch.setenv("ROTOR_AVC_MAX_YAML_MB", "1")
    path = tmp_path / "bad.yaml"
    path.write_bytes(data)
    status, _, err = run_cli(["poles", str(path)])
    assert status == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "bad.yaml" in err and "-- fix:" in err, err
    if line is not None:
        assert f"line {line}:" in err, err


# -- seeded mutations of the shipped configs ------------------------------------------------------
def leaves(data, prefix=()):
    """``(path, value)`` of every leaf of a nested mapping (lists are leaves)."""
    for key, value in data.items():
        if isinstance(value, dict) and value:
            yield from leaves(value, prefix + (key,))
        else:
            yield prefix + (key,), value


def deep(depth):
    value = 1.0
    for _ in range(depth):
        value = {"x": value}
    return value


#: mutation name -> new value from the old one (None deletes the key)
MUTATIONS = {
    "string": lambda v: "abc",
    "list": lambda v: [1, 2],
    "mapping": lambda v: {"x": 1},
    "missing": lambda v: None,
    "huge": lambda v: 1.0e308,
    "huge negative": lambda v: -1.0e308,
    "large": lambda v: 1.0e19,
    "times 1e9": lambda v: 1.0e9 * v if isinstance(v, (int, float)) else 1.0e9,
    "NaN": lambda v: math.nan,
    "NaN string": lambda v: "NaN",
    "inf string": lambda v: "inf",
    "negative": lambda v: -abs(v) if isinstance(v, (int, float)) and v else -1.0,
    "zero": lambda v: 0,
    "deep nesting": lambda v: deep(MAX_YAML_DEPTH + 10),
}


def mutated_case(rng: random.Random):
    """A shipped config, flattened (includes merged), with one seeded mutation."""
    source = rng.choice(SHIPPED)
    data = load_yaml(source)
    if "simulation" in data:           # keep the runs short unless the duration is the target
        data["simulation"]["duration_s"] = 0.02
    path, old = rng.choice(list(leaves(data)))
    kind = rng.choice(sorted(MUTATIONS))
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    new = MUTATIONS[kind](old)
    if new is None:
        del parent[path[-1]]
    else:
        parent[path[-1]] = new
    return source.name, ".".join(map(str, path)), kind, data


def check_case(tmp_path, k, data):
    """-> ("error" | "result", message); raises AssertionError for a bad outcome."""
    cfg = tmp_path / f"case{k}.yaml"
    cfg.write_text(yaml.safe_dump(data, sort_keys=False))
    simulate = "simulation" in data
    out = tmp_path / f"case{k}.npz"
    status, stdout, err = run_cli(["simulate", str(cfg), "--out", str(out)] if simulate
                                  else ["poles", str(cfg)])
    assert "Traceback" not in err and status in (0, 2), (status, err)
    if status == 2:
        assert err.count("\n") == 1 and "error:" in err, err
        return "error", err.strip()
    if simulate:
        ts = TimeSeries.load(out)
        assert all(np.all(np.isfinite(v)) for v in ts.channels.values())
    else:
        assert "nan" not in stdout.lower(), stdout
    return "result", ""


def test_mutated_shipped_configs_end_in_a_clear_error_or_a_result(tmp_path, full):
    rng = random.Random(2024)
    n_cases = 400 if full else 100
    counts = {"error": 0, "result": 0, "error naming the file": 0}
    failures = []
    for k in range(n_cases):
        source, field, kind, data = mutated_case(rng)
        try:
            outcome, message = check_case(tmp_path, k, data)
        except Exception as exc:             # a traceback, a bad status or a non-finite output
            failures.append(f"{source} {field} ({kind}): {type(exc).__name__}: {exc}")
            continue
        counts[outcome] += 1
        counts["error naming the file"] += f"case{k}.yaml" in message
    print(f"\n{n_cases} mutated configs: {counts['error']} clear errors "
          f"({counts['error naming the file']} naming the file), {counts['result']} finite "
          f"results, {len(failures)} bad outcomes")
    assert not failures, "\n".join(failures)
