"""Was a graph run lockstep? The ``rotor_avc_lockstep`` record of a bag (DESIGN.md section 4).

A lockstep run of the ROS graph is the in-process loop only if the plant stepped every sample
with every responder's own answer to it. The plant (rotor_avc.nodes.plant_simulator) keeps
that account in a :class:`LockstepRecord` and reports it on ``/diagnostics`` (status
``<plant>: lockstep``, its values the record's keys); the recorder writes the last report it
took into the bag as the ``rotor_avc_lockstep`` metadata record (next to ``rotor_avc_counts``),
so the bag itself says whether it is a lockstep run. What breaks it:

* a fault policy acted (``hold``, ``zero``: the plant stepped on without an answer): the
  samples at which it stood in for an answer (``substituted_at``);
* a responder answered a sample it had already answered with a different value (a resend or a
  late answer that changed: two streams, a restarted node): the samples (``changed_at``);
* a responder was absent, left the graph or never connected (``absent <name>``: why);
* more than one plant reported on the namespace (``other_plants``);
* the run ended early (``ended``: why).

``rotor-avc bag check`` turns a record with any of these into a failed line, ``rotor-avc
compare`` refuses to rate the run (:class:`NotLockstepError`, exit status
:data:`EXIT_NOT_LOCKSTEP`) and ``rotor-avc replay --check`` fails. A bag without the record (the
in-process simulator's, a recording of another source) says nothing about it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

from ..errors import RotorAvcError
from .errors import BagError

LOCKSTEP_RECORD = "rotor_avc_lockstep"
#: name suffix of the plant's diagnostic status that carries the record's values
LOCKSTEP_SUFFIX = ": lockstep"
#: at most this many sample ranges are kept per kind (the counts are always whole)
RANGES_KEPT = 100
#: exit status of a command refusing to rate a run that was not lockstep
EXIT_NOT_LOCKSTEP = 6
_ABSENT = "absent "


class SampleRanges:
    """Sample indices, added in increasing order, kept as ``first-last`` ranges (the first
    :data:`RANGES_KEPT` of them; ``count`` counts every sample)."""

    def __init__(self):
        self.count = 0
        self.ranges: list[list[int]] = []
        self.more = 0                          # ranges beyond RANGES_KEPT
        self._last = None

    def add(self, k: int) -> None:
        """Sample ``k`` (adding the last one again is a no-op)."""
        if k == self._last:
            return
        if self._last is not None and k == self._last + 1:
            if not self.more:
                self.ranges[-1][1] = k
        elif len(self.ranges) < RANGES_KEPT:
            self.ranges.append([k, k])
        else:
            self.more += 1
        self._last = k
        self.count += 1

    @property
    def text(self) -> str:
        """``"12-1680, 2000"`` (and how many ranges more)."""
        return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in self.ranges) + (
            f" and {self.more} more range(s)" if self.more else "")


@dataclass
class LockstepRecord:
    """What the plant says about a run's lockstep (see the module docstring)."""

    plant: str
    mode: str
    fault_policy: str
    samples: int
    substituted: int = 0
    substituted_at: str = ""
    changed: int = 0
    changed_at: str = ""
    absent: dict[str, str] = field(default_factory=dict)
    other_plants: str = ""
    ended: str = ""

    def problems(self) -> list[str]:
        """One sentence per way the run departed from lockstep (empty: it did not)."""
        out = []
        if self.substituted:
            out.append(f"the fault policy {self.fault_policy!r} stood in for missing answers at "
                       f"{self.substituted} sample(s): {self.substituted_at}")
        if self.changed:
            out.append(f"answers changed after they were given at {self.changed} sample(s): "
                       f"{self.changed_at}")
        out += [f"{name} {why}" for name, why in sorted(self.absent.items())]
        if self.other_plants:
            out.append(f"other plants reported on the namespace: {self.other_plants}")
        if self.ended:
            out.append(f"the run ended early: {self.ended}")
        return out

    @property
    def ok(self) -> bool:
        return not self.problems()

    def verdict(self) -> str:
        """One line: lockstep, or why not."""
        where = f"{self.plant} ({self.mode}, fault_policy {self.fault_policy}, {self.samples} " \
                "samples)"
        if self.ok:
            return f"{where}: every sample stepped with every responder's own answer"
        return f"{where}: NOT LOCKSTEP -- " + "; ".join(self.problems())

    def encode(self) -> dict[str, str]:
        """The record (and the diagnostic status values): strings only."""
        out = {"plant": self.plant, "mode": self.mode, "fault_policy": self.fault_policy,
               "samples": str(self.samples), "substituted_samples": str(self.substituted),
               "substituted_at": self.substituted_at, "changed_samples": str(self.changed),
               "changed_at": self.changed_at, "other_plants": self.other_plants,
               "ended": self.ended}
        out.update({_ABSENT + name: why for name, why in self.absent.items()})
        return out

    @classmethod
    def decode(cls, record: Mapping[str, str], path) -> "LockstepRecord":
        """Inverse of :meth:`encode`; a damaged record is a BagError naming the key."""
        try:
            return cls(record["plant"], record["mode"], record["fault_policy"],
                       int(record["samples"]), int(record["substituted_samples"]),
                       record["substituted_at"], int(record["changed_samples"]),
                       record["changed_at"],
                       {k[len(_ABSENT):]: v for k, v in record.items() if k.startswith(_ABSENT)},
                       record.get("other_plants", ""), record.get("ended", ""))
        except (KeyError, ValueError) as exc:
            raise BagError(path, f"the lockstep record is unreadable ({exc!r})",
                           fix="the bag's metadata is damaged; re-record the run") from None


def merge_reports(reports: Mapping[str, Mapping[str, str]]) -> LockstepRecord | None:
    """The record of a recording from the plants' last reports (node -> status values): the one
    plant's, or, when several plants reported, the one with the most samples naming the others
    (None when no plant reported; an unreadable report is a BagError)."""
    if not reports:
        return None
    records = {node: LockstepRecord.decode(values, f"(the lockstep report of {node})")
               for node, values in reports.items()}
    main = max(records, key=lambda n: records[n].samples)
    record = records[main]
    record.other_plants = ", ".join(sorted(n for n in records if n != main))
    return record


class NotLockstepError(RotorAvcError):
    """A recording whose plant stepped without every answer: no lockstep comparison of it."""

    exit_status = EXIT_NOT_LOCKSTEP

    def __init__(self, path, record: LockstepRecord):
        self.record = record
        super().__init__(f"{path}: not a lockstep run, so it is not rated against the sampled "
                         f"loop -- {record.verdict()} -- fix: record it again with fault_policy "
                         "wait (the plant's default), with every responder running")


def read_lockstep(metadata: Mapping[str, Mapping[str, str]], path) -> LockstepRecord | None:
    """The lockstep record of a bag's metadata records (None: the bag has none)."""
    record = metadata.get(LOCKSTEP_RECORD)
    return None if record is None else LockstepRecord.decode(record, path)


def require_lockstep(metadata: Mapping[str, Mapping[str, str]], path) -> LockstepRecord | None:
    """:func:`read_lockstep`, raising :class:`NotLockstepError` unless the run was lockstep."""
    record = read_lockstep(metadata, path)
    if record is not None and not record.ok:
        raise NotLockstepError(path, record)
    return record
