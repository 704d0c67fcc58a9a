"""Reading bags written by this package, the recorder node or ``ros2 bag record -s mcap``.

:class:`BagReader` gives the topics (type, count, QoS, type hash), the time range, the MCAP
metadata and the run configuration, decoded messages (dicts, :mod:`.cdr`, decoded from the
bag's own ``ros2msg`` schemas, so foreign types work too), raw CDR for replay, and numpy time
series per topic (:class:`TopicSeries`). The series path reads each chunk once, finds the
channel's messages through the MCAP message index and decodes every numeric field of all
messages with one numpy copy when the messages share one structure (the usual case); otherwise
it decodes message by message.

Every problem is a :class:`~rotor_avc.bag.errors.BagError` naming it: no such file, an empty
(0-byte) file, not MCAP, a truncated file (no footer: the recording was killed -- finish it
with :func:`rotor_avc.bag.recover.recover_bag`), not the ``ros2`` profile, a topic whose schema
cannot be decoded (unknown encoding, IDL, a missing dependency), no configuration metadata, a
bag or topic without messages. With ``integrity=True`` the file first goes through the
streaming integrity pass (:mod:`.integrity`: CRCs, indexes, statistics, schemas, duplicates
against the data), which raises :class:`~rotor_avc.bag.errors.CorruptBagError` (exit status 4).
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import zstandard
from mcap.exceptions import McapError
from mcap.reader import SeekingReader

from .cdr import CdrCodec, CdrError
from .errors import BagError, no_such_bag
from .integrity import verify
from .lockstep import LockstepRecord, read_lockstep
from .mcap_writer import MAGIC, MESSAGE_HEADER
from .metadata import CONFIG_RECORD, COUNTS_RECORD, decode_config, decode_counts, parse_qos_yaml
from .msgdefs import MsgDefError, parse_schema
from .records import RecordError, chunk_messages, open_chunk
from .series import TopicSeries, series_of_messages
from .topics import labels_of

#: messages decoded at once by :meth:`BagReader.series_chunks` from a file without indexes
SERIES_BATCH = 65536
_RECOVER_FIX = ("finish it with `rotor-avc bag recover BAG` (recover_bag in Python, or "
                "`mcap recover`): every intact chunk is kept")
#: what a damaged record raises inside mcap, zstandard, lz4 (RuntimeError) and struct
DAMAGE_ERRORS = (McapError, zstandard.ZstdError, RuntimeError, ValueError, struct.error,
                 zlib.error, IndexError, EOFError)


@dataclass(frozen=True)
class TopicInfo:
    name: str
    msg_type: str
    count: int
    type_hash: str
    qos: list


@dataclass(frozen=True)
class BagMessage:
    topic: str
    time_ns: int
    publish_time_ns: int
    sequence: int
    data: Any          # dict (decoded) or bytes (raw)


class BagReader:
    """Open a bag for reading (a context manager; also usable without ``with``)."""

    def __init__(self, path, *, require_config: bool = False, require_messages: bool = False,
                 integrity: bool = False):
        self.path = Path(path)
        self._file = self._open_checked()
        self.integrity = None
        if integrity:
            try:
                self.integrity = verify(self.path)
            except BagError:
                self.close()
                raise
        try:
            self._reader = SeekingReader(self._file, validate_crcs=True)
            header = self._reader.get_header()
            self._summary = self._reader.get_summary()
        except DAMAGE_ERRORS as exc:
            self.close()
            raise BagError(self.path, f"damaged MCAP file ({exc})", fix=_RECOVER_FIX) from None
        if header.profile != "ros2":
            self.close()
            raise BagError(self.path, f"MCAP profile is {header.profile!r}, not 'ros2'",
                           fix="record the bag with rosbag2 or this package")
        if self._summary is None or self._summary.statistics is None:
            self.close()
            raise BagError(self.path, "the file has no summary/statistics section",
                           fix="rebuild it with `rotor-avc bag recover BAG`")
        self._codecs: dict[int, CdrCodec | BagError] = {}
        self.check(require_config=require_config, require_messages=require_messages)

    def _open_checked(self):
        if not self.path.is_file():
            raise no_such_bag(self.path)
        size = self.path.stat().st_size
        if size == 0:
            raise BagError(self.path, "empty file (0 bytes)",
                           fix="the recording never started; record the run again")
        f = open(self.path, "rb")
        start = f.read(len(MAGIC))
        f.seek(max(0, size - len(MAGIC)))
        end = f.read(len(MAGIC))
        if start != MAGIC:
            f.close()
            raise BagError(self.path, "not an MCAP file (wrong magic bytes)",
                           fix="give a .mcap bag written by rosbag2 or rotor_avc")
        if end != MAGIC or size < 2 * len(MAGIC) + 9 + 29:
            f.close()
            raise BagError(self.path, f"truncated: the file ends after {size} bytes without the "
                           "MCAP footer (the recording was interrupted)", fix=_RECOVER_FIX)
        f.seek(0)
        return f

    # -- what is in it ---------------------------------------------------------------------
    @property
    def topics(self) -> dict[str, TopicInfo]:
        stats = self._summary.statistics
        out = {}
        for cid, ch in sorted(self._summary.channels.items()):
            schema = self._summary.schemas.get(ch.schema_id)
            qos = parse_qos_yaml(ch.metadata.get("offered_qos_profiles", ""))
            out[ch.topic] = TopicInfo(ch.topic, schema.name if schema else "",
                                      stats.channel_message_counts.get(cid, 0),
                                      ch.metadata.get("topic_type_hash", ""), qos)
        return out

    @property
    def message_count(self) -> int:
        return self._summary.statistics.message_count

    @property
    def time_range_ns(self) -> tuple[int, int]:
        stats = self._summary.statistics
        return stats.message_start_time, stats.message_end_time

    @property
    def metadata(self) -> dict[str, dict[str, str]]:
        try:
            return {m.name: dict(m.metadata) for m in self._reader.iter_metadata()}
        except DAMAGE_ERRORS as exc:
            raise BagError(self.path, f"damaged metadata record ({exc})",
                           fix=_RECOVER_FIX) from None

    @property
    def config(self) -> dict[str, Any]:
        """The run configuration (sections of :mod:`.metadata`)."""
        record = self.metadata.get(CONFIG_RECORD)
        if record is None:
            raise BagError(self.path, "the bag carries no run configuration (no `rotor_avc` "
                           "metadata record)", fix="record the run with rotor_avc's recorder "
                           "or simulator, which store the configuration in the bag")
        return decode_config(record, self.path)

    @property
    def counts(self) -> dict[str, dict[str, int | None]] | None:
        """Per topic ``{"published", "recorded", "lost"}`` as the recording wrote them (None for
        a bag without the ``rotor_avc_counts`` record, e.g. one from ``ros2 bag record``)."""
        record = self.metadata.get(COUNTS_RECORD)
        return None if record is None else decode_counts(record, self.path)

    @property
    def lockstep(self) -> LockstepRecord | None:
        """The run's lockstep account (:class:`.lockstep.LockstepRecord`), None for a bag
        without the ``rotor_avc_lockstep`` record (the in-process simulator's, a foreign one)."""
        return read_lockstep(self.metadata, self.path)

    def check(self, *, require_config: bool = False, require_messages: bool = False) -> None:
        """Raise the BagError a command needs: configuration present, messages present."""
        if require_config:
            self.config
        if require_messages and self.message_count == 0:
            raise BagError(self.path, "the bag holds no messages",
                           fix="record a run that publishes (check the topics and the graph)")

    # -- messages --------------------------------------------------------------------------
    def _channel_id(self, topic: str) -> int:
        for cid, ch in self._summary.channels.items():
            if ch.topic == topic:
                return cid
        raise BagError(self.path, f"no topic {topic}",
                       fix="use one of " + ", ".join(sorted(self.topics)))

    def codec(self, topic: str) -> CdrCodec:
        """The decoder of a topic (BagError when its schema cannot be decoded)."""
        cid = self._channel_id(topic)
        if cid not in self._codecs:
            self._codecs[cid] = self._make_codec(self._summary.channels[cid])
        codec = self._codecs[cid]
        if isinstance(codec, BagError):
            raise codec
        return codec

    def _make_codec(self, channel):
        schema = self._summary.schemas.get(channel.schema_id)
        what = f"topic {channel.topic}: "
        fix = "the bag's writer must store ros2msg schemas with their full dependency text"
        if channel.message_encoding != "cdr":
            return BagError(self.path, what + f"message encoding {channel.message_encoding!r} "
                            "is not cdr", fix=fix)
        if schema is None:
            return BagError(self.path, what + "no schema", fix=fix)
        if schema.encoding != "ros2msg":
            return BagError(self.path, what + f"unknown schema {schema.name!r} with encoding "
                            f"{schema.encoding!r} (only ros2msg is decoded)", fix=fix)
        try:
            return CdrCodec(schema.name, parse_schema(schema.name, schema.data.decode()))
        except (MsgDefError, UnicodeDecodeError) as exc:
            return BagError(self.path, what + f"unknown schema {schema.name!r}: {exc}", fix=fix)

    def raw_messages(self, topics=None, start_ns=None, end_ns=None) -> Iterator[BagMessage]:
        """Messages in log-time order with ``data`` the CDR bytes (for replay)."""
        names = [topics] if isinstance(topics, str) else topics
        for name in names or ():
            self._channel_id(name)
        try:
            for _, channel, msg in self._reader.iter_messages(
                    topics=names, start_time=start_ns, end_time=end_ns, log_time_order=True):
                yield BagMessage(channel.topic, msg.log_time, msg.publish_time, msg.sequence,
                                 msg.data)
        except DAMAGE_ERRORS as exc:
            raise BagError(self.path, f"damaged chunk ({exc})", fix=_RECOVER_FIX) from None

    def messages(self, topics=None, start_ns=None, end_ns=None) -> Iterator[BagMessage]:
        """Decoded messages (dicts) in log-time order."""
        for m in self.raw_messages(topics, start_ns, end_ns):
            yield BagMessage(m.topic, m.time_ns, m.publish_time_ns, m.sequence,
                             self._decode(m.topic, m.data))

    def _decode(self, topic: str, data: bytes) -> dict:
        try:
            return self.codec(topic).decode(data)
        except CdrError as exc:
            raise BagError(self.path, f"topic {topic}: message does not match its schema "
                           f"({exc})") from None

    # -- time series -----------------------------------------------------------------------
    def series(self, topic: str) -> TopicSeries:
        """All messages of a topic as numpy arrays (see :class:`TopicSeries`)."""
        self._require_messages(topic)
        times, rows = self._indexed_rows(self._channel_id(topic))
        series = None if rows is None else self._rows_series(topic, times, rows)
        if series is not None:
            return series
        messages = list(self.raw_messages(topic))
        return self._messages_series(topic, [m.time_ns for m in messages],
                                     [m.data for m in messages])

    def series_chunks(self, topic: str) -> Iterator[TopicSeries]:
        """A topic's messages as :class:`TopicSeries` one chunk at a time (in the order of the
        chunks' start times, each in log-time order): :meth:`series` in the memory of one
        chunk. A file without message indexes is read in runs of :data:`SERIES_BATCH`
        messages."""
        self._require_messages(topic)
        cid = self._channel_id(topic)
        if not self.has_message_indexes:
            batch = []
            for m in self.raw_messages(topic):
                batch.append(m)
                if len(batch) == SERIES_BATCH:
                    yield self._messages_series(topic, [m.time_ns for m in batch],
                                                [m.data for m in batch])
                    batch = []
            if batch:
                yield self._messages_series(topic, [m.time_ns for m in batch],
                                            [m.data for m in batch])
            return
        for ci in sorted(self._summary.chunk_indexes, key=lambda c: c.message_start_time):
            if cid not in ci.message_index_offsets:
                continue
            records = self._chunk_records(ci)
            times, rows = self._chunk_rows(ci, cid, records)
            order = np.argsort(times, kind="stable")
            series = None if rows is None else self._rows_series(topic, times[order],
                                                                 rows[order])
            if series is None:
                payloads = self._chunk_payloads(ci, cid, records)
                series = self._messages_series(topic, times[order],
                                               [payloads[i] for i in order])
            yield series

    def _require_messages(self, topic: str) -> None:
        self.codec(topic)
        if self.topics[topic].count == 0:
            raise BagError(self.path, f"topic {topic} has no messages",
                           fix="check that the run published it")

    def _rows_series(self, topic: str, times, rows) -> TopicSeries | None:
        """Fixed-size CDR rows decoded with one numpy copy (None: they do not share one
        structure)."""
        codec = self.codec(topic)
        layout = codec.layout(rows[0].tobytes())
        if not layout.matches(rows):
            return None
        return TopicSeries(topic, codec.type_name, times, layout.decode(rows),
                           labels_of(self._decode(topic, rows[0].tobytes())))

    def _messages_series(self, topic: str, times, payloads) -> TopicSeries:
        """Messages decoded one by one; the numeric fields every message has in one shape."""
        return series_of_messages(topic, self.codec(topic).type_name, times,
                                  [self._decode(topic, data) for data in payloads])

    def log_times(self, topic: str) -> np.ndarray:
        """Log times (ns) of a topic's messages, sorted: from the message indexes without
        decompressing a chunk, or by reading the messages of a file without them."""
        cid = self._channel_id(topic)
        times = []
        for ci in self._summary.chunk_indexes:
            if cid in ci.message_index_offsets:
                times.append(self._message_index(ci.message_index_offsets[cid])[:, 0])
            elif not ci.message_index_offsets:
                return np.sort(np.fromiter((m.time_ns for m in self.raw_messages(topic)),
                                           np.int64))
        if not times:
            return np.zeros(0, np.int64)
        return np.sort(np.concatenate(times).astype(np.int64))

    def chunk_log_times(self, topics) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """The log times (ns) of ``topics`` chunk by chunk, in the order of the chunks' start
        times: ``(chunk start ns, {topic: log times})``, from the message indexes without
        decompressing a chunk (a chunk without them is read); memory: one chunk's times."""
        cids = {t: self._channel_id(t) for t in topics}
        for ci in sorted(self._summary.chunk_indexes, key=lambda c: c.message_start_time):
            if ci.message_index_offsets:
                yield ci.message_start_time, {
                    t: self._message_index(ci.message_index_offsets[cid])[:, 0].astype(np.int64)
                    for t, cid in cids.items() if cid in ci.message_index_offsets}
                continue
            try:
                msgs = chunk_messages(self._chunk_records(ci))
            except RecordError as exc:
                raise BagError(self.path, f"damaged chunk ({exc})", fix=_RECOVER_FIX) from None
            yield ci.message_start_time, {t: msgs.log_time[msgs.channel == cid]
                                          for t, cid in cids.items()
                                          if np.any(msgs.channel == cid)}

    def _indexed_rows(self, cid: int):
        """(times, (N, size) payload bytes) via the message index, or (None, None)."""
        times, blocks = [], []
        for ci in sorted(self._summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
            if cid not in ci.message_index_offsets:
                if not ci.message_index_offsets:
                    return None, None          # a writer without message indexes
                continue
            t, rows = self._chunk_rows(ci, cid, self._chunk_records(ci))
            if rows is None or (blocks and rows.shape[1] != blocks[0].shape[1]):
                return None, None
            times.append(t)
            blocks.append(rows)
        if not blocks:
            return None, None
        times = np.concatenate(times)
        order = np.argsort(times, kind="stable")
        return times[order], np.concatenate(blocks)[order]

    def _chunk_rows(self, ci, cid: int, records: np.ndarray):
        """(times, (n, size) payload bytes) of channel ``cid`` in one chunk (rows None: its
        messages differ in size)."""
        entries = self._message_index(ci.message_index_offsets[cid])
        offsets = entries[:, 1].astype(np.int64)
        try:
            length = records[offsets[:, None] + np.arange(1, 9)].copy().view("<u8")[:, 0]
            size = length.astype(np.int64) - (MESSAGE_HEADER.size - 9)
            if np.any(size != size[0]):
                return entries[:, 0].astype(np.int64), None
            rows = records[offsets[:, None] + MESSAGE_HEADER.size + np.arange(size[0])]
        except (IndexError, ValueError):
            raise BagError(self.path, "damaged message index (offsets outside the chunk)",
                           fix=_RECOVER_FIX) from None
        return entries[:, 0].astype(np.int64), rows

    def _chunk_payloads(self, ci, cid: int, records: np.ndarray) -> list[bytes]:
        """The CDR payloads of channel ``cid`` in one chunk, in message-index order."""
        out = []
        for offset in self._message_index(ci.message_index_offsets[cid])[:, 1].astype(np.int64):
            length = int(records[offset + 1:offset + 9].copy().view("<u8")[0])
            end = offset + 9 + length
            if end > records.size:
                raise BagError(self.path, "damaged message index (offsets outside the chunk)",
                               fix=_RECOVER_FIX)
            out.append(records[offset + MESSAGE_HEADER.size:end].tobytes())
        return out

    def chunk_rows(self, topics):
        """The messages of ``topics`` chunk by chunk, in the order of the chunks' start times:
        ``(later_ns, {topic: (log times, (n, size) payload bytes)})`` per chunk, ``later_ns``
        the start time of the next chunk (every message not yet yielded is logged at or after
        it; None after the last). Rows are None for a topic whose messages in that chunk differ
        in size. Needs message indexes (:attr:`has_message_indexes`)."""
        cids = {t: self._channel_id(t) for t in topics}
        chunks = sorted(self._summary.chunk_indexes, key=lambda c: c.message_start_time)
        for i, ci in enumerate(chunks):
            later = chunks[i + 1].message_start_time if i + 1 < len(chunks) else None
            present = {t: cid for t, cid in cids.items() if cid in ci.message_index_offsets}
            if not present:
                yield later, {}
                continue
            records = self._chunk_records(ci)
            yield later, {t: self._chunk_rows(ci, cid, records) for t, cid in present.items()}

    @property
    def has_message_indexes(self) -> bool:
        return all(ci.message_index_offsets for ci in self._summary.chunk_indexes)

    def _message_index(self, offset: int) -> np.ndarray:
        self._file.seek(offset)
        op, _, _, nbytes = struct.unpack("<BQHI", self._file.read(15))
        body = self._file.read(nbytes)
        if op != 0x07 or len(body) != nbytes:
            raise BagError(self.path, "damaged message index", fix=_RECOVER_FIX)
        return np.frombuffer(body, "<u8").reshape(-1, 2)

    def _chunk_records(self, ci) -> np.ndarray:
        self._file.seek(ci.chunk_start_offset + 9)
        try:
            chunk = open_chunk(self._file.read(ci.chunk_length - 9))
        except ValueError as exc:
            raise BagError(self.path, f"damaged chunk ({exc})", fix=_RECOVER_FIX) from None
        return np.frombuffer(chunk.data, np.uint8)

    # -- closing ---------------------------------------------------------------------------
    def close(self) -> None:
        if getattr(self, "_file", None) is not None and not self._file.closed:
            self._file.close()

    def __enter__(self) -> "BagReader":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
