"""The journal of a study, ``journal.csv``: one line per finished point, appended as results
arrive (any order), so an interrupted study resumes from it.

Its first line names the study it belongs to (``# rotor-avc study journal, fingerprint
<sha256>``, the fingerprint of :func:`rotor_avc.studies.output.fingerprint`), the second holds
the column names (``index``, the axis labels, the record's fields, ``error``), every further line
one point. Each append is flushed to the disk (``fsync``); an append that fails is cut off again,
so the journal never holds a part of a line that a later append would continue.

Read back, nothing is trusted: a line cut off by an interruption (no line end) is dropped (the
point is computed again); any other line must be exactly what this study writes -- an index of
one of its points, given once, the axis values of that point, every cell in the spelling
:func:`cell` gives it (``true``/``false``, the shortest exact float), no record with an error.
Anything else is refused with the file, the line and the fix.
"""
from __future__ import annotations

import csv
import io
import os
import re
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..output_files import OutputError, output_errors
from .folder import FOREIGN_FIX, reading, replace_file
from .spec import Outcome

HEADER = "# rotor-avc study journal, fingerprint "
_INDEX = re.compile(r"0|[1-9][0-9]*")


def cell(value) -> str:
    """The text of a journal or table cell: ``""`` for None, ``true``/``false``, floats as
    ``repr`` (the shortest text that reads back bit for bit)."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def parse_cell(text: str, kind: type):
    """The value of a cell written by :func:`cell` for a field of type ``kind``; ValueError
    for any other spelling."""
    if text == "":
        return None
    if kind is bool:
        if text not in ("true", "false"):
            raise ValueError(f"{text!r} is not true or false")
        return text == "true"
    value = kind(text)
    if cell(value) != text:
        raise ValueError(f"{text!r} is not written as this study writes a {kind.__name__} "
                         f"({cell(value)!r})")
    return value


class Journal:
    """``journal.csv`` of a study with ``columns`` and ``fingerprint`` (module docstring)."""

    def __init__(self, path: Path, columns: list[str], fingerprint: str, labels: list[str],
                 fields: dict[str, type]):
        self.path = path
        self.columns = columns
        self.header = f"{HEADER}{fingerprint}\n{','.join(columns)}\n"
        self.labels = labels
        self.fields = fields
        self._fd = None
        self._size = 0

    # -- reading ------------------------------------------------------------------------------
    def _refuse(self, line: int | None, problem: str, fix: str = FOREIGN_FIX):
        where = f"{self.path}" + (f" line {line}" if line else "")
        return ConfigError("--out", f"{where}: {problem}", fix=fix)

    def read(self, points) -> dict[int, tuple[list[str], Outcome]]:
        """The checked lines of the journal: index -> (cells, outcome); cuts off a last line
        that has no line end."""
        if not self.path.exists():
            return {}
        with reading(self.path):
            data = self.path.read_bytes()
        end = data.rfind(b"\n") + 1
        if end != len(data):                              # an interrupted append
            with output_errors(self.path):
                os.truncate(self.path, end)
        data = data[:end]
        if not data:
            return {}
        if b"\0" in data:
            raise self._refuse(data[:data.index(b"\0")].count(b"\n") + 1, "holds NUL bytes")
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise self._refuse(data[:exc.start].count(b"\n") + 1, "is not UTF-8 text") from None
        lines = text.split("\n")[:-1]
        if not lines[0].startswith(HEADER):
            raise self._refuse(1, "is not the journal of a rotor-avc study (no "
                                  f"{HEADER.strip()!r} line: another program or an older version)")
        if lines[0] != self.header.split("\n")[0]:
            raise self._refuse(1, "belongs to another study (its fingerprint differs from this "
                                  "study's study.json)")
        if len(lines) < 2 or lines[1] != ",".join(self.columns):
            raise self._refuse(2, "has other columns than this study")
        done: dict[int, tuple[list[str], Outcome]] = {}
        for number, line in enumerate(lines[2:], start=3):
            try:
                row = next(csv.reader([line], strict=True))
                index, outcome = self._check(row, points, done)
            except (ValueError, csv.Error, StopIteration) as exc:
                raise self._refuse(number, str(exc) or "an empty line", fix=(
                    f"delete that line (its point is computed again), or {FOREIGN_FIX}")) from None
            done[index] = (row, outcome)
        return done

    def _check(self, row: list[str], points, done) -> tuple[int, Outcome]:
        if len(row) != len(self.columns):
            raise ValueError(f"{len(row)} cells where the study has {len(self.columns)} columns")
        if not _INDEX.fullmatch(row[0]):
            raise ValueError(f"index {row[0]!r} is not a point number")
        index = int(row[0])
        if index in done:
            raise ValueError(f"point {index} is in the journal twice")
        try:
            point = points.point(index)
        except (IndexError, ValueError):
            raise ValueError(f"index {index} is not a point of this study") from None
        for k, label in enumerate(self.labels, start=1):
            if row[k] != cell(point.values[label]):
                raise ValueError(f"{label} = {row[k]!r}, but point {index} of this study has "
                                 f"{cell(point.values[label])!r}")
        first = 1 + len(self.labels)
        values = {}
        for (name, kind), text in zip(self.fields.items(), row[first:-1]):
            try:
                values[name] = parse_cell(text, kind)
            except ValueError as exc:
                raise ValueError(f"{name}: {exc}") from None
        error = row[-1] or None
        if error and any(v is not None for v in values.values()):
            raise ValueError("a failed point with record values")
        return index, Outcome(index, None if error else values, error)

    # -- writing ------------------------------------------------------------------------------
    def open(self) -> None:
        """Open for appending (a new journal is created whole, with its two header lines)."""
        if not self.path.exists() or self.path.stat().st_size == 0:
            replace_file(self.path, lambda fh: fh.write(self.header.encode()))
        with output_errors(self.path):
            self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)
            self._size = os.fstat(self._fd).st_size

    def append(self, rows: list[list[str]]) -> None:
        """Append ``rows`` and sync them to the disk; a failed append is cut off again."""
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerows(rows)
        payload = buf.getvalue().encode()
        data = memoryview(payload)
        try:
            while data:
                data = data[os.write(self._fd, data):]
            os.fsync(self._fd)
        except OSError as exc:
            try:
                os.ftruncate(self._fd, self._size)
            except OSError:
                pass                             # a cut-off last line is dropped when read
            raise OutputError(self.path, exc) from None
        self._size += len(payload)

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
