"""What a bag holds, from its summary section alone: ``rotor-avc bag info`` without the data.

An MCAP file ends with a summary (https://mcap.dev/spec): the schemas and channels, a Statistics
record (message count, per-channel counts, start and end time, chunk count), a ChunkIndex per
chunk (offset, times, compression, where its message indexes are) and a MetadataIndex per
metadata record, then a Footer pointing at it with the summary's CRC. :func:`read_summary`
reads the header, the footer and the summary -- and, for each topic's first and last log time,
the message indexes of the chunks that can hold them (usually two per topic) -- so its time and
memory do not depend on the file's size. It trusts the summary as every seeking reader does
(``ros2 bag info``, Foxglove); what it checks is that the summary is there and whole: its CRC
(where the writer stored one), its records parse, the statistics agree with the channels and
chunk indexes. A missing or damaged summary is one :class:`~.errors.BagError` suggesting the
full integrity pass (:mod:`.integrity`, ``bag info --integrity``) or ``bag recover``.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.records import Channel, ChunkIndex, MetadataIndex, Schema, Statistics

from . import records as R
from .errors import EXIT_CORRUPT, BagError, no_such_bag
from .mcap_writer import MAGIC

_FOOTER = struct.Struct("<BQQQI")            # opcode, length 20, summary start, offsets, CRC
SUMMARY_FIX = ("`rotor-avc bag info --integrity BAG` reads the data itself; `rotor-avc bag "
               "recover BAG` rebuilds the summary from every intact chunk")
_CHUNK_INDEX_HEAD = struct.Struct("<QQQQI")   # times, chunk offset and length, index bytes
_INDEX_ENTRY = struct.Struct("<HQ")           # channel id, message index offset


def _chunk_index(body: bytes) -> ChunkIndex:
    """A ChunkIndex record from its body (mcap's own reader takes several times longer, which
    counts with thousands of chunks)."""
    start, end, offset, length, nbytes = _CHUNK_INDEX_HEAD.unpack_from(body, 0)
    at = _CHUNK_INDEX_HEAD.size
    if nbytes % _INDEX_ENTRY.size or at + nbytes > len(body):
        raise ValueError(f"message index offsets of {nbytes} bytes")
    entries = dict(_INDEX_ENTRY.iter_unpack(body[at:at + nbytes]))
    index_length, clen = struct.unpack_from("<QI", body, at + nbytes)
    at += nbytes + 12
    compression = body[at:at + clen].decode()
    compressed, uncompressed = struct.unpack_from("<QQ", body, at + clen)
    return ChunkIndex(chunk_length=length, chunk_start_offset=offset, compression=compression,
                      compressed_size=compressed, message_end_time=end,
                      message_index_length=index_length,
                      message_index_offsets=entries,
                      message_start_time=start, uncompressed_size=uncompressed)


#: how each summary record :func:`read_summary` uses is read from its body
_PARSED = {op: (lambda body, cls=cls: cls.read(ReadDataStream(BytesIO(body))))
           for op, cls in ((R.OP_SCHEMA, Schema), (R.OP_CHANNEL, Channel),
                           (R.OP_STATISTICS, Statistics), (R.OP_METADATA_INDEX, MetadataIndex))}
_PARSED[R.OP_CHUNK_INDEX] = _chunk_index


class DamagedSummaryError(BagError):
    """The summary section is there but damaged or inconsistent (exit status 4)."""

    exit_status = EXIT_CORRUPT


@dataclass(frozen=True)
class TopicSummary:
    topic: str
    msg_type: str
    count: int
    start_ns: int | None           # first and last log time (None: no message index says)
    end_ns: int | None

    @property
    def rate_hz(self) -> float | None:
        if self.start_ns is None or self.end_ns is None:
            return None
        span_s = (self.end_ns - self.start_ns) * 1e-9
        return (self.count - 1) / span_s if self.count > 1 and span_s > 0 else 0.0


@dataclass
class BagSummary:
    path: Path
    size_bytes: int
    profile: str
    library: str
    statistics: Statistics
    summary_crc: str                                   # "checked" or "absent"
    topics: list[TopicSummary] = field(default_factory=list)
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)
    metadata_names: list[str] = field(default_factory=list)

    @property
    def duration_s(self) -> float:
        s = self.statistics
        return (s.message_end_time - s.message_start_time) * 1e-9 if s.message_count else 0.0

    @property
    def compressions(self) -> set[str]:
        return {ci.compression or "none" for ci in self.chunk_indexes}


def read_summary(path) -> BagSummary:
    """The :class:`BagSummary` of the ``.mcap`` file ``path`` (see the module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise no_such_bag(path)
    size = path.stat().st_size
    with open(path, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise BagError(path, "not an MCAP file (wrong magic bytes)" if size else
                           "empty file (0 bytes)", fix="give a .mcap bag written by rosbag2 "
                           "or rotor_avc")
        footer_at = size - len(MAGIC) - _FOOTER.size
        f.seek(max(footer_at, 0))
        tail = f.read()
        if footer_at < len(MAGIC) or tail[-len(MAGIC):] != MAGIC or tail[0] != R.OP_FOOTER:
            raise BagError(path, "no summary: the file ends without the MCAP footer (a "
                           "recording that was interrupted)", fix=SUMMARY_FIX)
        _, _, start, _, crc = _FOOTER.unpack_from(tail)
        if start == 0:
            raise BagError(path, "the file has no summary section (its writer left it out)",
                           fix=SUMMARY_FIX)
        if not len(MAGIC) < start <= footer_at:
            raise DamagedSummaryError(path, f"damaged footer: the summary would start at byte "
                                      f"{start} of {size}", fix=SUMMARY_FIX)
        f.seek(start)
        body = f.read(footer_at - start)
        if crc and zlib.crc32(tail[:_FOOTER.size - 4], zlib.crc32(body)) != crc:
            raise DamagedSummaryError(path, "damaged summary: its CRC does not match",
                                      fix=SUMMARY_FIX)
        records = _summary_records(f, start, footer_at, path)
        summary = BagSummary(path, size, *_header(f, size, path), _statistics(records, path),
                             "checked" if crc else "absent",
                             chunk_indexes=sorted(records[R.OP_CHUNK_INDEX],
                                                  key=lambda c: c.chunk_start_offset),
                             metadata_names=[m.name for m in records[R.OP_METADATA_INDEX]])
        _check(summary, records, start)
        summary.topics = [_topic(f, summary, ch, records) for ch in records[R.OP_CHANNEL]]
    return summary


def _header(f, size: int, path: Path) -> tuple[str, str]:
    """(profile, library) of the Header record."""
    try:
        rec = next(R.scan(f, size))
        if rec.opcode != R.OP_HEADER:
            raise ValueError("the first record is not the header")
        stream = ReadDataStream(BytesIO(rec.body))
        return stream.read_prefixed_string(), stream.read_prefixed_string()
    except (StopIteration, *R.READ_ERRORS) as exc:
        raise DamagedSummaryError(path, f"damaged header ({exc})", fix=SUMMARY_FIX) from None


def _summary_records(f, start: int, end: int, path: Path) -> dict[int, list]:
    """The records of the summary (bytes ``start`` to ``end``) by opcode, those
    :data:`_PARSED` reads."""
    out: dict[int, list] = {op: [] for op in _PARSED}
    try:
        for rec in R.scan(f, end, start=start):
            if rec.opcode in _PARSED:
                out[rec.opcode].append(_PARSED[rec.opcode](rec.body))
    except R.READ_ERRORS as exc:
        raise DamagedSummaryError(path, f"damaged summary ({exc})", fix=SUMMARY_FIX) from None
    return out


def _statistics(records: dict[int, list], path: Path) -> Statistics:
    found = records[R.OP_STATISTICS]
    if not found:
        raise BagError(path, "the summary has no statistics record (its writer left it out)",
                       fix=SUMMARY_FIX)
    if len(found) > 1:
        raise DamagedSummaryError(path, f"damaged summary: {len(found)} statistics records",
                                  fix=SUMMARY_FIX)
    return found[0]


def _check(summary: BagSummary, records: dict[int, list], summary_start: int) -> None:
    """Refuse a summary that contradicts itself."""
    stats = summary.statistics
    schemas = {s.id for s in records[R.OP_SCHEMA]}
    channels = {c.id for c in records[R.OP_CHANNEL]}
    problems = []
    if sum(stats.channel_message_counts.values()) != stats.message_count:
        problems.append(f"the statistics count {stats.message_count} messages, their channels "
                        f"{sum(stats.channel_message_counts.values())}")
    if set(stats.channel_message_counts) - channels:
        problems.append("the statistics count messages of channels the summary does not list")
    if any(c.schema_id and c.schema_id not in schemas for c in records[R.OP_CHANNEL]):
        problems.append("a channel names a schema the summary does not hold")
    if summary.chunk_indexes and len(summary.chunk_indexes) != stats.chunk_count:
        problems.append(f"{len(summary.chunk_indexes)} chunk indexes for "
                        f"{stats.chunk_count} chunks")
    if any(not len(MAGIC) <= ci.chunk_start_offset < summary_start
           or any(not ci.chunk_start_offset < at < summary_start
                  for at in ci.message_index_offsets.values())
           for ci in summary.chunk_indexes):
        problems.append("a chunk index points outside the data section")
    if problems:
        raise DamagedSummaryError(summary.path, "damaged summary: " + "; ".join(problems),
                                  fix=SUMMARY_FIX)


def _topic(f, summary: BagSummary, channel: Channel, records) -> TopicSummary:
    schema = next((s for s in records[R.OP_SCHEMA] if s.id == channel.schema_id), None)
    count = summary.statistics.channel_message_counts.get(channel.id, 0)
    span = _span(f, summary, channel.id) if count else (None, None)
    return TopicSummary(channel.topic, schema.name if schema else "", count, *span)


def _span(f, summary: BagSummary, cid: int) -> tuple[int | None, int | None]:
    """The channel's first and last log time from the message indexes of the chunks that can
    hold them: the earliest-starting chunk with the channel, then any other chunk starting
    before that chunk's first message of it (chunks may overlap), and alike for the end."""
    chunks = [ci for ci in summary.chunk_indexes if cid in ci.message_index_offsets]
    if not chunks or any(not ci.message_index_offsets for ci in summary.chunk_indexes):
        return None, None                      # no message indexes to say which chunk has it
    first = min(chunks, key=lambda c: c.message_start_time)
    start = int(_index_times(f, summary, first, cid).min())
    for ci in chunks:
        if ci is not first and ci.message_start_time < start:
            start = min(start, int(_index_times(f, summary, ci, cid).min()))
    last = max(chunks, key=lambda c: c.message_end_time)
    end = int(_index_times(f, summary, last, cid).max())
    for ci in chunks:
        if ci is not last and ci.message_end_time > end:
            end = max(end, int(_index_times(f, summary, ci, cid).max()))
    return start, end


def _index_times(f, summary: BagSummary, ci: ChunkIndex, cid: int) -> np.ndarray:
    """The log times of channel ``cid``'s MessageIndex record of chunk ``ci``."""
    at = ci.message_index_offsets[cid]
    try:
        rec = next(R.scan(f, summary.size_bytes, start=at))
        channel, nbytes = struct.unpack_from("<HI", rec.body, 0)
        if rec.opcode != R.OP_MESSAGE_INDEX or channel != cid or nbytes != len(rec.body) - 6 \
                or not nbytes or nbytes % 16:
            raise ValueError("not the channel's message index")
    except (StopIteration, *R.READ_ERRORS) as exc:
        raise DamagedSummaryError(summary.path, f"the chunk index of the chunk at byte "
                                  f"{ci.chunk_start_offset} points at a damaged message index "
                                  f"(byte {at}: {exc})", fix=SUMMARY_FIX) from None
    return np.frombuffer(rec.body, "<u8", offset=6)[0::2]
