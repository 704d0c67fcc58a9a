"""Writing bags: single ``.mcap`` files in the rosbag2 MCAP profile, without ROS.

Three ways in, one file format:

* :meth:`BagWriter.write_raw` -- serialised CDR bytes as rclpy hands them to a subscription
  (the recorder node): no decoding, one ``struct.pack`` per message;
* :meth:`BagWriter.write` -- a message as a dict (encoded with :mod:`.cdr`);
* :meth:`BagWriter.write_streams` / :func:`write_bag` -- whole time series
  (:class:`rotor_avc.bag.topics.Stream`, e.g. from the in-process simulator), merged in time
  order and packed chunk by chunk with numpy.

The file: profile ``ros2``; one schema per type (encoding ``ros2msg``, rosbag2's full dependency
text, :mod:`.msgdefs`); one channel per topic (message encoding ``cdr``, metadata
``offered_qos_profiles`` and ``topic_type_hash``); log time = publish time = the message's sim
time in ns; the run configuration in the ``rotor_avc`` metadata record, written before the first
message; the ``rosbag2`` metadata record on close (:mod:`.metadata`). Crash safety is described
in :mod:`.mcap_writer`; :func:`rotor_avc.bag.recover.recover_bag` finishes a killed recording.
An ``OSError`` while writing (disk full, read-only file system, file-size limit, ...) is raised as
:class:`rotor_avc.output_files.OutputError` (one line: the path, the cause, the fix); the writer
is then closed and the file left as far as it got (its flushed chunks are recoverable).
"""
from __future__ import annotations

import contextlib
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from .. import __version__
from ..output_files import OutputError
from .cdr import CdrCodec, CdrError
from .errors import BagError
from .mcap_writer import MESSAGE_DTYPE, McapSink
from .metadata import (CONFIG_RECORD, COUNTS_RECORD, encode_config, encode_counts, qos_profiles,
                       qos_yaml, rosbag2_record)
from .msgdefs import MsgDefError, full_name, full_text, known_specs, type_hash
from .topics import Stream, message_type

LIBRARY = f"rotor_avc {__version__} (rosbag2 MCAP storage layout)"
_HEADER_BYTES = MESSAGE_DTYPE.itemsize


@dataclass
class _Topic:
    channel_id: int
    msg_type: str
    qos: list[dict]
    type_hash: str
    codec: CdrCodec
    sequence: int = 0


