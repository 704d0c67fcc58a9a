"""Incremental study results in a folder: a journal while the study runs, tables at the end.

* ``study.json`` -- what the study is (points, evaluator, configuration, columns) and its
  fingerprint, the SHA-256 of all that in canonical JSON;
* ``journal.csv`` -- one line per finished point, appended (and synced) as results arrive in
  any order, below a line with the fingerprint (:mod:`rotor_avc.studies.journal`): a study
  started again on the folder checks every line against its own points and computes only the
  missing ones (a line cut off by an interruption is dropped and recomputed; a foreign or
  damaged folder is refused with the file, the line and the fix). A sample's identity leaves
  out its number of points, so a study with a larger ``--n`` on the folder adds points to it,
  and one with a smaller ``--n`` reports the first ones;
* ``points.csv`` and ``points.npz`` -- every finished point in index order, rewritten every
  :data:`SNAPSHOT_S` s or more while the study runs, and when it ends or is interrupted.
  Columns: ``index``, the axis values, the record's fields, ``error`` (empty when the point
  succeeded). The CSV holds floats in their shortest exact form (``repr``), so it reads back
  bit for bit;
* ``study.lock`` -- held by the study that runs on the folder (:mod:`rotor_avc.studies.folder`:
  one study at a time, every file replaced whole, the operating system's failures as one line).

``points.npz`` is the columnar copy, one array per column (numbers as float64 with NaN where a
value is missing, text as unicode): ``numpy.load`` opens it, and
``pandas.DataFrame(dict(numpy.load("points.npz")))`` makes it a table. It needs nothing beyond
numpy; Parquet would need pyarrow (a 55 MB wheel, about numpy's and scipy's together) for the
same arrays. Its zip entries carry a fixed date, so equal results give equal bytes.
"""
from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import time
import zipfile
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..output_files import output_errors
from .folder import FOREIGN_FIX, FolderLock, reading, replace_file
from .journal import Journal, cell
from .spec import Outcome, StudySpec

#: least time between two rewrites of the tables while a study runs (s); a rewrite that takes
#: long spaces the next one ten times its duration out
SNAPSHOT_S = 30.0
#: the version of the folder's layout (part of the fingerprint)
LAYOUT = 2


def _canonical(value):
    """JSON for what ``json`` does not know: arrays in full (``str`` would abbreviate them)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (set, frozenset)):
        return sorted(value, key=repr)
    return str(value)


def manifest(spec: StudySpec) -> dict:
    """``study.json``: the study's identity (points, evaluator, columns) and its fingerprint."""
    fields = {name: kind.__name__ for name, kind in spec.evaluator.fields.items()}
    identity = {"layout": LAYOUT, "points": spec.points.describe(),
                "evaluator": spec.evaluator.describe(), "labels": list(spec.points.labels),
                "fields": fields}
    text = json.dumps(identity, sort_keys=True, default=_canonical, allow_nan=True)
    return {"fingerprint": hashlib.sha256(text.encode()).hexdigest(), **json.loads(text)}


