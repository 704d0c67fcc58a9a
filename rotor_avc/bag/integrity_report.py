"""The integrity pass's report: problems found, per-topic data, the verdict."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mcap.records import Channel, Schema


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
