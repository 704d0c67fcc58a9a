"""Mutation check: one-line mutants of the listed modules, each run against the tests that
exercise the module; a mutant the tests do not fail on (a survivor) is a hole in the tests.

Usage::

    python tools/mutation.py                       # every target of tools/mutation_targets.toml
    python tools/mutation.py --group "bag sequence" --max 40 --jobs 2
    python tools/mutation.py --module pkg/mod.py --tests test/test_mod.py   # no configuration
    python tools/mutation.py --module rotor_avc/bag/sequence.py --list      # the mutants only

The working tree is never edited: each worker copies the repository's files (``git ls-files``,
tracked and untracked-not-ignored, as they are now) to a temporary directory and runs
``pytest -x -q`` there with ``PYTHONPATH`` on the copy, one mutant at a time. A mutant is
*killed* (the tests fail), *survived* (they pass) or *timeout* (they run longer than
``--timeout-factor`` x the unmutated run, at least ``--min-timeout`` s). Mutants listed in
tools/mutation_equivalent.toml (same file, same original and mutated line) are equivalent --
the program's behaviour does not change -- and are not run. At most ``--max`` mutants per module
are drawn, the same ones on every run for one ``--seed``.

Writes ``<out>/mutation.md`` (the table and the survivors, file:line and the mutated line) and
``<out>/mutation.json``; exits 1 if a module's unmutated tests fail."""
import argparse
import contextlib
import json
import os
import queue
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tomllib
import zlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mutants import mutants  # noqa: E402  (a sibling script module, not an installed package)

HERE = Path(__file__).resolve().parent
#: test runs under way (their process groups are killed when the check is stopped)
RUNNING: set = set()
SKIP_DIRS = {".git", ".venv", "__pycache__", "out", "build", "install", "log", ".pytest_cache"}


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--config", default=str(HERE / "mutation_targets.toml"),
                   help="TOML file of [[target]] module/tests/group (default: %(default)s)")
    p.add_argument("--equivalent", default=str(HERE / "mutation_equivalent.toml"),
                   help="TOML file of [[equivalent]] file/line/original/mutated/reason")
    p.add_argument("--group", action="append", default=[], help="only the targets of this group")
    p.add_argument("--module", action="append", default=[],
                   help="only this module (a path in the repository); with --tests, no "
                        "configuration is needed")
    p.add_argument("--tests", nargs="+", default=[], help="test files for --module (no config)")
    p.add_argument("--max", type=int, default=40, help="mutants drawn per module (0: all)")
    p.add_argument("--seed", type=int, default=0, help="seed of the drawing of mutants")
    p.add_argument("--jobs", type=int, default=2, help="mutants run at the same time")
    p.add_argument("--timeout-factor", type=float, default=3.0,
                   help="a mutant times out after this many times the unmutated run")
    p.add_argument("--min-timeout", type=float, default=30.0, help="lowest per-mutant timeout, s")
    p.add_argument("--repo", default=None, help="repository to copy (default: this file's)")
    p.add_argument("--out", default="out/mutation", help="folder of mutation.md/.json")
    p.add_argument("--list", action="store_true", help="print the drawn mutants, run nothing")
    return p.parse_args(argv)


def load_targets(args) -> list[dict]:
    """The targets to run: ``--module``/``--tests`` as given, else the configuration's targets
    (filtered by ``--group``/``--module``)."""
    if args.module and args.tests:
        return [{"module": m, "tests": list(args.tests), "group": m} for m in args.module]
    with open(args.config, "rb") as fh:
        targets = tomllib.load(fh).get("target", [])
    for t in targets:
        if not t.get("module") or not t.get("tests"):
            raise SystemExit(f"{args.config}: every [[target]] needs module and tests; got {t}")
        t.setdefault("group", t["module"])
    if args.group:
        targets = [t for t in targets if t["group"] in args.group]
    if args.module:
        targets = [t for t in targets if t["module"] in args.module]
    if not targets:
        raise SystemExit("no target matches --group/--module; see the [[target]] list in "
                         f"{args.config}")
    return targets


