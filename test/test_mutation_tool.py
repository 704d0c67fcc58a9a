"""The mutation check (tools/mutation.py) on a tiny repository: it finds one-line mutants at the
expected places, kills those the tests notice, lists a survivor with its line, subtracts a listed
equivalent mutant, and never edits the repository it reads."""
import json
import subprocess
import sys
from pathlib import Path

TOOLS = Path(__file__).resolve().parent.parent / "tools"
sys.path.insert(0, str(TOOLS))
from mutants import mutants  # noqa: E402  (tools/ is a folder of scripts, not a package)

MODULE = '''"""tiny"""


def clip(x, limit):
    if x > limit:
        return limit
    return x


def scale(x):
    return x * 2
'''
TEST = '''from tiny import clip, scale


def test_clip():
    assert clip(5, 3) == 3
    assert clip(1, 3) == 1


def test_scale():
    assert scale(0) == 0
'''


def _texts(found, source):
    return {m.lines(source)[1] for m in found}


def test_mutants_of_a_module():
    found = mutants("tiny.py", MODULE)
    texts = _texts(found, MODULE)
    # relaxed and flipped comparison, return value, arithmetic swap, constant, in source order
    assert {"if x >= limit:", "if x <= limit:", "return None", "return x / 2", "return x * 0",
            "return x * 3"} <= texts
    assert [m.start for m in found] == sorted(m.start for m in found)
    assert all(m.apply(MODULE) != MODULE for m in found)
    # a string join is not arithmetic, a docstring is not a constant; f-strings are left alone
    source = 'def f(a):\n    """doc"""\n    b = "x" + a\n    return f"{a + 1}"\n'
    assert not [m for m in mutants("j.py", source) if m.operator in ("arith", "constant")]


def test_slice_and_deletion_mutants():
    source = ("def f(xs, out):\n    for x in xs[1:-1]:\n        if x:\n            continue\n"
              "        out.append(x)\n")
    texts = _texts(mutants("s.py", source), source)
    assert {"for x in xs[(1) + 1:-1]:", "for x in xs[1:(-1) - 1]:", "for x in xs[1:1]:",
            "pass"} <= texts
    deleted = [m for m in mutants("s.py", source) if m.operator == "delete"]
    assert [m.line for m in deleted] == [4, 5]   # `continue` and the call statement

def test_run_kills_and_lists_survivors(tmp_path):
    repo = tmp_path / "repo"
    (repo / "test").mkdir(parents=True)
    (repo / "tiny.py").write_text(MODULE)
    (repo / "test" / "test_tiny.py").write_text(TEST)
    equivalent = tmp_path / "equivalent.toml"
    # `x * 2` -> `x * 3` survives the test of scale(0); listed as equivalent here, it is not run
    equivalent.write_text('[[equivalent]]\nfile = "tiny.py"\nline = 11\noriginal = "return x * 2"\n'
                          'mutated = "return x * 3"\nreason = "the test only checks scale(0)"\n')
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, str(TOOLS / "mutation.py"), "--repo", str(repo),
                           "--module", "tiny.py", "--tests", "test/test_tiny.py", "--max", "0",
                           "--jobs", "2", "--equivalent", str(equivalent), "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    row = json.loads((out / "mutation.json").read_text())["modules"][0]
    survivors = {s["mutated"] for s in row["survivors"]}
    # killed: `>` -> `<=` (clip(1, 3) would be 3), `return limit` -> None; `x > limit` ->
    # `x >= limit` survives (clip(3, 3) untested); `x * 2` -> `x / 2` and `x * 0` survive scale(0)
    assert survivors == {"if x >= limit:", "return x / 2", "return x * 0"}
    assert row["equivalent"] == 1
    assert row["killed"] == row["mutants"] - row["equivalent"] - len(survivors) > 0
    assert row["timeout"] == 0
    report = (out / "mutation.md").read_text()
    assert "`tiny.py:5` (compare): `if x > limit:` -> `if x >= limit:`" in report
    # the repository read is untouched
    assert (repo / "tiny.py").read_text() == MODULE