class ResultStore:
    """The output folder of one study (see the module docstring), locked while it is open;
    :meth:`finish` writes the tables and releases it."""

    def __init__(self, folder: Path, spec: StudySpec):
        fields = spec.evaluator.fields
        if fields is None:
            raise ConfigError("--out", "this study's records are arrays, not table rows",
                              fix="run it without a results folder")
        self.folder = folder
        self.labels = list(spec.points.labels)
        self.fields = dict(fields)
        self.columns = ["index"] + self.labels + list(self.fields) + ["error"]
        self.spec = spec
        with output_errors(folder):
            folder.mkdir(parents=True, exist_ok=True)
        self._lock = FolderLock(folder)
        try:
            study = manifest(spec)
            self._check_manifest(folder / "study.json", study)
            self.journal = Journal(folder / "journal.csv", self.columns, study["fingerprint"],
                                   self.labels, self.fields)
            read = self.journal.read(spec.points)
            n = len(spec.points)                       # a larger sample's points are kept
            self.rows = {i: row for i, (row, _) in read.items() if i < n}
            self.done = {i: outcome for i, (_, outcome) in read.items() if i < n}
            self.journal.open()
        except BaseException:
            self._lock.release()
            raise
        self._next_snapshot = time.monotonic() + SNAPSHOT_S

    @staticmethod
    def _check_manifest(path: Path, study: dict) -> None:
        """Refuse a ``study.json`` of another study or a damaged one; write a missing one."""
        if not path.exists():
            replace_file(path, lambda fh: fh.write(
                (json.dumps(study, indent=1) + "\n").encode()))
            return
        with reading(path):
            data = path.read_bytes()
        try:
            old = json.loads(data.decode("utf-8"))
            found = old["fingerprint"]
        except (UnicodeDecodeError, ValueError, TypeError, KeyError):
            raise ConfigError("--out", f"{path} is damaged (not the JSON of a study)",
                              fix=FOREIGN_FIX) from None
        if found != study["fingerprint"]:
            raise ConfigError("--out", f"{path.parent} holds the results of a different study "
                                       f"({path.name} has another fingerprint)", fix=FOREIGN_FIX)

    # -- journal ------------------------------------------------------------------------------
    def _row(self, o: Outcome) -> list[str]:
        point = self.spec.points.point(o.index).values
        record = o.record or {}
        unknown = set(record) - set(self.fields)
        if unknown:
            raise ValueError(f"record fields {sorted(unknown)} are not declared by the evaluator")
        return ([str(o.index)] + [cell(point[lab]) for lab in self.labels]
                + [cell(record.get(f)) for f in self.fields] + [o.error or ""])

    def append(self, outcomes: list[Outcome]) -> None:
        """Journal finished points (and rewrite the tables when a snapshot is due)."""
        if not outcomes:
            return
        rows = [self._row(o) for o in outcomes]
        self.journal.append(rows)
        for o, row in zip(outcomes, rows):
            self.done[o.index] = o
            self.rows[o.index] = row
        if time.monotonic() >= self._next_snapshot:
            start = time.monotonic()
            self.write_tables()
            self._next_snapshot = time.monotonic() + max(SNAPSHOT_S, 10 * (time.monotonic() - start))

    # -- tables -------------------------------------------------------------------------------
    def finish(self) -> list[Path]:
        """Close the journal, write the tables and release the folder."""
        try:
            self.journal.close()
            return self.write_tables()
        finally:
            self._lock.release()

    def write_tables(self) -> list[Path]:
        """``points.csv`` and ``points.npz`` of the finished points in index order."""
        order = sorted(self.done)
        outcomes = [self.done[i] for i in order]
        rows = [self.rows[i] for i in order]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        w.writerows(rows)
        csv_path = self.folder / "points.csv"
        replace_file(csv_path, lambda fh: fh.write(buf.getvalue().encode()))
        columns = {"index": np.array([o.index for o in outcomes], dtype=np.int64)}
        for k, lab in enumerate(self.labels, start=1):
            columns[lab] = np.array([float(r[k]) for r in rows], dtype=float)
        for f, kind in self.fields.items():
            values = [None if o.record is None else o.record.get(f) for o in outcomes]
            columns[f] = (np.array(["" if v is None else v for v in values], dtype=str)
                          if kind is str else
                          np.array([math.nan if v is None else float(v) for v in values]))
        columns["error"] = np.array([o.error or "" for o in outcomes], dtype=str)
        npz_path = self.folder / "points.npz"
        replace_file(npz_path, lambda fh: write_npz(fh, columns))
        return [csv_path, npz_path]


def write_npz(fh, columns: dict[str, np.ndarray]) -> None:
    """``numpy.savez`` into the binary file ``fh`` with a fixed entry date (equal arrays give
    equal bytes)."""
    with zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, array in columns.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with zf.open(info, "w", force_zip64=True) as out:
                np.lib.format.write_array(out, np.asarray(array), allow_pickle=False)
