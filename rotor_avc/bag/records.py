"""The records of an MCAP file, read one at a time from the disk (no index is trusted).

The MCAP specification (https://mcap.dev/spec) lays a file out as magic, then records of
``opcode (1 byte), length (uint64), body``. :func:`scan` walks them in file order reading one
record at a time, so memory is bounded by the largest record (a chunk), never by the file's
size; :func:`open_chunk` checks a chunk record's fields, decompresses it (refusing an
uncompressed size above :data:`MAX_CHUNK_BYTES`) and checks its CRC; :func:`chunk_messages`
finds the Message records inside a chunk as numpy arrays. Used by the integrity pass
(:mod:`.integrity`) and recovery (:mod:`.recover`).
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from typing import BinaryIO, Iterator

import numpy as np
import zstandard
from mcap.exceptions import McapError

from .mcap_writer import MAGIC, MESSAGE_HEADER

#: a chunk that claims more uncompressed bytes than this is refused (writers use ~1 MiB)
MAX_CHUNK_BYTES = 256 << 20
#: a record longer than this is refused before it is read (a chunk's data is at most about
#: its uncompressed size)
MAX_RECORD_BYTES = MAX_CHUNK_BYTES + (1 << 20)
_RECORD_HEAD = struct.Struct("<BQ")
_CHUNK_FIXED = struct.Struct("<QQQI")
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 1, 2, 3, 4, 5, 6
OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_ATTACHMENT, OP_STATISTICS, OP_METADATA = 7, 8, 9, 11, 12
OP_METADATA_INDEX, OP_SUMMARY_OFFSET, OP_DATA_END = 13, 14, 15
KNOWN_OPCODES = frozenset(range(1, 16)) - {10}      # 10 is the attachment index


class RecordError(ValueError):
    """A record cannot be read: ``offset`` is where it starts in the file (or chunk)."""

    def __init__(self, offset: int, problem: str):
        self.offset = offset
        super().__init__(f"record at byte {offset}: {problem}")


#: what reading a damaged record's fields raises (RecordError is a ValueError)
READ_ERRORS = (ValueError, struct.error, UnicodeDecodeError, IndexError, EOFError, McapError)


@dataclass(frozen=True)
class Record:
    opcode: int
    offset: int                 # of the opcode byte, in the file
    body: bytes

    @property
    def end(self) -> int:
        return self.offset + 9 + len(self.body)


def scan(f: BinaryIO, size: int, start: int = len(MAGIC)) -> Iterator[Record]:
    """Every record from ``start`` on, in file order; raises :class:`RecordError` at the first
    record whose opcode is unknown or whose length runs past the end of the file or above
    :data:`MAX_RECORD_BYTES`. Stops after the Footer."""
    pos = start
    f.seek(pos)
    while pos < size:
        head = f.read(9)
        if len(head) < 9:
            raise RecordError(pos, "the file ends inside a record header")
        opcode, length = _RECORD_HEAD.unpack(head)
        if opcode not in KNOWN_OPCODES:
            raise RecordError(pos, f"unknown opcode 0x{opcode:02x}")
        if pos + 9 + length > size:
            raise RecordError(pos, f"length {length} runs past the end of the file")
        if length > MAX_RECORD_BYTES:
            raise RecordError(pos, f"length {length} is above the limit of {MAX_RECORD_BYTES}")
        body = f.read(length)
        yield Record(opcode, pos, body)
        pos += 9 + length
        if opcode == OP_FOOTER:
            return


@dataclass(frozen=True)
class Chunk:
    start_ns: int
    end_ns: int
    uncompressed_size: int
    crc: int
    compression: str
    compressed_size: int
    data: bytes                 # the uncompressed records


def open_chunk(body: bytes, *, check_crc: bool = True) -> Chunk:
    """Decode a Chunk record's body (raises ValueError naming the problem)."""
    if len(body) < _CHUNK_FIXED.size + 4:
        raise ValueError("chunk record too short")
    start, end, usize, crc = _CHUNK_FIXED.unpack_from(body, 0)
    (clen,) = struct.unpack_from("<I", body, 28)
    if 32 + clen + 8 > len(body):
        raise ValueError("chunk compression name runs past the record")
    try:
        compression = body[32:32 + clen].decode()
    except UnicodeDecodeError:
        raise ValueError("chunk compression name is not text") from None
    (dlen,) = struct.unpack_from("<Q", body, 32 + clen)
    if 40 + clen + dlen != len(body):
        raise ValueError(f"chunk data length {dlen} does not fit the record")
    if usize > MAX_CHUNK_BYTES:
        raise ValueError(f"chunk claims {usize} uncompressed bytes (limit {MAX_CHUNK_BYTES})")
    raw = body[40 + clen:]
    if compression == "zstd":
        try:
            data = zstandard.ZstdDecompressor().decompress(raw, max_output_size=usize)
        except zstandard.ZstdError as exc:
            raise ValueError(f"zstd data does not decompress ({exc})") from None
    elif compression == "lz4":
        import lz4.frame
        try:
            data = lz4.frame.decompress(raw)
        except RuntimeError as exc:
            raise ValueError(f"lz4 data does not decompress ({exc})") from None
    elif compression == "":
        data = bytes(raw)
    else:
        raise ValueError(f"unknown chunk compression {compression!r}")
    if len(data) != usize:
        raise ValueError(f"chunk holds {len(data)} bytes, its header says {usize}")
    if check_crc and crc and zlib.crc32(data) != crc:
        raise ValueError("chunk CRC mismatch (the chunk's data is damaged)")
    return Chunk(start, end, usize, crc, compression, dlen, data)


