"""A study's results folder and its Dask address under hostile conditions: foreign, edited and
damaged journals and manifests are refused with the file, the line and the fix; every file is
replaced whole; one study at a time per folder; the operating system's failures (file-size
limit, disk full, read-only file system) as one line; SIGTERM like Ctrl-C; pool workers that
end with a killed driver; malformed, silent and refusing scheduler addresses refused in one
line, in bounded time."""
import errno
import json
import os
import resource
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from rotor_avc.cli import main
from rotor_avc.config import load_config
from rotor_avc.errors import ConfigError
from rotor_avc.studies.backends import SCHEDULER_TIMEOUT_S, DaskBackend, ProcessBackend, SerialBackend
from rotor_avc.studies.engine import StudySpec, run_study
from rotor_avc.output_files import EXIT_OUTPUT, OutputError
from rotor_avc.studies.folder import FolderLock, replace_file
from rotor_avc.studies.points import Grid, Sample, parse_sample, parse_vary

ROOT = Path(__file__).resolve().parents[1]
KZ = "foundation.stiffness_n_per_m.z"
FACTOR = f"{KZ} (factor)"
ROBUST = ["study", "robustness", "foot_mount_case3", "--sample", f"{KZ}*=normal(1, 0.2)",
          "--speed-hz", "1:250:50"]
#: bound of every wait on another process in this module (s)
WAIT_S = 60.0


@dataclass(frozen=True)
class Toy:
    """A cheap evaluator with a field of every kind; points above ``fail_above`` raise."""

    fail_above: float = 10.0
    fields = {"stable": bool, "value": float, "count": int, "note": str}

    def prepare(self):
        return None

    def evaluate(self, context, point):
        x = point.values[next(iter(point.values))]
        if x > self.fail_above:
            raise ValueError(f"{x} is too large")
        return {"stable": x < 1.0, "value": 3.0 * x, "count": point.index, "note": f"p{point.index}"}

    def describe(self):
        return {"toy": self.fail_above}


@pytest.fixture(scope="module")
def case3():
    return load_config("foot_mount_case3")


def sample_spec(cfg, n=8, seed=7, fail_above=10.0):
    return StudySpec(Sample([parse_sample(f"{KZ}*=normal(1, 0.2)")], n, seed, cfg), Toy(fail_above))


def run(spec, folder, backend=None, **kw):
    return run_study(spec, backend or SerialBackend(), out=folder, progress=False, **kw)


def journal_lines(folder: Path) -> list[str]:
    return (folder / "journal.csv").read_text().splitlines(keepends=True)


def refused(spec, folder, *fragments):
    with pytest.raises(ConfigError) as err:
        run(spec, folder)
    text = str(err.value)
    assert text.startswith("--out: ") and "\n" not in text and "-- fix: " in text
    for fragment in fragments:
        assert fragment in text, text
    return text


# -- the journal: nothing is trusted --------------------------------------------------------------
def test_the_journal_of_another_study_is_refused(case3, tmp_path):
    """The journal of a study with another seed, copied into the folder: refused whole; its
    lines under this study's own header: refused at the first line whose values differ."""
    run(sample_spec(case3, seed=7), tmp_path / "seed7")
    run(sample_spec(case3, seed=8), tmp_path / "seed8")
    mine = journal_lines(tmp_path / "seed8")
    theirs = journal_lines(tmp_path / "seed7")
    (tmp_path / "seed8" / "journal.csv").write_text("".join(theirs))
    refused(sample_spec(case3, seed=8), tmp_path / "seed8", "journal.csv line 1",
            "belongs to another study", "delete that folder")
    (tmp_path / "seed8" / "journal.csv").write_text("".join(mine[:2] + theirs[2:]))
    refused(sample_spec(case3, seed=8), tmp_path / "seed8", "journal.csv line 3", FACTOR,
            "delete that line")
    (tmp_path / "seed8" / "journal.csv").write_text("".join(mine))
    assert run(sample_spec(case3, seed=8), tmp_path / "seed8").computed == 0


