"""Finishing a recording that was killed: rebuild a complete bag from what reached the disk.

The writer (:mod:`.mcap_writer`) puts the schemas, channels and the run configuration on disk
before the first message and flushes every chunk as soon as it is full, so after SIGKILL or a
power cut the file holds a valid MCAP prefix: everything up to the last complete chunk.
:func:`recover_bag` reads that prefix record by record, stops at the first record that is cut
off or fails its CRC, and writes a new, finished bag (summary, indexes, statistics, a fresh
``rosbag2`` record) with every message it could read. ``mcap recover`` (the Go CLI) does the
same job on any MCAP file.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message, Metadata, Schema
from mcap.stream_reader import breakup_chunk

from .errors import BagError
from .mcap_writer import MAGIC, McapSink
from .metadata import parse_qos_yaml, rosbag2_record
from .reader import DAMAGE_ERRORS
from .writer import LIBRARY


@dataclass(frozen=True)
class Recovery:
    """What :func:`recover_bag` kept: messages, and the bytes of the source it had to drop."""

    path: Path
    messages: int
    dropped_bytes: int


def _records(data: memoryview):
    """(opcode, body) of every complete record after the magic; stops at a cut-off one."""
    pos = len(MAGIC)
    while pos + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, pos)
        if pos + 9 + length > len(data):
            break
        yield opcode, data[pos + 9:pos + 9 + length], pos + 9 + length
        pos += 9 + length


def recover_bag(source, target=None, *, compression: str = "zstd") -> Recovery:
    """Write the readable part of ``source`` to ``target`` (default ``<name>.recovered.mcap``)."""
    source = Path(source)
    target = Path(target) if target is not None else source.with_suffix(".recovered.mcap")
    try:
        data = memoryview(source.read_bytes())
    except OSError as exc:
        raise BagError(source, f"cannot read the file ({exc.strerror})") from None
    if bytes(data[:len(MAGIC)]) != MAGIC:
        raise BagError(source, "not an MCAP file (wrong magic bytes)", fix="nothing to recover")
    if target.resolve() == source.resolve():
        raise BagError(target, "the recovered bag must be a new file", fix="give another name")

    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    metadata: list[Metadata] = []
    messages: list[Message] = []
    profile, used = None, len(MAGIC)
    for opcode, body, end in _records(data):
        stream = ReadDataStream(BytesIO(bytes(body)))
        try:
            if opcode == Opcode.HEADER:
                profile = stream.read_prefixed_string()
            elif opcode == Opcode.SCHEMA:
                schema = Schema.read(stream)
                schemas[schema.id] = schema
            elif opcode == Opcode.CHANNEL:
                channel = Channel.read(stream)
                channels[channel.id] = channel
            elif opcode == Opcode.METADATA:
                metadata.append(Metadata.read(stream))
            elif opcode == Opcode.MESSAGE:
                messages.append(Message.read(stream, len(body)))
            elif opcode == Opcode.CHUNK:
                for record in breakup_chunk(Chunk.read(stream), validate_crc=True):
                    if isinstance(record, Schema):
                        schemas[record.id] = record
                    elif isinstance(record, Channel):
                        channels[record.id] = record
                    elif isinstance(record, Message):
                        messages.append(record)
            elif opcode in (Opcode.DATA_END, Opcode.FOOTER):
                used = len(data)          # a finished file: only the summary is rebuilt
                break
        except DAMAGE_ERRORS:
            break                     # a damaged record ends what can be trusted
        used = end
    if profile is None:
        raise BagError(source, "the file ends inside its MCAP header", fix="nothing to recover")
    _write(target, profile, schemas, channels, metadata, messages, compression)
    return Recovery(target, len(messages), len(data) - used)


def _write(target, profile, schemas, channels, metadata, messages, compression) -> None:
    with open(target, "wb") as f:
        sink = McapSink(f, profile, LIBRARY, compression)
        schema_ids = {sid: sink.add_schema(s.name, s.encoding, s.data)
                      for sid, s in sorted(schemas.items())}
        channel_ids = {cid: sink.add_channel(c.topic, c.message_encoding,
                                             schema_ids.get(c.schema_id, 0), c.metadata)
                       for cid, c in sorted(channels.items())}
        for record in metadata:
            if record.name != "rosbag2":
                sink.add_metadata(record.name, record.metadata)
        for m in sorted(messages, key=lambda m: m.log_time):
            if m.channel_id in channel_ids:
                sink.add_message(channel_ids[m.channel_id], m.log_time, m.publish_time,
                                 m.sequence, m.data)
        sink.flush_chunk()
        topics = []
        for cid, c in sorted(channels.items()):
            schema = schemas.get(c.schema_id)
            qos = parse_qos_yaml(c.metadata.get("offered_qos_profiles", ""))
            topics.append({"name": c.topic, "type": schema.name if schema else "", "qos": qos,
                           "hash": c.metadata.get("topic_type_hash", ""),
                           "count": sink.counts[channel_ids[cid]]})
        sink.add_metadata("rosbag2", rosbag2_record(Path(target).name, topics, sink.start_ns or 0,
                                                    sink.end_ns or 0, compression))
        sink.finish()
