"""The streaming pass of :func:`.integrity.scan_bag`: the data section record by record.

It reads records, chunks and their message indexes, decodes every message, counts repeats and
checks the data end and footer CRCs; the summary cross-checks come from :class:`SummaryChecks`.
"""
from __future__ import annotations

import struct
import zlib
from io import BytesIO
from pathlib import Path

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.records import (Channel, ChunkIndex, Footer, Metadata, MetadataIndex, Schema,
                          Statistics, SummaryOffset)

from . import records as R
from .cdr import CdrCodec, CdrError, Layout
from .integrity_report import IntegrityReport, TopicData
from .integrity_summary import SummaryChecks
from .mcap_writer import MAGIC, MESSAGE_HEADER
from .msgdefs import MsgDefError, parse_schema
from .schema_check import hash_problem, standard_text_problem

_ENTRY = np.dtype([("time", "<u8"), ("offset", "<u8")])     # a message index entry
#: bytes of the unit the pass's progress counts in (MB)
MB = 1_000_000


class _Pass(SummaryChecks):
    def __init__(self, path: Path, f, progress=None):
        self.f = f
        self.progress, self._mb_read = progress, 0    # progress(MB read, MB of the file)
        self.report = IntegrityReport(path, size_bytes=path.stat().st_size)
        self.codecs: dict[int, CdrCodec | None] = {}
        self.layouts: dict[int, Layout] = {}       # the last structure seen per channel
        self.chunks: dict[int, dict] = {}          # offset -> what the chunk index must say
        self.metadata_at: dict[int, tuple[str, int]] = {}
        self.summary: dict[str, list] = {"schema": [], "channel": [], "statistics": [],
                                         "chunk_index": [], "metadata_index": [],
                                         "summary_offset": []}
        self.footer: Footer | None = None
        self.summary_layout: list[tuple[int, int, int]] = []    # (opcode, start, end)

    # -- the walk --------------------------------------------------------------------------
    def run(self) -> IntegrityReport:
        rep, f = self.report, self.f
        if f.read(len(MAGIC)) != MAGIC:
            rep.add("format", "byte 0", "not an MCAP file (wrong magic bytes)")
            return rep
        data_crc = zlib.crc32(MAGIC)
        summary_crc, summary_start = 0, None
        in_summary = False
        pending = None                              # a chunk and its message indexes
        try:
            for rec in R.scan(f, rep.size_bytes):
                if self.progress is not None:
                    self._advance(rec.end)
                raw_head = struct.pack("<BQ", rec.opcode, len(rec.body))
                if rec.opcode != R.OP_MESSAGE_INDEX and pending is not None:
                    self._chunk(*pending)
                    pending = None
                if in_summary and rec.opcode != R.OP_FOOTER:
                    summary_crc = zlib.crc32(rec.body, zlib.crc32(raw_head, summary_crc))
                    self.summary_layout.append((rec.opcode, rec.offset, rec.end))
                if rec.opcode == R.OP_DATA_END:
                    self._data_end(rec, data_crc)
                    in_summary, summary_start = True, rec.end
                    continue
                if not in_summary:
                    data_crc = zlib.crc32(rec.body, zlib.crc32(raw_head, data_crc))
                if rec.opcode == R.OP_CHUNK:
                    pending = (rec, [])
                elif rec.opcode == R.OP_MESSAGE_INDEX:
                    if pending is None or in_summary:
                        rep.add("message_index", f"record at byte {rec.offset}",
                                "a message index that follows no chunk")
                    else:
                        pending[1].append(rec)
                elif rec.opcode == R.OP_FOOTER:
                    self._footer(rec, summary_crc, summary_start)
                else:
                    self._record(rec, in_summary)
        except R.RecordError as exc:
            rep.add("structure", f"byte {exc.offset}",
                    f"{exc} -- nothing after it can be read by its structure")
            if pending is not None:
                self._chunk(*pending)
            return rep
        if pending is not None:
            self._chunk(*pending)
        if self.footer is None:
            rep.add("structure", f"byte {rep.size_bytes}", "the file ends without its footer "
                    "(a recording that was interrupted)")
            return rep
        self._check_summary()
        self._check_records()
        self._check_topics()
        return rep

    def _advance(self, end: int) -> None:
        """Report the megabytes read (rounded up) when they grow."""
        read = -(-end // MB)
        if read > self._mb_read:
            self._mb_read = read
            self.progress(read, -(-self.report.size_bytes // MB))

    def _read(self, cls, rec, *extra):
        return cls.read(ReadDataStream(BytesIO(rec.body)), *extra)

    def _record(self, rec, in_summary: bool) -> None:
        rep = self.report
        try:
            if rec.opcode == R.OP_HEADER:
                stream = ReadDataStream(BytesIO(rec.body))
                rep.profile, rep.library = stream.read_prefixed_string(), \
                    stream.read_prefixed_string()
            elif rec.opcode == R.OP_SCHEMA:
                schema = self._read(Schema, rec)
                (self.summary["schema"].append(schema) if in_summary
                 else self._add_schema(schema, rec.offset))
            elif rec.opcode == R.OP_CHANNEL:
                channel = self._read(Channel, rec)
                (self.summary["channel"].append(channel) if in_summary
                 else self._add_channel(channel, rec.offset))
            elif rec.opcode == R.OP_METADATA:
                meta = self._read(Metadata, rec)
                rep.metadata[meta.name] = dict(meta.metadata)
                self.metadata_at[rec.offset] = (meta.name, 9 + len(rec.body))
            elif rec.opcode == R.OP_MESSAGE:
                rep.messages_outside_chunks += 1
                self._loose_message(rec)
            elif rec.opcode == R.OP_STATISTICS:
                self.summary["statistics"].append(self._read(Statistics, rec))
            elif rec.opcode == R.OP_CHUNK_INDEX:
                self.summary["chunk_index"].append(self._read(ChunkIndex, rec))
            elif rec.opcode == R.OP_METADATA_INDEX:
                self.summary["metadata_index"].append(self._read(MetadataIndex, rec))
            elif rec.opcode == R.OP_SUMMARY_OFFSET:
                self.summary["summary_offset"].append(self._read(SummaryOffset, rec))
        except R.READ_ERRORS as exc:
            rep.add("structure", f"record at byte {rec.offset}",
                    f"opcode 0x{rec.opcode:02x} cannot be read ({exc})")

    # -- schemas and channels --------------------------------------------------------------
    def _add_schema(self, schema: Schema, offset: int) -> None:
        old = self.report.schemas.get(schema.id)
        if old is not None and old != schema:
            self.report.add("schema", f"record at byte {offset}",
                            f"schema id {schema.id} is defined twice, differently")
        self.report.schemas[schema.id] = schema

    def _add_channel(self, channel: Channel, offset: int) -> None:
        rep = self.report
        old = rep.channels.get(channel.id)
        if old is not None:
            if old != channel:
                rep.add("channel", f"record at byte {offset}",
                        f"channel id {channel.id} is defined twice, differently")
            return
        rep.channels[channel.id] = channel
        schema = rep.schemas.get(channel.schema_id)
        rep.topics[channel.id] = TopicData(channel.topic, schema.name if schema else "",
                                           channel.id)
        self.codecs[channel.id] = self._codec(channel, schema, offset)

    def _codec(self, channel: Channel, schema: Schema | None, offset: int):
        """The channel's decoder; a schema this package cannot decode is noted (the reader
        refuses it when the topic is read), a schema that contradicts its type is a problem."""
        rep = self.report
        where = f"topic {channel.topic} (channel record at byte {offset})"
        if channel.message_encoding != "cdr":
            rep.undecodable[channel.topic] = f"message encoding {channel.message_encoding!r}"
            return None
        if schema is None:
            rep.undecodable[channel.topic] = f"schema id {channel.schema_id} is not in the file"
            return None
        if schema.encoding != "ros2msg":
            rep.undecodable[channel.topic] = f"schema encoding {schema.encoding!r}"
            return None
        problem = standard_text_problem(schema.name, schema.data)
        if problem:
            rep.add("schema", where, problem)
            return None
        try:
            codec = CdrCodec(schema.name, parse_schema(schema.name, schema.data.decode()))
        except (MsgDefError, UnicodeDecodeError) as exc:
            rep.undecodable[channel.topic] = f"schema {schema.name!r} cannot be parsed ({exc})"
            return None
        problem = hash_problem(channel, schema)
        if problem:
            rep.add("schema", where, problem)
        return codec

    # -- messages --------------------------------------------------------------------------
    def _loose_message(self, rec) -> None:
        body = rec.body
        if len(body) < MESSAGE_HEADER.size - 9:
            raise ValueError("message record shorter than its fixed fields")
        data = MESSAGE_HEADER.pack(R.OP_MESSAGE, len(body), 0, 0, 0, 0)[:9] + body
        self._messages(R.chunk_messages(data), data, f"message at byte {rec.offset}")

    def _chunk(self, rec, index_records) -> None:
        rep = self.report
        where = f"chunk at byte {rec.offset}"
        rep.chunks += 1
        index, index_offsets = {}, {}
        for irec in index_records:
            body = irec.body
            if len(body) < 6:
                rep.add("message_index", f"record at byte {irec.offset}", "too short")
                continue
            channel, nbytes = struct.unpack_from("<HI", body, 0)
            if nbytes % 16 or 6 + nbytes != len(body):
                rep.add("message_index", f"record at byte {irec.offset}",
                        f"entries of {nbytes} bytes in a record of {len(body)}")
                continue
            index[channel] = np.frombuffer(body, _ENTRY, offset=6)
            index_offsets[channel] = irec.offset
        try:
            chunk = R.open_chunk(rec.body)
        except ValueError as exc:
            rep.add("chunk", where, f"damaged ({exc})")
            return
        rep.compressions.add(chunk.compression or "none")
        expected = {"length": 9 + len(rec.body), "start": chunk.start_ns, "end": chunk.end_ns,
                    "compression": chunk.compression, "compressed": chunk.compressed_size,
                    "uncompressed": chunk.uncompressed_size, "index_offsets": index_offsets,
                    "index_length": sum(9 + len(r.body) for r in index_records)}
        self.chunks[rec.offset] = expected
        hint = (np.concatenate([rows["offset"] for rows in index.values()]).astype(np.int64)
                if index else None)
        try:
            msgs = R.chunk_messages(chunk.data, hint)
        except R.RecordError as exc:
            rep.add("chunk", where, f"its records do not fit together ({exc})")
            return
        for opcode, at, body in msgs.others:
            stream = ReadDataStream(BytesIO(body))
            try:
                if opcode == R.OP_SCHEMA:
                    self._add_schema(Schema.read(stream), rec.offset)
                else:
                    self._add_channel(Channel.read(stream), rec.offset)
            except R.READ_ERRORS as exc:
                rep.add("structure", f"{where}, record at byte {at} of the chunk",
                        f"unreadable ({exc})")
        if len(msgs.log_time) and (int(msgs.log_time.min()) != chunk.start_ns
                                   or int(msgs.log_time.max()) != chunk.end_ns):
            rep.add("chunk", where, f"says its messages span {chunk.start_ns}-{chunk.end_ns} ns, "
                    f"they span {msgs.log_time.min()}-{msgs.log_time.max()} ns")
        if not index:
            rep.chunks_without_index += 1
        else:
            self._compare_index(msgs, index, where)
        self._messages(msgs, chunk.data, where)

    def _compare_index(self, msgs, index, where: str) -> None:
        rep = self.report
        for channel in sorted(set(index) | set(np.unique(msgs.channel).tolist())):
            name = self._name(channel)
            mask = msgs.channel == channel
            order = np.argsort(msgs.log_time[mask], kind="stable")   # record order within a time
            a_time, a_off = msgs.log_time[mask][order], msgs.offset[mask][order]
            claimed = index.get(channel)
            if claimed is None:
                rep.add("message_index", f"{name}, {where}",
                        f"{len(a_time)} message(s) in the chunk have no message index entry")
                continue
            c_time, c_off = claimed["time"].astype(np.int64), claimed["offset"].astype(np.int64)
            lex = np.lexsort((c_off, c_time))
            c_time, c_off = c_time[lex], c_off[lex]
            if len(a_time) != len(c_time):
                rep.add("message_index", f"{name}, {where}", f"the index lists {len(c_time)} "
                        f"message(s), the chunk holds {len(a_time)}")
                continue
            wrong = np.flatnonzero((a_time != c_time) | (a_off != c_off))
            if len(wrong):
                k = int(wrong[0])
                rep.add("message_index", f"{name}, {where}, t = {a_time[k] * 1e-9:.6f} s",
                        f"{len(wrong)} entries differ from the data; entry {k} says (time "
                        f"{c_time[k]} ns, offset {c_off[k]}), the data has (time {a_time[k]} "
                        f"ns, offset {a_off[k]})")

    def _name(self, channel: int) -> str:
        t = self.report.topics.get(channel)
        return f"topic {t.topic}" if t else f"channel {channel}"

    def _messages(self, msgs, data: bytes, where: str) -> None:
        rep = self.report
        buf = np.frombuffer(data, np.uint8)
        for channel in np.unique(msgs.channel).tolist():
            t = rep.topics.get(channel)
            if t is None:
                rep.add("channel", where, f"messages of channel {channel}, which no channel "
                        "record defines")
                continue
            mask = np.flatnonzero(msgs.channel == channel)
            times = msgs.log_time[mask]
            t.count += len(times)
            lo, hi = int(times.min()), int(times.max())
            t.start_ns = lo if t.start_ns is None else min(t.start_ns, lo)
            t.end_ns = hi if t.end_ns is None else max(t.end_ns, hi)
            self._decode(t, msgs, mask, data, buf, where)
            self._repeats(t, msgs, mask, data)

    def _decode(self, t: TopicData, msgs, mask, data, buf, where: str) -> None:
        codec = self.codecs.get(t.channel_id)
        if codec is None:
            return                              # its schema problem is reported already
        sizes = msgs.size[mask]
        try:
            if np.all(sizes == sizes[0]):
                layout = self.layouts.get(t.channel_id)
                if layout is None or layout.size != sizes[0]:
                    layout = codec.layout(msgs.payload(data, mask[0]))
                    self.layouts[t.channel_id] = layout
                starts = msgs.offset[mask] + MESSAGE_HEADER.size
                if all(np.all(buf[starts[:, None] + off + np.arange(4)].copy().view("<u4")[:, 0]
                              == value) for off, value in layout.prefixes.items()):
                    return       # every string length and sequence count alike: all decode
            for k in mask:
                codec.decode(msgs.payload(data, k))
        except CdrError as exc:
            self.report.add("decode", f"topic {t.topic}, {where}", "a message does not decode "
                            f"as {codec.type_name} ({exc})")

    def _repeats(self, t: TopicData, msgs, mask, data) -> None:
        times = msgs.log_time[mask]
        prev = np.concatenate([[t.last[0]], times[:-1]]) if t.last else times[:-1]
        cur = times if t.last else times[1:]
        backwards = np.flatnonzero(cur < prev)
        if len(backwards):
            t.backwards += len(backwards)
            t.first_repeat_ns.setdefault("backwards", int(cur[backwards[0]]))
        same = np.flatnonzero(cur == prev)
        for k in same:
            now = mask[k + (0 if t.last else 1)]
            before = t.last[1] if (t.last and k == 0) else msgs.payload(
                data, mask[k - (1 if t.last else 0)])
            kind = "duplicate" if msgs.payload(data, now) == before else "conflict"
            if kind == "duplicate":
                t.duplicates += 1
            else:
                t.conflicts += 1
            t.first_repeat_ns.setdefault(kind, int(msgs.log_time[now]))
        t.last = (int(times[-1]), msgs.payload(data, mask[-1]))

    # -- the end of the data and the summary -----------------------------------------------
    def _data_end(self, rec, data_crc: int) -> None:
        (claimed,) = struct.unpack_from("<I", rec.body, 0) if len(rec.body) >= 4 else (0,)
        if not claimed:
            self.report.crcs["data"] = "absent"
        elif claimed != data_crc:
            self.report.add("crc", f"data end at byte {rec.offset}", "the data section CRC does "
                            "not match: a record before it was altered")
        else:
            self.report.crcs["data"] = "checked"

    def _footer(self, rec, summary_crc: int, summary_start) -> None:
        try:
            self.footer = self._read(Footer, rec)
        except R.READ_ERRORS as exc:
            self.report.add("structure", f"footer at byte {rec.offset}", f"unreadable ({exc})")
            return
        ft = self.footer
        if ft.summary_start and summary_start is not None and ft.summary_start != summary_start:
            self.report.add("summary", f"footer at byte {rec.offset}", f"says the summary starts "
                            f"at byte {ft.summary_start}, it starts at {summary_start}")
        if not ft.summary_crc:
            self.report.crcs["summary"] = "absent"
            return
        crc = zlib.crc32(struct.pack("<BQQQ", R.OP_FOOTER, 20, ft.summary_start,
                                     ft.summary_offset_start), summary_crc)
        if crc != ft.summary_crc:
            self.report.add("crc", f"summary at byte {ft.summary_start}", "the summary CRC does "
                            "not match: the summary or the footer was altered")
        else:
            self.report.crcs["summary"] = "checked"