class BagWriter:
    """Write one bag; use as a context manager (the file is finished on exit).

    ``config`` is the run configuration (``{"machine": ..., "controllers": ...,
    "discretisation": ..., "balancer": ..., "speed_profile": ..., "unbalance": ...}``, see
    :mod:`.metadata`); a bag written without it is valid MCAP but not self-describing, and
    :class:`~rotor_avc.bag.reader.BagReader` refuses it where the configuration is needed.
    """

    def __init__(self, path, config: Mapping[str, Any] | None, *, compression: str = "zstd",
                 chunk_size: int = 1 << 20, level: int | None = None, overwrite: bool = False):
        self.path = Path(path)
        if self.path.suffix != ".mcap":
            raise BagError(self.path, "a bag file name must end in .mcap", fix="rename it")
        if self.path.exists() and not overwrite:
            raise BagError(self.path, "file exists", fix="choose a new name or pass overwrite=True")
        if compression not in ("zstd", "lz4", ""):
            raise BagError(self.path, f"unknown chunk compression {compression!r}",
                           fix="use 'zstd', 'lz4' or '' (none)")
        if chunk_size < 1024:
            raise BagError(self.path, f"chunk_size {chunk_size} is too small", fix="use >= 1024")
        record = encode_config(config) if config is not None else None
        try:
            self._file = open(self.path, "wb")
        except OSError as exc:
            raise OutputError(self.path, exc) from None
        self._compression = compression
        self._specs = known_specs()
        self._schemas: dict[str, int] = {}
        self._topics: dict[str, _Topic] = {}
        self._closed = False
        self._failed: OutputError | None = None
        try:
            self._sink = McapSink(self._file, "ros2", LIBRARY, compression, chunk_size, level)
            if record is not None:
                self._sink.add_metadata(CONFIG_RECORD, record)
        except OSError as exc:
            raise self._fail(exc) from None

    # -- topics ----------------------------------------------------------------------------
    def add_topic(self, topic: str, msg_type: str | None = None,
                  qos: list[Mapping] | None = None) -> None:
        """Register a topic (before its first message); the type defaults to the package's
        type of that topic (:mod:`.topics`), QoS to the ROS 2 default publisher profile."""
        self._check_open()
        if topic in self._topics:
            raise BagError(self.path, f"topic {topic} is already registered")
        if not topic.startswith("/"):
            raise BagError(self.path, f"topic {topic!r} must be absolute (start with /)")
        try:
            name = full_name(msg_type or message_type(topic))
            text, digest = full_text(name), type_hash(name, self._specs)
            codec = CdrCodec(name, self._specs)
        except MsgDefError as exc:
            raise BagError(self.path, f"topic {topic}: {exc}") from None
        profiles = qos_profiles(qos)
        try:
            if name not in self._schemas:
                self._schemas[name] = self._sink.add_schema(name, "ros2msg", text.encode())
            channel = self._sink.add_channel(topic, "cdr", self._schemas[name],
                                             {"offered_qos_profiles": qos_yaml(profiles),
                                              "topic_type_hash": digest})
        except OSError as exc:
            raise self._fail(exc) from None
        self._topics[topic] = _Topic(channel, name, profiles, digest, codec)

    def _topic(self, topic: str) -> _Topic:
        entry = self._topics.get(topic)
        if entry is None:
            self.add_topic(topic)
            entry = self._topics[topic]
        return entry

    # -- one message -----------------------------------------------------------------------
    def write_raw(self, topic: str, data: bytes, time_ns: int, publish_time_ns: int | None = None,
                  sequence: int | None = None) -> None:
        """Append serialised CDR bytes as they are (the recorder's path)."""
        entry = self._topics.get(topic)
        if entry is None or self._closed:
            self._check_open()
            entry = self._topic(topic)
        entry.sequence += 1
        try:
            self._sink.add_message(entry.channel_id, time_ns,
                                   time_ns if publish_time_ns is None else publish_time_ns,
                                   entry.sequence if sequence is None else sequence, data)
        except (struct.error, TypeError) as exc:
            raise BagError(self.path, f"topic {topic}: bad time, sequence or data ({exc})",
                           fix="times are integer ns >= 0, data is bytes") from None
        except OSError as exc:
            raise self._fail(exc) from None

    def write(self, topic: str, message: Mapping, time_ns: int,
              publish_time_ns: int | None = None) -> None:
        """Encode a message given as a dict (missing fields are zero) and append it."""
        entry = self._topic(topic)
        try:
            data = entry.codec.encode(message)
        except CdrError as exc:
            raise BagError(self.path, f"topic {topic}: {exc}") from None
        self.write_raw(topic, data, time_ns, publish_time_ns)

    # -- time series -----------------------------------------------------------------------
    def write_streams(self, streams: Iterable[Stream]) -> None:
        """Write whole time series, merged by time (ties keep the order of ``streams``)."""
        self._check_open()
        streams = [s for s in streams if len(s.time_ns)]
        prepared = [self._prepare(s) for s in streams]
        if not prepared:
            return
        try:
            self._write_streams(streams, prepared)
        except OSError as exc:
            raise self._fail(exc) from None

    def _write_streams(self, streams, prepared) -> None:
        """The writes of :meth:`write_streams`, chunk by chunk."""
        self._sink.flush_chunk()
        times = np.concatenate([s.time_ns for s in streams])
        owner = np.concatenate([np.full(len(s.time_ns), k) for k, s in enumerate(streams)])
        within = np.concatenate([np.arange(len(s.time_ns)) for s in streams])
        order = np.argsort(times, kind="stable")
        times, owner, within = times[order], owner[order], within[order]
        sizes = np.array([_HEADER_BYTES + p[2].size for p in prepared])[owner]
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        chunk_of = starts // self._sink.chunk_size
        cuts = np.concatenate([[0], np.flatnonzero(np.diff(chunk_of)) + 1, [len(times)]])
        for a, b in zip(cuts[:-1], cuts[1:]):
            total = int(starts[b - 1] - starts[a] + sizes[b - 1])
            self._write_chunk(streams, prepared, times[a:b], owner[a:b], within[a:b],
                              starts[a:b] - starts[a], total)
        for stream in streams:
            self._topics[stream.topic].sequence += len(stream.time_ns)

    def _prepare(self, stream: Stream):
        if stream.topic in self._topics:
            if self._topics[stream.topic].msg_type != full_name(stream.msg_type):
                raise BagError(self.path, f"topic {stream.topic} was registered as "
                               f"{self._topics[stream.topic].msg_type}, not {stream.msg_type}")
        else:
            self.add_topic(stream.topic, stream.msg_type)
        entry = self._topics[stream.topic]
        if np.any(stream.time_ns < 0):
            raise BagError(self.path, f"topic {stream.topic}: negative times")
        try:
            template = entry.codec.encode(stream.template)
            layout = entry.codec.layout(template)
            layout.encode(template, {k: np.asarray(v)[:1] for k, v in stream.fields.items()}, 1)
        except CdrError as exc:
            raise BagError(self.path, f"topic {stream.topic}: {exc}") from None
        return entry, template, layout

    def _write_chunk(self, streams, prepared, times, owner, within, offsets, total) -> None:
        buffer = np.empty(total, np.uint8)
        index = {}
        for k in np.unique(owner):
            stream, (entry, template, layout) = streams[k], prepared[k]
            mask = owner == k
            rows_at = within[mask]
            n = len(rows_at)
            head = np.zeros(n, MESSAGE_DTYPE)
            head["op"] = 5
            head["length"] = _HEADER_BYTES - 9 + layout.size
            head["channel"] = entry.channel_id
            head["sequence"] = entry.sequence + rows_at + 1
            head["log_time"] = head["publish_time"] = times[mask]
            payload = layout.encode(template, {p: np.asarray(v)[rows_at]
                                               for p, v in stream.fields.items()}, n)
            records = np.concatenate([head.view(np.uint8).reshape(n, -1), payload], axis=1)
            buffer[offsets[mask][:, None] + np.arange(records.shape[1])] = records
            index[entry.channel_id] = np.column_stack([times[mask],
                                                       offsets[mask]]).astype(np.uint64)
        self._sink.write_chunk(buffer.tobytes(), index)

    # -- the end ---------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._failed is not None:
            raise self._failed
        if self._closed:
            raise BagError(self.path, "the bag is already closed")

    def _fail(self, exc: OSError) -> OutputError:
        """The writer closed after ``exc`` (disk full, ...), the file left as far as it got;
        returns the error to raise."""
        self._failed = OutputError(self.path, exc)
        self._closed = True
        with contextlib.suppress(OSError):
            self._file.close()
        return self._failed

    @property
    def recorded_counts(self) -> dict[str, int]:
        """Messages written so far per topic (also those still in the chunk being filled)."""
        return {name: t.sequence for name, t in self._topics.items()}

    def close(self, published: Mapping[str, int | None] | None = None,
              lost: Mapping[str, int] | None = None,
              records: Mapping[str, Mapping[str, str]] | None = None) -> None:
        """Finish the file: last chunk, message counts, rosbag2 metadata record, summary, footer.

        Every bag carries, per topic, the messages recorded and -- from the publishers' side --
        published (``published``; default: as many as recorded, for a writer that is its own
        publisher) and known lost (``lost``, default 0), in the ``rotor_avc_counts`` record;
        ``records``: more metadata records (name -> string mapping), e.g. the recorder's
        ``rotor_avc_lockstep`` (:mod:`.lockstep`)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._finish(published, lost, records)
        except OSError as exc:
            raise self._fail(exc) from None

    def _finish(self, published, lost, records) -> None:
        """The writes of :meth:`close`."""
        sink = self._sink
        sink.flush_chunk()
        recorded = {name: sink.counts[t.channel_id] for name, t in self._topics.items()}
        published = dict(recorded if published is None else published)
        for name, record in (records or {}).items():
            sink.add_metadata(name, {str(k): str(v) for k, v in record.items()})
        sink.add_metadata(COUNTS_RECORD, encode_counts(
            {name: {"published": published.get(name), "recorded": n,
                    "lost": (lost or {}).get(name, 0)} for name, n in recorded.items()}))
        topics = [{"name": name, "type": t.msg_type, "qos": t.qos, "hash": t.type_hash,
                   "count": sink.counts[t.channel_id]} for name, t in self._topics.items()]
        sink.add_metadata("rosbag2", rosbag2_record(
            self.path.name, topics, sink.start_ns or 0, sink.end_ns or 0, self._compression))
        sink.finish()
        self._file.close()

    def __enter__(self) -> "BagWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def write_bag(path, streams: Iterable[Stream], config: Mapping[str, Any] | None,
              **options) -> Path:
    """Write time series to a new bag in one call (the in-process simulator's path)."""
    with BagWriter(path, config, **options) as bag:
        bag.write_streams(streams)
    return Path(path)
