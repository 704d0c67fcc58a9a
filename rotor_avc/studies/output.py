"""Incremental study results in a folder: a journal while the study runs, tables at the end.

* ``study.json`` -- what the study is (points, evaluator, configuration) and its fingerprint;
* ``journal.csv`` -- one line per finished point, appended (and flushed) as results arrive in
  any order: a study started again on the folder reads it and computes only the missing points
  (a line cut off by an interruption is dropped and recomputed). A sample's identity leaves out
  its number of points, so a study with a larger ``--n`` on the folder adds points to it, and
  one with a smaller ``--n`` reports the first ones;
* ``points.csv`` and ``points.npz`` -- every finished point in index order, rewritten (each
  file replaced whole) every :data:`SNAPSHOT_S` s or more while the study runs, and when it ends
  or is interrupted. Columns: ``index``, the axis values, the record's fields,
  ``error`` (empty when the point succeeded). The CSV holds floats in their shortest exact
  form (``repr``), so it reads back bit for bit.

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
import os
import time
import zipfile
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from .spec import Outcome, StudySpec

#: least time between two rewrites of the tables while a study runs (s); a rewrite that takes
#: long spaces the next one ten times its duration out
SNAPSHOT_S = 30.0


def fingerprint(spec: StudySpec) -> str:
    text = json.dumps({"points": spec.points.describe(), "evaluator": spec.evaluator.describe()},
                      sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _cell(value) -> str:
    if isinstance(value, np.generic):
        value = value.item()
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _parse(text: str, kind: type):
    if text == "":
        return None
    if kind is bool:
        return text == "true"
    return kind(text)


class ResultStore:
    """The output folder of one study (see the module docstring)."""

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
        manifest = {"fingerprint": fingerprint(spec), "columns": self.columns,
                    "points": spec.points.describe(), "evaluator": spec.evaluator.describe()}
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "study.json"
        self.journal = folder / "journal.csv"
        if path.exists():
            old = json.loads(path.read_text())
            if old.get("fingerprint") != manifest["fingerprint"]:
                raise ConfigError("--out", f"{folder} holds the results of a different study",
                                  fix="give another --out folder, or delete that one to start over")
        else:
            path.write_text(json.dumps(manifest, indent=1, default=str) + "\n")
        self.rows: dict[int, list[str]] = {}
        self.done = self._read_journal()
        self._next_snapshot = time.monotonic() + SNAPSHOT_S
        self._fh = open(self.journal, "a", newline="")
        if self._fh.tell() == 0:
            self._fh.write(",".join(self.columns) + "\n")
            self._fh.flush()

    # -- journal ------------------------------------------------------------------------------
    def _row(self, o: Outcome) -> list[str]:
        point = self.spec.points.point(o.index).values
        record = o.record or {}
        unknown = set(record) - set(self.fields)
        if unknown:
            raise ValueError(f"record fields {sorted(unknown)} are not declared by the evaluator")
        return ([str(o.index)] + [_cell(point[lab]) for lab in self.labels]
                + [_cell(record.get(f)) for f in self.fields] + [o.error or ""])

    def _read_journal(self) -> dict[int, Outcome]:
        if not self.journal.exists():
            return {}
        text = self.journal.read_text()
        complete = text[:text.rfind("\n") + 1]           # a cut-off last line is dropped
        if len(complete) != len(text):
            self.journal.write_text(complete)
        lines = complete.splitlines()
        if not lines:
            return {}
        if lines[0].split(",") != self.columns:
            raise ConfigError("--out", f"{self.journal} has other columns than this study",
                              fix="give another --out folder, or delete that one to start over")
        kinds = list(self.fields.values())
        first = 1 + len(self.labels)
        done = {}
        for row in csv.reader(lines[1:]):
            index, error = int(row[0]), row[-1] or None
            if index >= len(self.spec.points):           # a larger study of the same points
                continue
            record = None if error else {
                f: _parse(v, k) for f, v, k in zip(self.fields, row[first:-1], kinds)}
            done[index] = Outcome(index, record, error)
            self.rows[index] = row
        return done

    def append(self, outcomes: list[Outcome]) -> None:
        """Journal finished points (and rewrite the tables when a snapshot is due)."""
        if not outcomes:
            return
        rows = [self._row(o) for o in outcomes]
        for o, row in zip(outcomes, rows):
            self.done[o.index] = o
            self.rows[o.index] = row
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerows(rows)
        self._fh.write(buf.getvalue())
        self._fh.flush()
        if time.monotonic() >= self._next_snapshot:
            start = time.monotonic()
            self.write_tables()
            self._next_snapshot = time.monotonic() + max(SNAPSHOT_S, 10 * (time.monotonic() - start))

    # -- tables -------------------------------------------------------------------------------
    def finish(self) -> list[Path]:
        """Close the journal and write the tables."""
        self._fh.close()
        return self.write_tables()

    def write_tables(self) -> list[Path]:
        """``points.csv`` and ``points.npz`` of the finished points in index order."""
        order = sorted(self.done)
        outcomes = [self.done[i] for i in order]
        rows = [self.rows[i] for i in order]
        csv_path = self.folder / "points.csv"
        with open(csv_path.with_suffix(".csv.part"), "w", newline="") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(self.columns)
            w.writerows(rows)
        os.replace(csv_path.with_suffix(".csv.part"), csv_path)
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
        write_npz(npz_path.with_suffix(".npz.part"), columns)
        os.replace(npz_path.with_suffix(".npz.part"), npz_path)
        return [csv_path, npz_path]


def write_npz(path: Path, columns: dict[str, np.ndarray]) -> None:
    """``numpy.savez`` with a fixed entry date (equal arrays give equal bytes)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, array in columns.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with zf.open(info, "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.asarray(array), allow_pickle=False)