@pytest.mark.parametrize("edit, fragments", [
    (lambda row: row.replace(",true,", ",True,").replace(",false,", ",False,"),
     ("stable", "not true or false")),
    (lambda row: "-1" + row[row.index(","):], ("index '-1' is not a point number",)),
    (lambda row: "8" + row[row.index(","):], ("but point 8 of this study has",)),
    (lambda row: "03" + row[row.index(","):], ("index '03'",)),
    (lambda row: row.rsplit(",", 2)[0] + "\n", ("cells where the study has",)),
    (lambda row: row.rstrip("\n") + "ValueError: made up\n", ("a failed point with record values",)),
])
def test_an_edited_journal_line_is_refused_with_its_line(case3, tmp_path, edit, fragments):
    """A spreadsheet's ``True``, index -1 (was: "9 of 8 points"), an index past the study, a
    short row (was: a failed point), a value in another spelling, a failed point with values."""
    spec = sample_spec(case3)
    run(spec, tmp_path)
    lines = journal_lines(tmp_path)
    row = next(k for k in range(2, len(lines)) if ",true," in lines[k] or ",false," in lines[k])
    lines[row] = edit(lines[row])
    (tmp_path / "journal.csv").write_text("".join(lines))
    refused(spec, tmp_path, f"journal.csv line {row + 1}", "delete that line", *fragments)


@pytest.mark.parametrize("column, spelling", [("value", "1e0"), ("value", " 3.0"),
                                              ("count", "+1"), ("count", "1.0")])
def test_numbers_must_be_spelled_as_the_study_writes_them(case3, tmp_path, column, spelling):
    spec = sample_spec(case3)
    run(spec, tmp_path)
    lines = journal_lines(tmp_path)
    cells = lines[3].rstrip("\n").split(",")
    cells[lines[1].rstrip("\n").split(",").index(column)] = spelling
    lines[3] = ",".join(cells) + "\n"
    (tmp_path / "journal.csv").write_text("".join(lines))
    refused(spec, tmp_path, "journal.csv line 4", column)


def test_a_point_twice_in_the_journal_is_refused(case3, tmp_path):
    """(Was: the last line wins.)"""
    spec = sample_spec(case3)
    run(spec, tmp_path)
    lines = journal_lines(tmp_path)
    (tmp_path / "journal.csv").write_text("".join(lines + [lines[4]]))
    refused(spec, tmp_path, f"journal.csv line {len(lines) + 1}", "in the journal twice")


@pytest.mark.parametrize("damage, fragment", [
    (lambda data: data[:200] + b"\0\0\0\0" + data[204:], "NUL bytes"),
    (lambda data: data[:200] + b"\xff\xfe" + data[202:], "not UTF-8"),
    (lambda data: data.split(b"\n", 1)[1], "is not the journal of a rotor-avc study"),
    (lambda data: b"\n".join(data.split(b"\n")[:1] + data.split(b"\n")[2:]), "other columns"),
])
def test_a_damaged_journal_is_refused_in_one_line(case3, tmp_path, damage, fragment):
    """NUL bytes, bytes that are not UTF-8, a journal without its study line (another
    program's, or an older version's), a missing column line: one line, no traceback."""
    spec = sample_spec(case3)
    run(spec, tmp_path)
    path = tmp_path / "journal.csv"
    path.write_bytes(damage(path.read_bytes()))
    refused(spec, tmp_path, "journal.csv line", fragment)


