"""Recovering a bag: a new, finished file with every message of every intact chunk.

A recording that was killed ends inside its last chunk (the writer, :mod:`.mcap_writer`, puts
the schemas, channels and run configuration on disk first and flushes every chunk as soon as it
is full); a damaged file has chunks whose bytes fail their CRC or do not decompress.
:func:`recover_bag` walks the source record by record (:mod:`.records`, one chunk in memory at
a time, so memory does not grow with the file's size), copies every Schema, Channel and Metadata
record and every message of every chunk that is intact, and drops only what is damaged: a bad
chunk costs that chunk; a record whose length field itself is damaged is skipped by searching
the following bytes for the next chunk whose fixed fields are consistent. The new file gets a
fresh summary, indexes, statistics and ``rosbag2`` record; the package's ``rotor_avc_counts``
record is rewritten (recorded = kept, the rest counted as lost), so a comparison sees the gap.

The output is written under a temporary name and renamed when finished
(:func:`rotor_avc.output_files.writing`): an interrupted recovery (Ctrl-C) or a full disk leaves
no partial file, and the operating system's refusal is one line naming the output and the cause.
``mcap recover`` (the Go CLI) does a similar job.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Metadata, Schema, Statistics

from ..output_files import writing
from . import records as R
from .errors import BagError, no_such_bag
from .schema_check import hash_problem, standard_text_problem
from .mcap_writer import MAGIC, McapSink
from .msgdefs import full_text
from .metadata import COUNTS_RECORD, decode_counts, encode_counts, parse_qos_yaml, rosbag2_record
from .writer import LIBRARY

#: bytes read at a time while searching for the next intact chunk
_SEARCH_BLOCK = 1 << 20
_SKIPPED = (R.OP_MESSAGE_INDEX, R.OP_CHUNK_INDEX, R.OP_STATISTICS, R.OP_METADATA_INDEX,
            R.OP_SUMMARY_OFFSET, R.OP_ATTACHMENT)


@dataclass
class Recovery:
    """What :func:`recover_bag` kept and lost."""

    path: Path
    messages: int = 0
    dropped_bytes: int = 0                           # of the source's data section
    kept: dict[str, int] = field(default_factory=dict)      # per topic
    lost: dict[str, int] = field(default_factory=dict)      # per topic, where known
    lost_counted: bool = False      # True: ``lost`` is complete (the source's statistics)
    chunks_kept: int = 0
    lost_chunks: list[tuple[int, str]] = field(default_factory=list)   # (offset, why)
    notes: list[str] = field(default_factory=list)


def recover_bag(source, target=None, *, compression: str = "zstd") -> Recovery:
    """Write every intact message of ``source`` to the new file ``target`` (default
    ``<name>.recovered.mcap``); see the module docstring."""
    source = Path(source)
    target = Path(target) if target is not None else source.with_suffix(".recovered.mcap")
    if not source.is_file():
        raise no_such_bag(source)
    if target.exists() and target.resolve() == source.resolve():
        raise BagError(target, "the recovered bag must be a new file", fix="give another name")
    if target.exists():
        raise BagError(target, "the output file exists", fix="give a new --out name or delete it")
    if not target.parent.is_dir():
        raise BagError(target, "the output directory does not exist", fix="create it first")
    try:
        src = open(source, "rb")
    except OSError as exc:
        raise BagError(source, f"cannot read the file ({exc.strerror})", fix="check the path "
                       "and its permissions") from None
    with src, writing(target) as partial, open(partial, "wb") as out:
        result = _Recovery(source, src, out, target.name, compression).run()
    result.path = target
    return result


class _Recovery:
    def __init__(self, source: Path, src, out, name: str, compression: str):
        self.source, self.src, self.out, self.name = source, src, out, name
        self.size = source.stat().st_size
        self.compression = compression
        self.sink: McapSink | None = None
        self.schemas: dict[int, Schema] = {}
        self.schema_ids: dict[int, int] = {}
        self.channels: dict[int, Channel] = {}
        self.channel_ids: dict[int, int] = {}
        self.metadata: dict[str, dict[str, str]] = {}
        self.result = Recovery(Path(name))

    def run(self) -> Recovery:
        self.src.seek(0)
        if self.src.read(len(MAGIC)) != MAGIC:
            raise BagError(self.source, "not an MCAP file (wrong magic bytes)",
                           fix="nothing to recover")
        pos, crc = len(MAGIC), zlib.crc32(MAGIC)
        while pos < self.size:
            try:
                rec = next(R.scan(self.src, self.size, pos))
            except StopIteration:
                break
            except R.RecordError as exc:
                found = self._next_chunk(pos + 1)
                self._lose(pos, (found or self.size) - pos, str(exc))
                if found is None:
                    break
                pos = found
                continue
            if rec.opcode in (R.OP_DATA_END, R.OP_FOOTER):
                self._data_end(rec, crc)
                break                       # a finished data section: the summary is rebuilt
            self._record(rec)
            crc = zlib.crc32(rec.body, zlib.crc32(struct.pack("<BQ", rec.opcode, len(rec.body)),
                                                  crc))
            pos = rec.end
        if self.sink is None:
            raise BagError(self.source, "the file ends inside its MCAP header",
                           fix="nothing to recover")
        self._finish()
        return self.result

    def _data_end(self, rec, crc: int) -> None:
        """A data-section CRC that fails while every kept chunk passed its own CRC: a record
        outside the chunks (schema, channel, metadata) may be altered -- say so."""
        (claimed,) = struct.unpack_from("<I", rec.body) if len(rec.body) >= 4 else (0,)
        if rec.opcode == R.OP_DATA_END and claimed and claimed != crc \
                and not self.result.lost_chunks:
            self.result.notes.append("the source's data-section CRC does not match although "
                                     "every chunk is intact: a schema, channel or metadata "
                                     "record may be altered; check the configuration")

    # -- records ---------------------------------------------------------------------------
    def _record(self, rec) -> None:
        stream = ReadDataStream(BytesIO(rec.body))
        try:
            if rec.opcode == R.OP_HEADER:
                self.sink = McapSink(self.out, stream.read_prefixed_string(), LIBRARY,
                                     self.compression)
            elif rec.opcode == R.OP_SCHEMA:
                self._schema(Schema.read(stream))
            elif rec.opcode == R.OP_CHANNEL:
                self._channel(Channel.read(stream))
            elif rec.opcode == R.OP_METADATA:
                meta = Metadata.read(stream)
                self.metadata[meta.name] = dict(meta.metadata)
                if meta.name not in ("rosbag2", COUNTS_RECORD):
                    self._sink().add_metadata(meta.name, meta.metadata)
            elif rec.opcode == R.OP_MESSAGE:
                data = struct.pack("<BQ", R.OP_MESSAGE, len(rec.body)) + rec.body
                self._messages(R.chunk_messages(data), data)
            elif rec.opcode == R.OP_CHUNK:
                self._chunk(rec)
            elif rec.opcode not in _SKIPPED:
                self.result.notes.append(f"record at byte {rec.offset} "
                                         f"(opcode 0x{rec.opcode:02x}) skipped")
        except R.READ_ERRORS as exc:
            self._lose(rec.offset, rec.end - rec.offset, f"unreadable record ({exc})")

    def _sink(self) -> McapSink:
        if self.sink is None:
            raise ValueError("records before the MCAP header")
        return self.sink

    def _schema(self, schema: Schema) -> None:
        """Copy a schema; a standard type's damaged text is replaced by its definition."""
        if schema.id in self.schemas:
            return
        problem = standard_text_problem(schema.name, schema.data)
        if problem:
            self.result.notes.append(f"schema {schema.id}: {problem}; the standard definition "
                                     "was written instead")
            schema = Schema(id=schema.id, name=schema.name, encoding=schema.encoding,
                            data=full_text(schema.name).encode())
        self.schemas[schema.id] = schema
        self.schema_ids[schema.id] = self._sink().add_schema(schema.name, schema.encoding,
                                                             schema.data)

    def _channel(self, channel: Channel) -> None:
        if channel.id not in self.channels:
            schema = self.schemas.get(channel.schema_id)
            problem = schema and hash_problem(channel, schema)
            if problem:
                self.result.notes.append(f"topic {channel.topic}: {problem}; copied as it is")
            self.channels[channel.id] = channel
            self.channel_ids[channel.id] = self._sink().add_channel(
                channel.topic, channel.message_encoding,
                self.schema_ids.get(channel.schema_id, 0), channel.metadata)
            self.result.kept[channel.topic] = 0

    def _chunk(self, rec) -> None:
        try:
            chunk = R.open_chunk(rec.body)
            msgs = R.chunk_messages(chunk.data)
            for opcode, _, body in msgs.others:
                stream = ReadDataStream(BytesIO(body))
                if opcode == R.OP_SCHEMA:
                    self._schema(Schema.read(stream))
                else:
                    self._channel(Channel.read(stream))
        except R.READ_ERRORS as exc:
            self._lose(rec.offset, rec.end - rec.offset, str(exc), self._indexed_counts(rec.end))
            return
        self.result.chunks_kept += 1
        self._messages(msgs, chunk.data)

    def _messages(self, msgs, data: bytes) -> None:
        sink = self._sink()
        for k in range(len(msgs.offset)):
            cid = int(msgs.channel[k])
            if cid not in self.channel_ids:
                self.result.lost["(no channel record)"] = \
                    self.result.lost.get("(no channel record)", 0) + 1
                continue
            sink.add_message(self.channel_ids[cid], int(msgs.log_time[k]),
                             int(msgs.publish_time[k]), int(msgs.sequence[k]),
                             msgs.payload(data, k))
            topic = self.channels[cid].topic
            self.result.kept[topic] += 1
            self.result.messages += 1

    # -- what was lost ---------------------------------------------------------------------
    def _lose(self, offset: int, nbytes: int, why: str, counts=None) -> None:
        self.result.dropped_bytes += nbytes
        self.result.lost_chunks.append((offset, why))
        for cid, n in (counts or {}).items():
            topic = self.channels[cid].topic if cid in self.channels else f"channel {cid}"
            self.result.lost[topic] = self.result.lost.get(topic, 0) + n

    def _indexed_counts(self, pos: int) -> dict[int, int]:
        """Messages per channel of a lost chunk, from the message indexes that follow it."""
        counts = {}
        try:
            for rec in R.scan(self.src, self.size, pos):
                if rec.opcode != R.OP_MESSAGE_INDEX or len(rec.body) < 6:
                    break
                counts[struct.unpack_from("<H", rec.body)[0]] = (len(rec.body) - 6) // 16
        except R.READ_ERRORS:
            pass
        return counts

    def _next_chunk(self, pos: int) -> int | None:
        """The offset of the next record from ``pos`` on that looks like an intact chunk."""
        while pos < self.size:
            self.src.seek(pos)
            block = self.src.read(_SEARCH_BLOCK + 64)
            for hit in np.flatnonzero(np.frombuffer(block[:_SEARCH_BLOCK], np.uint8)
                                      == R.OP_CHUNK):
                if _looks_like_chunk(block, int(hit), self.size - pos - int(hit)):
                    return pos + int(hit)
            pos += _SEARCH_BLOCK
        return None

    # -- the end ---------------------------------------------------------------------------
    def _finish(self) -> None:
        sink, result = self.sink, self.result
        sink.flush_chunk()
        stats = self._statistics_counts()
        result.lost_counted = stats is not None
        if stats is not None:
            for cid, n in stats.items():
                topic = self.channels[cid].topic if cid in self.channels else f"channel {cid}"
                missing = n - result.kept.get(topic, 0)
                if missing > 0:
                    result.lost[topic] = missing
        if COUNTS_RECORD in self.metadata:
            self._rewrite_counts()
        topics = []
        for cid, c in sorted(self.channels.items()):
            schema = self.schemas.get(c.schema_id)
            topics.append({"name": c.topic, "type": schema.name if schema else "",
                           "qos": parse_qos_yaml(c.metadata.get("offered_qos_profiles", "")),
                           "hash": c.metadata.get("topic_type_hash", ""),
                           "count": sink.counts[self.channel_ids[cid]]})
        sink.add_metadata("rosbag2", rosbag2_record(self.name, topics, sink.start_ns or 0,
                                                    sink.end_ns or 0, self.compression))
        sink.finish()

    def _rewrite_counts(self) -> None:
        """The counts record with what was kept; the messages recovery lost are lost."""
        try:
            counts = decode_counts(self.metadata[COUNTS_RECORD], self.source)
        except BagError as exc:
            self.result.notes.append(f"{COUNTS_RECORD} record dropped: {exc.problem}")
            return
        for topic, c in counts.items():
            kept = self.result.kept.get(topic, 0)
            c["lost"] = (c["lost"] or 0) + max(0, c["recorded"] - kept)
            c["recorded"] = kept
        self.sink.add_metadata(COUNTS_RECORD, encode_counts(counts))

    def _statistics_counts(self) -> dict[int, int] | None:
        """Per-channel counts of the source's Statistics record (None without a summary)."""
        try:
            self.src.seek(self.size - len(MAGIC) - 29)
            tail = self.src.read(29 + len(MAGIC))
            if tail[-len(MAGIC):] != MAGIC or tail[0] != R.OP_FOOTER:
                return None
            (summary_start,) = struct.unpack_from("<Q", tail, 9)
            if not 0 < summary_start < self.size:
                return None
            for rec in R.scan(self.src, self.size, summary_start):
                if rec.opcode == R.OP_STATISTICS:
                    stats = Statistics.read(ReadDataStream(BytesIO(rec.body)))
                    return dict(stats.channel_message_counts)
        except R.READ_ERRORS:
            return None
        return None


def _looks_like_chunk(block: bytes, at: int, remaining: int) -> bool:
    """Are the fixed fields of a chunk record at ``block[at:]`` consistent?"""
    if at + 9 + 40 > len(block):
        return False
    length, start, end, usize = struct.unpack_from("<QQQQ", block, at + 1)
    (clen,) = struct.unpack_from("<I", block, at + 9 + 28)
    if (length > min(remaining - 9, R.MAX_RECORD_BYTES) or end < start
            or usize > R.MAX_CHUNK_BYTES or clen > 8):
        return False
    if at + 9 + 32 + clen + 8 > len(block):
        return False
    name = block[at + 9 + 32:at + 9 + 32 + clen]
    (dlen,) = struct.unpack_from("<Q", block, at + 9 + 32 + clen)
    return name in (b"", b"zstd", b"lz4") and 40 + clen + dlen == length
