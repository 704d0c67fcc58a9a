"""The operating system's refusals on every output path -- disk full, read-only file system,
file-size limit -- are one line naming the path, the cause and the fix, exit status 74, and
leave no file under the final name (an older file of that name stays as it was)."""
import builtins
import errno
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from rotor_avc.bag.writer import BagWriter
from rotor_avc.cli import main
from rotor_avc.config import find_config
from rotor_avc.output_files import (EXIT_OUTPUT, OutputError, partial_name, write_text,
                                    writing)

ROOT = Path(__file__).resolve().parents[1]
REFERENCE_BAG = ROOT / "bags" / "reference" / "case3_stepped.mcap"
CAUSES = {errno.ENOSPC: "disk full", errno.EROFS: "read-only file system",
          errno.EFBIG: "file too large", errno.EACCES: "permission denied",
          errno.EDQUOT: "disk quota exceeded"}


class _RefusingFile:
    """A file opened for writing whose writes fail as a full (read-only, ...) disk makes them."""

    def __init__(self, f, err: int):
        self._f, self._err = f, err

    def write(self, data):
        raise OSError(self._err, os.strerror(self._err))

    def __getattr__(self, name):
        return getattr(self._f, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._f.close()


def refuse_writes(monkeypatch, folder: Path, err: int) -> None:
    """Every file opened for writing below ``folder`` refuses its writes with ``err``."""
    real_open, folder = builtins.open, Path(os.path.abspath(folder))

    def fake_open(file, mode="r", *args, **kwargs):
        f = real_open(file, mode, *args, **kwargs)
        if (isinstance(file, (str, os.PathLike)) and set(mode) & set("wax+")
                and Path(os.path.abspath(file)).is_relative_to(folder)):
            return _RefusingFile(f, err)
        return f

    monkeypatch.setattr(builtins, "open", fake_open)


def short_scenario(tmp_path: Path) -> Path:
    cfg = tmp_path / "short.yaml"
    cfg.write_text(f"include: {find_config('scenario_case3_steady')}\n"
                   "simulation: {duration_s: 0.05}\n")
    return cfg


def assert_refused(capsys, status: int, final: Path, err: int) -> None:
    """One line on stderr naming ``final`` and the cause, exit 74, no file (or partial) left."""
    lines = [line for line in capsys.readouterr().err.strip().splitlines()
             if not (line.startswith("[") and " ETA " in line)]      # progress bars aside
    assert status == EXIT_OUTPUT
    assert len(lines) == 1, lines
    assert f"{final}: cannot write: {CAUSES[err]}" in lines[0] and "-- fix:" in lines[0]
    assert not final.exists()
    assert not list(final.parent.glob(".*partial*")), list(final.parent.iterdir())


@pytest.mark.parametrize("err", sorted(CAUSES))
def test_writing_names_path_and_cause_and_keeps_the_old_file(tmp_path, err):
    path = tmp_path / "out" / "table.csv"
    write_text(path, "old\n")
    with pytest.raises(OutputError) as info:
        with writing(path) as tmp:
            tmp.write_text("new, half")
            raise OSError(err, os.strerror(err))
    text = str(info.value)
    assert text.startswith(f"{path}: cannot write: {CAUSES[err]}") and "-- fix: " in text
    assert "\n" not in text and info.value.exit_status == EXIT_OUTPUT
    assert path.read_text() == "old\n" and not partial_name(path).exists()


def test_writing_renames_only_a_complete_file(tmp_path):
    path = tmp_path / "new" / "page.html"
    path.parent.mkdir()
    partial_name(path).write_text("left by a killed run")
    with writing(path) as tmp:
        assert tmp.parent == path.parent and tmp.suffix == ".html" and tmp.name.startswith(".")
        assert not tmp.exists()
        with open(tmp, "x") as fh:
            fh.write("<p>done</p>")
        assert not path.exists()
    assert path.read_text() == "<p>done</p>" and sorted(os.listdir(path.parent)) == ["page.html"]


@pytest.mark.parametrize("command, err, final", [
    ("frf foot_mount_case3 --speed-hz 1:100:20 --out {out}", errno.ENOSPC, "frf.csv"),
    ("frf foot_mount_case3 --speed-hz 1:100:20 --out {out}", errno.EROFS, "frf.csv"),
    ("campbell foot_mount_case3 --speed-hz 0:100:10 --out {out}", errno.EFBIG, "campbell.json"),
    ("simulate {short} --out {out}/run.mcap", errno.ENOSPC, "run.mcap"),
    ("simulate {short} --out {out}/run.npz", errno.EFBIG, "run.npz"),
    (f"bag recover {REFERENCE_BAG} --out {{out}}/recovered.mcap", errno.EROFS, "recovered.mcap"),
    (f"compare {REFERENCE_BAG} --out {{out}}", errno.ENOSPC, "metrics.json"),
])
def test_commands_report_the_refusal_in_one_line(tmp_path, monkeypatch, capsys, command, err,
                                                 final):
    out = tmp_path / "out"
    out.mkdir()
    argv = command.format(out=out, short=short_scenario(tmp_path)).split()
    refuse_writes(monkeypatch, out, err)
    assert_refused(capsys, main(argv), out / final, err)


def test_a_report_file_refused_after_others_were_written(tmp_path, monkeypatch, capsys):
    """campbell writes campbell.json, then the PNG: a refused PNG is named, the JSON stays."""
    import matplotlib.figure

    def full_disk(fig, path, **options):
        Path(path).write_bytes(b"\x89PNG half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", full_disk)
    out = tmp_path / "out"
    status = main(f"campbell foot_mount_case3 --speed-hz 0:100:10 --out {out}".split())
    assert_refused(capsys, status, out / "campbell.png", errno.ENOSPC)
    assert (out / "campbell.json").stat().st_size > 0


def test_a_bag_writer_refused_mid_run_stays_closed(tmp_path, monkeypatch):
    """After a refused write the writer is closed: later writes raise the same error, closing
    raises nothing, and the file keeps what was flushed before."""
    path = tmp_path / "run.mcap"
    writer = BagWriter(path, None, chunk_size=1024)
    writer.add_topic("/clock")
    header = path.stat().st_size
    monkeypatch.setattr(writer._sink, "_file", _RefusingFile(writer._sink._file, errno.ENOSPC))
    with pytest.raises(OutputError, match=f"{path}: cannot write: disk full") as first:
        for k in range(1000):
            writer.write_raw("/clock", b"\0" * 12, k)
    assert k > 0                              # the first chunk filled up, then its write failed
    with pytest.raises(OutputError) as again:
        writer.write_raw("/clock", b"\0" * 12, 0)
    assert again.value is first.value
    writer.close()
    assert path.stat().st_size == header


def _file_size_limit(limit_bytes: int):
    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    return apply


@pytest.mark.parametrize("suffix", [".mcap", ".npz"])
def test_a_real_file_size_limit_in_a_subprocess(tmp_path, suffix):
    """RLIMIT_FSIZE (`ulimit -f`) makes the kernel refuse the writes with EFBIG."""
    out = tmp_path / "out" / f"run{suffix}"
    proc = subprocess.run(
        [sys.executable, "-m", "rotor_avc", "simulate", str(short_scenario(tmp_path)),
         "--out", str(out)], capture_output=True, text=True, timeout=600,
        preexec_fn=_file_size_limit(16 * 1024))
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == EXIT_OUTPUT, proc.stderr
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert lines[0].startswith(f"rotor-avc simulate: error: {out}: cannot write: file too large")
    assert not out.exists() and os.listdir(out.parent) == []
