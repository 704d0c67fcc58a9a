"""Is a bag what its index, statistics and schemas say? One streaming pass over the data.

A reader that seeks through an MCAP file by its index (this package's series path, Foxglove,
``ros2 bag play``) trusts the message indexes, chunk indexes and statistics. :func:`scan_bag`
checks them instead of trusting them: it reads the file record by record (:mod:`.records`,
one chunk in memory at a time, so memory is independent of the file's size) and compares what
the **data** holds with

* the CRCs: each chunk's CRC of its uncompressed records, the data-section CRC of the DataEnd
  record and the summary CRC of the Footer, where the writer stored them (non-zero);
* each chunk's MessageIndex records (every message's log time and offset, per channel) and the
  chunk's own start/end times;
* the summary: schemas and channels, the Statistics record (message count, per-channel counts,
  start/end times, chunk, schema, channel and metadata counts), the ChunkIndex records (offset,
  length, times, message-index offsets, compression, sizes) and the MetadataIndex records;
* the ``rosbag2`` metadata record (``metadata.yaml``: per-topic types and counts, start,
  duration, QoS strings) and the package's ``rotor_avc_counts`` record (messages recorded);
* the schemas: every message decodes with the ``ros2msg`` text its channel names; for a type
  whose standard definition the package knows (:mod:`.msgdefs`) the text defines exactly that
  type; the channel's ``topic_type_hash`` (RIHS01) is the hash of that text; a topic of the
  package (:mod:`.topics`) in a bag of the package carries its own type (:mod:`.schema_check`);
* duplicates, per topic: the same log time and the same bytes twice, and two different messages
  for one sample (same log time) on a sampled topic (:data:`.topics.SAMPLED`). The lockstep
  plant resends an unanswered sample, so up to :data:`RESENDS_ALLOWED` of a sampled topic's
  messages may repeat one (a bag written twice repeats every one of them).

Missing samples are :mod:`.sequence`'s job (it reads the message indexes, which this pass
proves right). :func:`verify` raises :class:`~.errors.CorruptBagError` (exit status 4) listing
the problems with where they are (topic, record offset, sample time).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mcap.records import Channel, Schema

from .errors import BagError, CorruptBagError

#: share of a sampled topic's messages that may repeat a sample (lockstep resends)
RESENDS_ALLOWED = 0.01
#: problems kept in a report (the total is counted)
PROBLEMS_KEPT = 25


@dataclass(frozen=True)
class Problem:
    check: str                 # short name: crc, message_index, statistics, schema, ...
    where: str                 # topic, record offset, sample time
    detail: str

    def __str__(self) -> str:
        return f"{self.check}: {self.where}: {self.detail}"


@dataclass
class TopicData:
    """What the data holds for one channel."""

    topic: str
    msg_type: str
    channel_id: int
    count: int = 0
    start_ns: int | None = None
    end_ns: int | None = None
    duplicates: int = 0        # same log time, same bytes as a message before it
    conflicts: int = 0         # same log time, other bytes (sampled topics)
    backwards: int = 0         # log time earlier than the topic's message before it
    first_repeat_ns: dict[str, int] = field(default_factory=dict)   # kind -> first log time
    last: tuple[int, bytes] | None = None

    @property
    def duration_s(self) -> float:
        return 0.0 if self.count < 2 else (self.end_ns - self.start_ns) * 1e-9

    @property
    def rate_hz(self) -> float:
        return (self.count - 1) / self.duration_s if self.duration_s > 0 else 0.0


@dataclass
class IntegrityReport:
    path: Path
    profile: str = ""
    library: str = ""
    size_bytes: int = 0
    topics: dict[int, TopicData] = field(default_factory=dict)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    chunks: int = 0
    compressions: set = field(default_factory=set)
    chunks_without_index: int = 0
    messages_outside_chunks: int = 0
    crcs: dict[str, str] = field(default_factory=dict)    # what -> "checked"/"absent"
    summary: dict[str, bool] = field(default_factory=dict)  # statistics, chunk_indexes, ...
    undecodable: dict[str, str] = field(default_factory=dict)    # topic -> why
    problems: list[Problem] = field(default_factory=list)
    problem_count: int = 0

    @property
    def ok(self) -> bool:
        return self.problem_count == 0

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics.values())

    def by_topic(self) -> dict[str, TopicData]:
        return {t.topic: t for t in self.topics.values()}

    def add(self, check: str, where: str, detail: str) -> None:
        self.problem_count += 1
        if len(self.problems) < PROBLEMS_KEPT:
            self.problems.append(Problem(check, where, detail))

    def verdict(self) -> str:
        lines = [str(p) for p in self.problems]
        if self.problem_count > len(self.problems):
            lines.append(f"... and {self.problem_count - len(self.problems)} more problem(s)")
        return "\n".join(lines)


def verify(path) -> IntegrityReport:
    """:func:`scan_bag`, raising :class:`CorruptBagError` unless the bag is consistent."""
    report = scan_bag(path)
    if not report.ok:
        raise CorruptBagError(report.path, report.problem_count, report.verdict())
    return report


def scan_bag(path) -> IntegrityReport:
    """The integrity report of the ``.mcap`` file ``path`` (see the module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise BagError(path, "no such bag file", fix="check the path")
    from .integrity_pass import _Pass      # imported here: it imports this module's types
    with open(path, "rb") as f:
        return _Pass(path, f).run()
