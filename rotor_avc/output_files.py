"""Writing output files: the whole file under its final name or none, and the operating system's
refusals as one line.

Every file a command writes goes through :func:`writing` (or :func:`write_text`,
:func:`open_text`, :func:`save_figure`, which use it): the data go to a temporary name in the
same folder (:func:`partial_name`, ``.x.partial.csv`` for ``x.csv``) and are renamed to the
final name only when complete, so an error or Ctrl-C never leaves a truncated file under the
final name (an older file of that name stays as it was). An ``OSError`` -- disk full,
read-only file system, file-size limit, permission denied, ... -- becomes an
:class:`OutputError`: one line naming the path, the cause and the fix, which the command line
prints and ends with :data:`EXIT_OUTPUT`. Streams that must stay at their final name while they
grow (a recorder's bag, readable after a crash) wrap their writes in :func:`output_errors` only.
"""
from __future__ import annotations

import contextlib
import errno
import os
from pathlib import Path

from .errors import RotorAvcError

#: exit status of a command whose output could not be written (sysexits.h's EX_IOERR)
EXIT_OUTPUT = 74

_ELSEWHERE = "write to another folder (--out)"
#: errno -> (cause, fix) of the refusals a user can do something about
_CAUSES = {
    errno.ENOSPC: ("disk full", f"free space on that disk, or {_ELSEWHERE} on a disk with room"),
    errno.EDQUOT: ("disk quota exceeded", f"free space within the quota, or {_ELSEWHERE}"),
    errno.EROFS: ("read-only file system", f"{_ELSEWHERE} on a writable disk"),
    errno.EFBIG: ("file too large for the file-size limit (`ulimit -f`) or the file system",
                  "raise the limit (`ulimit -f unlimited`), or write to a file system that "
                  "holds larger files"),
    errno.EACCES: ("permission denied", f"{_ELSEWHERE} you may write to, or change its "
                                        "permissions"),
    errno.EPERM: ("operation not permitted", f"{_ELSEWHERE} you may write to"),
    errno.EIO: ("input/output error of the device", f"check the disk, or {_ELSEWHERE}"),
    errno.ENAMETOOLONG: ("name too long", "give a shorter name"),
    errno.ENOTDIR: ("a part of the path is a file, not a folder", "give another path"),
    errno.EISDIR: ("a folder has that name", "give another name"),
    errno.ENOENT: ("the folder does not exist (any more)", "give an existing folder"),
}


class OutputError(RotorAvcError):
    """An output file could not be written: ``path: cannot write: cause -- fix: ...``."""

    exit_status = EXIT_OUTPUT

    def __init__(self, path, exc: OSError):
        self.path = str(path)
        self.os_error = exc
        cause, fix = _CAUSES.get(exc.errno, (exc.strerror or type(exc).__name__,
                                             f"check the disk and the folder, or {_ELSEWHERE}"))
        self.cause, self.fix = cause, fix
        super().__init__(f"{self.path}: cannot write: {cause} -- fix: {fix}")


@contextlib.contextmanager
def output_errors(path):
    """Inside: any ``OSError`` is raised as :class:`OutputError` naming ``path``."""
    try:
        yield
    except OSError as exc:
        raise OutputError(path, exc) from None


def partial_name(path) -> Path:
    """The temporary name an output is written under before it is renamed to ``path`` (same
    folder, so the rename is atomic; same suffix, so writers that pick the format by it work)."""
    path = Path(path)
    return path.with_name(f".{path.stem}.partial{path.suffix}")


def make_folder(path) -> Path:
    """Create the output folder ``path`` (and its parents) if needed."""
    path = Path(path)
    with output_errors(path):
        path.mkdir(parents=True, exist_ok=True)
    return path


@contextlib.contextmanager
def writing(path):
    """Yield the temporary name to write ``path`` under (its folder is created, a file left
    there by a killed run removed): when the body ends normally the file written there is
    renamed to ``path`` (a body that wrote nothing replaces nothing); on any error it is removed.
    ``OSError`` -> :class:`OutputError`."""
    path = Path(path)
    make_folder(path.parent)
    tmp = partial_name(path)
    try:
        try:
            tmp.unlink(missing_ok=True)
            yield tmp
            if tmp.exists():
                os.replace(tmp, path)
        except OSError as exc:
            raise OutputError(path, exc) from None
        except OutputError as exc:                 # a writer (a bag) that named the temporary file
            if Path(exc.path) != tmp:
                raise
            raise OutputError(path, exc.os_error) from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def open_text(path, newline: str | None = None):
    """A text file (UTF-8) opened for writing through :func:`writing`."""
    with writing(path) as tmp, open(tmp, "w", encoding="utf-8", newline=newline) as fh:
        yield fh


def write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through :func:`writing`."""
    with open_text(path) as fh:
        fh.write(text)
    return Path(path)


def save_figure(fig, path, **options) -> Path:
    """``fig.savefig`` (matplotlib; format from the suffix) through :func:`writing`."""
    with writing(path) as tmp:
        fig.savefig(tmp, **options)
    return Path(path)