def load_equivalent(path: str) -> list[dict]:
    if not os.path.exists(path):
        return []
    with open(path, "rb") as fh:
        entries = tomllib.load(fh).get("equivalent", [])
    for e in entries:
        missing = [k for k in ("file", "original", "mutated", "reason") if not e.get(k)]
        if missing:
            raise SystemExit(f"{path}: an [[equivalent]] entry lacks {', '.join(missing)}: {e}")
    return entries


def _norm(text: str) -> str:
    return " ".join(text.split())


def is_equivalent(entries, module: str, original: str, mutated: str) -> str | None:
    """The reason a mutant is equivalent, or None."""
    for e in entries:
        if (e["file"], _norm(e["original"]), _norm(e["mutated"])) == (module, original, mutated):
            return e["reason"]
    return None


def draw(found: list, count: int, seed: int, module: str) -> list:
    """At most ``count`` of ``found`` (all if 0), the same ones for one seed and module."""
    if count <= 0 or len(found) <= count:
        return list(found)
    rng = random.Random(seed * 1_000_003 + zlib.crc32(module.encode()))
    return sorted(rng.sample(found, count), key=lambda m: m.start)


def repo_files(repo: Path) -> list[str]:
    """The repository's files as they are now: tracked and untracked-not-ignored (git), or every
    file outside build/cache folders (no git)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others",
                              "--exclude-standard"], cwd=repo, capture_output=True,
                             check=True).stdout
        return [f for f in out.decode().split("\0") if f and (repo / f).is_file()]
    except (subprocess.CalledProcessError, FileNotFoundError):
        files = []
        for root, dirs, names in os.walk(repo):
            dirs[:] = [d for d in dirs if d not in SKIP_DIRS]
            files += [os.path.relpath(os.path.join(root, n), repo) for n in names]
        return files


def copy_repo(repo: Path, files: list[str], into: Path):
    for f in files:
        (into / f).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(repo / f, into / f)


def run_tests(copy: Path, tests: list[str], timeout: float | None) -> tuple[str, float]:
    """``pytest -x -q`` of ``tests`` in the copy: ("pass"|"fail"|"timeout", seconds)."""
    env = dict(os.environ, PYTHONPATH=str(copy) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               PYTHONDONTWRITEBYTECODE="1")
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests]
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=copy, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    RUNNING.add(proc)
    try:
        code = proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        return "timeout", time.monotonic() - t0
    finally:
        RUNNING.discard(proc)
    return ("pass" if code == 0 else "fail"), time.monotonic() - t0


class Workers:
    """``jobs`` copies of the repository, each running one mutant at a time."""

    def __init__(self, repo: Path, jobs: int):
        self.root = Path(tempfile.mkdtemp(prefix="mutation-"))
        files = repo_files(repo)
        self.copies = queue.Queue()
        for k in range(max(1, jobs)):
            copy = self.root / f"w{k}"
            copy_repo(repo, files, copy)
            self.copies.put(copy)
        self.jobs = max(1, jobs)

    def run(self, module: str, source: str, tests, mutant, timeout) -> str:
        copy = self.copies.get()
        target = copy / module
        try:
            target.write_text(mutant.apply(source) if mutant else source)
            if mutant is None:
                return run_tests(copy, tests, timeout)
            state, _ = run_tests(copy, tests, timeout)
            return {"pass": "survived", "fail": "killed", "timeout": "timeout"}[state]
        finally:
            target.write_text(source)
            self.copies.put(copy)

    def close(self):
        for proc in list(RUNNING):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
        shutil.rmtree(self.root, ignore_errors=True)


def run_target(workers: Workers, repo: Path, target: dict, args, equivalent) -> dict:
    module, tests = target["module"], target["tests"]
    source = (repo / module).read_text()
    drawn = draw(mutants(module, source), target.get("max", args.max), args.seed, module)
    row = {"module": module, "group": target["group"], "tests": tests, "mutants": len(drawn),
           "killed": 0, "survived": 0, "timeout": 0, "equivalent": 0, "survivors": [],
           "baseline": "pass"}
    todo = []
    for m in drawn:
        original, mutated = m.lines(source)
        reason = is_equivalent(equivalent, module, original, mutated)
        if reason:
            row["equivalent"] += 1
        else:
            todo.append((m, original, mutated))
    state, seconds = workers.run(module, source, tests, None, None)
    if state != "pass":
        row["baseline"] = state
        print(f"{module}: the unmutated tests fail ({' '.join(tests)}); no mutant run", flush=True)
        return row
    timeout = max(args.min_timeout, args.timeout_factor * seconds)
    with ThreadPoolExecutor(workers.jobs) as pool:
        results = list(pool.map(
            lambda item: workers.run(module, source, tests, item[0], timeout), todo))
    for (m, original, mutated), outcome in zip(todo, results):
        row[outcome] += 1
        if outcome == "survived":
            row["survivors"].append({"file": module, "line": m.line, "operator": m.operator,
                                     "original": original, "mutated": mutated})
    print(f"{module}: {row['mutants']} mutants, {row['killed']} killed, "
          f"{row['survived']} survived, {row['timeout']} timeout, {row['equivalent']} "
          f"equivalent ({seconds:.1f} s per run)", flush=True)
    return row


def score(rows) -> float:
    """Killed (and timed-out) share of the non-equivalent mutants, percent."""
    run = sum(r["killed"] + r["survived"] + r["timeout"] for r in rows)
    return 100.0 * sum(r["killed"] + r["timeout"] for r in rows) / run if run else 100.0


def write_report(rows, out: Path, args):
    out.mkdir(parents=True, exist_ok=True)
    groups = {}
    for r in rows:
        groups.setdefault(r["group"], []).append(r)
    lines = ["# Mutation check", "",
             f"seed {args.seed}, at most {args.max} mutants per module; killed % = (killed + "
             "timeout) / (mutants - equivalent)", "",
             "| group | module | mutants | killed | survived | timeout | equivalent | killed % |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for group, members in groups.items():
        for r in members:
            note = "" if r["baseline"] == "pass" else f" (unmutated tests: {r['baseline']})"
            lines.append(f"| {group} | {r['module']}{note} | {r['mutants']} | {r['killed']} | "
                         f"{r['survived']} | {r['timeout']} | {r['equivalent']} | "
                         f"{score([r]):.0f} |")
        if len(members) > 1:
            lines.append(f"| {group} | **all** | {sum(r['mutants'] for r in members)} | "
                         f"{sum(r['killed'] for r in members)} | "
                         f"{sum(r['survived'] for r in members)} | "
                         f"{sum(r['timeout'] for r in members)} | "
                         f"{sum(r['equivalent'] for r in members)} | {score(members):.0f} |")
    lines += ["", "## Survivors", ""]
    survivors = [s for r in rows for s in r["survivors"]]
    lines += [f"- `{s['file']}:{s['line']}` ({s['operator']}): `{s['original']}` -> "
              f"`{s['mutated']}`" for s in survivors] or ["none"]
    (out / "mutation.md").write_text("\n".join(lines) + "\n")
    (out / "mutation.json").write_text(json.dumps(
        {"seed": args.seed, "max": args.max, "modules": rows,
         "groups": {g: round(score(m), 1) for g, m in groups.items()}}, indent=1) + "\n")


def main(argv=None) -> int:
    args = parse_args(argv)
    repo = Path(args.repo).resolve() if args.repo else HERE.parent
    targets = load_targets(args)
    equivalent = load_equivalent(args.equivalent)
    if args.list:
        for t in targets:
            source = (repo / t["module"]).read_text()
            drawn = draw(mutants(t["module"], source), t.get("max", args.max), args.seed,
                         t["module"])
            for m in drawn:
                original, mutated = m.lines(source)
                mark = (" [equivalent]" if is_equivalent(equivalent, t["module"], original, mutated)
                        else "")
                print(f"{t['module']}:{m.line} ({m.operator}){mark}\n  - {original}\n  + {mutated}")
        return 0
    # a stop (SIGTERM) ends the test runs and removes the copies
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    workers = Workers(repo, args.jobs)
    try:
        rows = []
        for t in targets:
            rows.append(run_target(workers, repo, t, args, equivalent))
            write_report(rows, Path(args.out), args)        # the report so far, after each module
    finally:
        workers.close()
    print(f"report: {Path(args.out) / 'mutation.md'}; killed {score(rows):.0f} % of the "
          "non-equivalent mutants")
    return 1 if any(r["baseline"] != "pass" for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