@dataclass
class ChunkMessages:
    """The Message records of one chunk (arrays in record order) and its other records."""

    offset: np.ndarray          # of each record in the chunk
    channel: np.ndarray
    sequence: np.ndarray
    log_time: np.ndarray
    publish_time: np.ndarray
    size: np.ndarray            # payload bytes
    others: list[tuple[int, int, bytes]]      # (opcode, offset, body) of non-message records

    def payload(self, data: bytes, i: int) -> bytes:
        start = int(self.offset[i]) + MESSAGE_HEADER.size
        return data[start:start + int(self.size[i])]


def chunk_messages(data: bytes, hint: np.ndarray | None = None) -> ChunkMessages:
    """Find the records in a chunk's data. ``hint``: claimed record offsets (from the message
    indexes); when they tile the data exactly with Message records the walk is done in numpy,
    otherwise record by record. Raises :class:`RecordError` for a record that does not fit."""
    buf = np.frombuffer(data, np.uint8)
    if hint is not None and len(hint):
        offsets = np.sort(hint.astype(np.int64))
        if offsets[-1] + 9 <= len(buf) and offsets[0] == 0:
            ops = buf[offsets]
            lengths = buf[offsets[:, None] + np.arange(1, 9)].copy().view("<u8")[:, 0]
            ends = offsets + 9 + lengths.astype(np.int64)
            if (np.all(ops == OP_MESSAGE) and np.all(lengths >= MESSAGE_HEADER.size - 9)
                    and np.array_equal(ends[:-1], offsets[1:]) and ends[-1] == len(buf)):
                return _messages_at(buf, offsets, lengths, [])
    offsets, lengths, others = [], [], []
    pos = 0
    while pos < len(data):
        if pos + 9 > len(data):
            raise RecordError(pos, "a record header is cut off at the end of the chunk")
        opcode, length = _RECORD_HEAD.unpack_from(data, pos)
        if pos + 9 + length > len(data):
            raise RecordError(pos, f"length {length} runs past the end of the chunk")
        if opcode == OP_MESSAGE:
            if length < MESSAGE_HEADER.size - 9:
                raise RecordError(pos, "message record shorter than its fixed fields")
            offsets.append(pos)
            lengths.append(length)
        elif opcode in (OP_SCHEMA, OP_CHANNEL):
            others.append((opcode, pos, bytes(data[pos + 9:pos + 9 + length])))
        else:
            raise RecordError(pos, f"opcode 0x{opcode:02x} cannot be inside a chunk")
        pos += 9 + length
    return _messages_at(buf, np.asarray(offsets, np.int64), np.asarray(lengths, np.uint64),
                        others)


def _messages_at(buf, offsets, lengths, others) -> ChunkMessages:
    fixed = buf[offsets[:, None] + np.arange(9, MESSAGE_HEADER.size)].copy()
    return ChunkMessages(
        offsets, fixed[:, 0:2].copy().view("<u2")[:, 0], fixed[:, 2:6].copy().view("<u4")[:, 0],
        fixed[:, 6:14].copy().view("<u8")[:, 0].astype(np.int64),
        fixed[:, 14:22].copy().view("<u8")[:, 0].astype(np.int64),
        lengths.astype(np.int64) - (MESSAGE_HEADER.size - 9), others)