def test_a_cut_journal_line_is_computed_again(case3, tmp_path):
    spec = sample_spec(case3)
    run(spec, tmp_path / "whole")
    run(spec, tmp_path / "cut")
    lines = journal_lines(tmp_path / "cut")
    (tmp_path / "cut" / "journal.csv").write_text("".join(lines[:5]) + lines[5][:7])
    assert run(spec, tmp_path / "cut").computed == len(lines) - 5
    for name in ("points.csv", "points.npz"):
        assert (tmp_path / "cut" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes()


@pytest.mark.parametrize("damage, fragment", [
    (lambda data: data[:len(data) // 2], "is damaged"),                 # a write cut off
    (lambda data: b"\0" * len(data), "is damaged"),
    (lambda data: b"\xff" + data, "is damaged"),
    (lambda data: b"[1, 2]", "is damaged"),
    (lambda data: data.replace(b'"fingerprint": "', b'"fingerprint": "0'), "different study"),
])
def test_a_damaged_or_foreign_manifest_is_refused_in_one_line(case3, tmp_path, damage, fragment):
    spec = sample_spec(case3)
    run(spec, tmp_path)
    path = tmp_path / "study.json"
    path.write_bytes(damage(path.read_bytes()))
    refused(spec, tmp_path, "study.json" if "damaged" in fragment else str(tmp_path), fragment)


def test_the_fingerprint_covers_config_seed_points_and_evaluator(case3, tmp_path):
    run(sample_spec(case3), tmp_path)
    base = json.loads((tmp_path / "study.json").read_text())
    assert base["fingerprint"] in journal_lines(tmp_path)[0]
    changed = load_config("foot_mount_case3")
    changed.data["machine"]["stator_mass_kg"] += 1.0
    for other in (sample_spec(case3, seed=8), sample_spec(case3, fail_above=5.0),
                  sample_spec(changed),
                  StudySpec(Sample([parse_sample(f"{KZ}*=normal(1, 0.3)")], 8, 7, case3), Toy())):
        refused(other, tmp_path, "different study")
    assert run(sample_spec(case3, n=12), tmp_path).computed == 4      # more points: same study


def test_a_grid_journal_is_checked_against_the_grid(case3, tmp_path):
    """Index 4 of a 4-point grid (was: "5 of 4 points")."""
    spec = StudySpec(Grid([parse_vary(f"{KZ}*=0.5:1.5:4")], case3), Toy())
    run(spec, tmp_path)
    lines = journal_lines(tmp_path)
    lines.append("4" + lines[-1][1:])
    (tmp_path / "journal.csv").write_text("".join(lines))
    refused(spec, tmp_path, "line 7", "index 4 is not a point of this study")


# -- whole files, one study at a time ---------------------------------------------------------------
def test_a_file_is_replaced_whole_or_not_at_all(tmp_path):
    path = tmp_path / "study.json"
    path.write_text("old")

    def write_half(fh):
        fh.write(b"new, but")
        raise KeyboardInterrupt                 # stopped in the middle of the write

    with pytest.raises(KeyboardInterrupt):
        replace_file(path, write_half)
    assert path.read_text() == "old" and sorted(os.listdir(tmp_path)) == ["study.json"]
    replace_file(path, lambda fh: fh.write(b"new"))
    assert path.read_text() == "new" and sorted(os.listdir(tmp_path)) == ["study.json"]


def test_a_second_study_on_a_folder_in_use_is_refused(case3, tmp_path, capsys):
    spec = sample_spec(case3)
    tmp_path.mkdir(exist_ok=True)
    held = FolderLock(tmp_path)
    try:
        text = refused(spec, tmp_path, "is in use by another study", f"(process {os.getpid()})")
        assert "wait for that study to end" in text
        assert main(ROBUST + ["--n", "3", "--workers", "1", "--out", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert "in use by another study" in err and len(err.strip().splitlines()) == 1
    finally:
        held.release()
    assert run(spec, tmp_path).computed == 8
    assert run(spec, tmp_path).computed == 0                 # the lock ends with the study


def test_two_identical_studies_at_once_one_is_refused(tmp_path):
    """Two processes started together on one folder: one computes, the other is refused in
    one line (was: both computed everything and one crashed on the shared temporary name)."""
    argv = [sys.executable, "-m", "rotor_avc"] + ROBUST + ["--n", "40", "--workers", "1",
                                                          "--no-plots", "--out", str(tmp_path)]
    procs = [subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(2)]
    results = [p.communicate(timeout=WAIT_S * 3) for p in procs]
    codes = sorted(p.returncode for p in procs)
    if codes == [0, 0]:                       # the first ended before the second began
        pytest.skip("the two studies did not overlap on this machine")
    assert codes == [0, 2], results
    err = next(e for p, (_, e) in zip(procs, results) if p.returncode == 2)
    assert "is in use by another study" in err and "Traceback" not in err
    assert len(journal_lines(tmp_path)) == 2 + 40


# -- the operating system's failures ---------------------------------------------------------------
def _fsize_limit(limit_bytes: int):
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    return apply


def test_a_file_size_limit_is_one_line_and_leaves_no_partial_file(tmp_path):
    """`ulimit -f`: study.json cannot be written -- one line naming it, the output exit status,
    no study.json and no temporary file left (was: a traceback)."""
    out = tmp_path / "study"
    proc = subprocess.run([sys.executable, "-m", "rotor_avc"] + ROBUST + [
        "--n", "3", "--workers", "1", "--out", str(out)], cwd=ROOT, capture_output=True,
        text=True, timeout=WAIT_S, preexec_fn=_fsize_limit(512))
    assert proc.returncode == EXIT_OUTPUT, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{out / 'study.json'}: cannot write: file too large" in lines[0]
    assert "Traceback" not in proc.stderr
    assert sorted(os.listdir(out)) == ["study.lock"]


def test_a_full_disk_while_journaling_stops_the_study_cleanly(case3, tmp_path, monkeypatch):
    """ENOSPC on the third append: one error naming journal.csv; the journal keeps whole lines
    only, the tables are not half written; freed, the same study completes with the same bytes."""
    spec = sample_spec(case3)
    run(spec, tmp_path / "whole", batch_size=1)
    real_write, calls = os.write, []

    def full_disk(fd, data):
        calls.append(fd)
        if len(calls) == 3:
            real_write(fd, bytes(data)[:5])           # a part went to disk before it filled up
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(fd, data)

    monkeypatch.setattr(os, "write", full_disk)
    with pytest.raises(OutputError, match="journal.csv: cannot write: disk full"):
        run(spec, tmp_path / "full", batch_size=1)
    monkeypatch.setattr(os, "write", real_write)
    data = (tmp_path / "full" / "journal.csv").read_text()
    assert data.endswith("\n") and len(data.splitlines()) == 2 + 2
    assert not list((tmp_path / "full").glob(".*partial*"))
    assert run(spec, tmp_path / "full", batch_size=1).computed == 6
    for name in ("points.csv", "points.npz"):
        assert (tmp_path / "full" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes()


def test_a_read_only_folder_at_the_tables_is_one_line(case3, tmp_path, monkeypatch):
    """EROFS when the tables are written: the error names points.csv; the journal is whole and
    no temporary file is left."""
    spec = sample_spec(case3)
    real_open = open

    def read_only(file, mode="r", *args, **kwargs):
        if "w" in mode and "points" in str(file):
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(file))
        return real_open(file, mode, *args, **kwargs)

    monkeypatch.setattr("builtins.open", read_only)
    with pytest.raises(OutputError) as err:
        run(spec, tmp_path)
    monkeypatch.setattr("builtins.open", real_open)
    assert f"{tmp_path / 'points.csv'}: cannot write: read-only file system" in str(err.value)
    assert sorted(os.listdir(tmp_path)) == ["journal.csv", "study.json", "study.lock"]
    assert len(journal_lines(tmp_path)) == 2 + 8


def test_a_folder_without_permission_is_one_line(case3, tmp_path, monkeypatch):
    """EACCES on the lock file (as root, permission bits do not stop this test's process)."""
    real_open = os.open

    def denied(path, flags, *args, **kwargs):
        if str(path).endswith("study.lock"):
            raise OSError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", denied)
    with pytest.raises(OutputError, match="study.lock: cannot write: permission denied"):
        run(sample_spec(case3), tmp_path)


# -- signals and process lifetimes ------------------------------------------------------------------
def _wait_for(predicate, what: str, proc=None):
    deadline = time.monotonic() + WAIT_S
    while not predicate():
        assert proc is None or proc.poll() is None, f"{what}: the process ended ({proc.returncode})"
        assert time.monotonic() < deadline, f"no {what} within {WAIT_S} s"
        time.sleep(0.05)


def test_sigterm_stops_a_study_like_ctrl_c(tmp_path):
    """SIGTERM mid-study: exit 130, one line, tables of the journaled points; the rerun resumes
    (was: exit -15 without the tables)."""
    out = tmp_path / "study"
    proc = subprocess.Popen([sys.executable, "-m", "rotor_avc"] + ROBUST + [
        "--n", "2000", "--workers", "2", "--batch-size", "1", "--no-plots", "--out", str(out)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _wait_for(lambda: (out / "journal.csv").exists() and len(journal_lines(out)) >= 2 + 6,
                  "journaled points", proc)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=WAIT_S)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == 130 and "interrupted" in err and "Traceback" not in err, err
    done = len(journal_lines(out)) - 2
    assert 6 <= done < 2000
    table = np.load(out / "points.npz")
    assert sorted(table["index"].tolist()) == table["index"].tolist() and len(table["index"]) == done
    assert len((out / "points.csv").read_text().splitlines()) == 1 + done


WORKER_SCRIPT = textwrap.dedent('''
    import os, sys, time
    from rotor_avc.config import load_config
    from rotor_avc.studies.backends import ProcessBackend
    from rotor_avc.studies.engine import StudySpec, run_study
    from rotor_avc.studies.points import Sample, parse_sample

    class Hang:
        fields = {"x": float}
        def prepare(self):
            return None
        def evaluate(self, context, point):
            if os.getpid() != DRIVER:
                open(os.path.join(sys.argv[1], str(os.getpid())), "w").close()
                time.sleep(600)
            return {"x": 1.0}
        def describe(self):
            return {}

    DRIVER = os.getpid()
    cfg = load_config("foot_mount_case3")
    spec = StudySpec(Sample([parse_sample("machine.stator_mass_kg*=normal(1, 0.1)")], 8, 0, cfg), Hang())
    run_study(spec, ProcessBackend(2), batch_size=1, progress=False)
''')


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads /proc")
def test_pool_workers_end_with_a_killed_driver(tmp_path):
    """kill -9 of the study's process: its pool workers end too (was: they ran on for good)."""
    script = tmp_path / "driver.py"
    script.write_text(WORKER_SCRIPT)
    pids = tmp_path / "pids"
    pids.mkdir()
    driver = subprocess.Popen([sys.executable, str(script), str(pids)], cwd=ROOT,
                              env={**os.environ, "PYTHONPATH": str(ROOT)})
    workers = []
    try:
        _wait_for(lambda: len(os.listdir(pids)) >= 2, "two busy workers", driver)
        workers = [int(p) for p in os.listdir(pids)]
        driver.kill()
        driver.wait(WAIT_S)
        _wait_for(lambda: not any(map(_alive, workers)), "end of the workers")
    finally:
        driver.kill()
        for pid in workers:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


# -- Dask addresses ---------------------------------------------------------------------------------
@pytest.mark.parametrize("address", ["", " ", "127.0.0.1:8786", "tcp://", "tcp://:8786",
                                     "tcp://127.0.0.1", "tcp://127.0.0.1:0",
                                     "tcp://127.0.0.1:65536", "tcp://127.0.0.1:87a6",
                                     "http://127.0.0.1:8786", " tcp://127.0.0.1:8786",
                                     "tcp://bad host:8786", "tcp://127.0.0.1:8786/x"])
@pytest.mark.parametrize("command", [ROBUST + ["--n", "3"],
                                     ["stability", "roller_bearing_stability", "--vary",
                                      "bearings.stiffness_n_per_m.z=1.0e+8:3.0e+8:3"],
                                     ["study", "sleeve_bearing_motor", "--gains", "1:2:2"]])
def test_a_malformed_scheduler_address_is_refused_before_any_work(tmp_path, capsys, address,
                                                                  command):
    """(Was: tracebacks, and `--scheduler ''` ran in this process without a word.)"""
    out = tmp_path / "out"
    assert main(command + ["--scheduler", address, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--scheduler" in err and "tcp://HOST:PORT" in err
    assert not out.exists()


@pytest.mark.parametrize("argv, option", [
    (["study", "strategies", "scenario_case3_stepped", "--workers", "2"], "--workers"),
    (["study", "strategies", "scenario_case3_stepped", "--scheduler", ""], "--scheduler"),
    (["stability", "roller_bearing_stability", "--workers", "2"], "--workers"),
])
def test_backend_options_where_they_do_not_apply_are_refused(tmp_path, capsys, argv, option):
    assert main(argv + ["--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert option in err and len(err.strip().splitlines()) == 1


@pytest.fixture
def silent_server():
    """``tcp://127.0.0.1:PORT`` of a server that accepts connections and never answers."""
    server = socket.create_server(("127.0.0.1", 0))
    held, stop = [], threading.Event()

    def accept():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except TimeoutError:
                pass

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    stop.set()
    thread.join(WAIT_S)
    for conn in held:
        conn.close()
    server.close()


@pytest.mark.timeout(4 * SCHEDULER_TIMEOUT_S + 30)
def test_a_silent_server_is_no_scheduler_within_the_stated_time(tmp_path, capsys, silent_server):
    """A port that accepts and never answers (was: still waiting at 400 s): the command ends
    after the stated SCHEDULER_TIMEOUT_S with one line (bounded by the timeout mark)."""
    pytest.importorskip("distributed")
    out = tmp_path / "out"
    assert main(ROBUST + ["--n", "3", "--scheduler", silent_server, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and silent_server in err
    assert f"gave no Dask answer within {SCHEDULER_TIMEOUT_S:g} s" in err
    assert not out.exists()
    with pytest.raises(ConfigError, match="gave no Dask answer within 1 s"):
        DaskBackend(silent_server, timeout_s=1.0)


@pytest.mark.timeout(60)
def test_a_port_nobody_listens_on_is_refused_at_once():
    pytest.importorskip("distributed")
    with socket.create_server(("127.0.0.1", 0)) as probe:
        port = probe.getsockname()[1]                 # closed again: nobody listens there
    with pytest.raises(ConfigError, match="cannot connect: Connection refused"):
        DaskBackend(f"tcp://127.0.0.1:{port}")


def test_bit_identical_results_across_backends_still_hold(case3, tmp_path):
    spec = sample_spec(case3, n=30, fail_above=1.1)
    serial = run(spec, tmp_path / "serial", batch_size=30)
    pool = run(spec, tmp_path / "pool", ProcessBackend(2), batch_size=1)
    assert serial.outcomes == pool.outcomes and 0 < len(serial.failed) < 30
    for name in ("points.csv", "points.npz"):
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / "pool" / name).read_bytes()
