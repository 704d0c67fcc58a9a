"""The results folder of a study on disk: one study at a time, files replaced whole, and the
operating system's failures as one line.

* **Lock.** A study holds an exclusive ``fcntl.flock`` on ``study.lock`` in the folder while it
  runs (the file holds its process id); a second study on the same folder is refused at once
  with that id. The kernel drops the lock when the process ends, however it ends.
* **Whole files.** :func:`replace_file` writes under a temporary name in the same folder
  (:func:`rotor_avc.output_files.partial_name`), flushes it to the disk (``fsync``), renames it
  over the final name and syncs the folder: the final name holds the old file or the new one,
  never a part.
* **Failures.** An ``OSError`` writing the folder (disk full, read-only file system, file-size
  limit, no permission) becomes an :class:`~rotor_avc.output_files.OutputError` naming the
  path, the cause and the fix; a failed write leaves no temporary file behind.
"""
from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path

from ..errors import ConfigError
from ..output_files import OutputError, output_errors, partial_name

LOCK_NAME = "study.lock"
#: what to do about a folder that holds something else than this study's results
FOREIGN_FIX = "give another --out, or delete that folder to start the study over"


@contextlib.contextmanager
def reading(path: Path):
    """Inside: an ``OSError`` is raised as a ConfigError of ``--out`` naming ``path``."""
    try:
        yield
    except OSError as exc:
        raise ConfigError("--out", f"cannot read {path}: {exc.strerror or exc}",
                          fix=FOREIGN_FIX) from None


def replace_file(path: Path, write) -> None:
    """Write ``path`` whole: ``write(binary_file)`` fills the temporary file, which is synced
    and renamed to ``path`` (module docstring)."""
    tmp = partial_name(path)
    try:
        with open(tmp, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        sync_folder(path.parent)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(exc, OSError):
            raise OutputError(path, exc) from None
        raise


def sync_folder(folder: Path) -> None:
    """``fsync`` a folder, so a rename in it survives a crash of the machine."""
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


class FolderLock:
    """The exclusive lock of a study folder (module docstring); :meth:`release` ends it."""

    def __init__(self, folder: Path):
        path = folder / LOCK_NAME
        with output_errors(path):
            self._fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(self._fd, 32, 0).decode("ascii", "replace").strip() or "unknown"
            os.close(self._fd)
            raise ConfigError("--out", f"{folder} is in use by another study (process {holder})",
                              fix="wait for that study to end, or give another --out") from None
        try:
            with output_errors(path):
                os.ftruncate(self._fd, 0)
                os.pwrite(self._fd, f"{os.getpid()}\n".encode(), 0)
        except BaseException:
            self.release()
            raise

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)                   # closing the descriptor drops the lock
            self._fd = None
