"""CDR (XCDR1, little endian) encoding of ROS 2 messages, one at a time and in numpy batches.

The wire format rclpy/rmw produce and rosbag2 records: a 4-byte encapsulation header
``00 01 00 00`` (CDR_LE), then the fields in order, each primitive aligned to its own size (up to
8) relative to the end of the header; strings are ``uint32`` length (with the NUL) + bytes + NUL;
sequences a ``uint32`` count + elements; fixed arrays the elements only. Padding bytes carry no
meaning (rmw leaves them uninitialised), so nothing here compares them.

Messages are plain dicts: missing fields take their zero value on encoding; decoding gives
Python scalars, ``str``, numpy arrays for primitive sequences/arrays, lists of dicts for nested
sequences.

Batches: every message of a topic usually has the same structure (same strings, same sequence
lengths), so every numeric field sits at the same byte offset. :meth:`CdrCodec.layout` finds
those offsets from one message; :class:`Layout` then encodes or decodes N messages as an
``(N, size)`` byte matrix with one numpy copy per field -- the fast path of the bag writer
(:func:`~rotor_avc.bag.writer.BagWriter.write_streams`) and reader (``series``).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field as dc_field
from typing import Any, Mapping

import numpy as np

from .msgdefs import Field, MsgDefError, MsgSpec, full_name

HEADER_LE = b"\x00\x01\x00\x00"
#: primitive -> numpy dtype (little endian); size = itemsize = CDR alignment
DTYPES = {
    "bool": np.dtype("?"), "byte": np.dtype("u1"), "char": np.dtype("u1"),
    "int8": np.dtype("i1"), "uint8": np.dtype("u1"), "int16": np.dtype("<i2"),
    "uint16": np.dtype("<u2"), "int32": np.dtype("<i4"), "uint32": np.dtype("<u4"),
    "int64": np.dtype("<i8"), "uint64": np.dtype("<u8"), "float32": np.dtype("<f4"),
    "float64": np.dtype("<f8"),
}
_STRUCTS = {name: struct.Struct("<" + dt.char) for name, dt in DTYPES.items()}
_U32 = struct.Struct("<I")


class CdrError(ValueError):
    """A payload does not match its message definition (the reader wraps it)."""


@dataclass
class Layout:
    """Byte offsets of the numeric fields of messages with one fixed structure.

    ``leaves`` maps a field path (``accel.linear.z``, ``position``, ``status[0].level``) to
    ``(offset, dtype, count, is_scalar)``; ``prefixes`` maps the offsets of every string length
    and sequence count to its value -- messages whose prefixes all match share the layout.
    ``end`` is the byte after the last field (``size`` may include trailing bytes).
    """

    size: int
    end: int = 0
    leaves: dict[str, tuple[int, np.dtype, int, bool]] = dc_field(default_factory=dict)
    prefixes: dict[int, int] = dc_field(default_factory=dict)

    def matches(self, rows: np.ndarray) -> bool:
        """True when every row of an ``(N, size)`` byte matrix has this structure."""
        if rows.ndim != 2 or rows.shape[1] != self.size:
            return False
        return all(np.all(_column(rows, off, np.dtype("<u4"), 1)[:, 0] == value)
                   for off, value in self.prefixes.items())

    def decode(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """Every numeric field of N messages: ``(N,)`` for scalars, ``(N, count)`` otherwise."""
        out = {}
        for path, (off, dtype, count, scalar) in self.leaves.items():
            col = _column(rows, off, dtype, count)
            out[path] = col[:, 0] if scalar else col
        return out

    def encode(self, template: bytes, fields: Mapping[str, Any], n: int) -> np.ndarray:
        """``(n, size)`` payloads: ``template`` with the given fields overwritten per row."""
        rows = np.empty((n, self.size), np.uint8)
        rows[:] = np.frombuffer(template, np.uint8)
        for path, values in fields.items():
            if path not in self.leaves:
                raise CdrError(f"no numeric field {path!r}; fields: " + ", ".join(self.leaves))
            off, dtype, count, _ = self.leaves[path]
            arr = np.asarray(values)
            if arr.size != n * count:
                raise CdrError(f"field {path!r}: need {n} x {count} values, got shape {arr.shape}")
            raw = np.ascontiguousarray(arr.reshape(n, count).astype(dtype, copy=False))
            rows[:, off:off + count * dtype.itemsize] = raw.view(np.uint8).reshape(n, -1)
        return rows


def _column(rows: np.ndarray, off: int, dtype: np.dtype, count: int) -> np.ndarray:
    raw = np.ascontiguousarray(rows[:, off:off + count * dtype.itemsize])
    return raw.view(dtype).reshape(rows.shape[0], count)


class CdrCodec:
    """Encoder/decoder of one message type over its specs (from :mod:`.msgdefs`)."""

    def __init__(self, type_name: str, specs: Mapping[str, MsgSpec]):
        self.type_name = full_name(type_name)
        self.specs = specs
        for spec in specs.values():
            for f in spec.fields:
                if f.type == "wstring":
                    raise MsgDefError(f"{spec.name}.{f.name}: wstring fields are not supported")
        if self.type_name not in specs:
            raise MsgDefError(f"no definition of {self.type_name}")

    # -- encoding --------------------------------------------------------------------------
    def encode(self, msg: Mapping[str, Any]) -> bytes:
        buf = bytearray(HEADER_LE)
        self._encode(self.specs[self.type_name], msg or {}, buf, self.type_name)
        return bytes(buf)

    def _encode(self, spec: MsgSpec, msg: Mapping, buf: bytearray, path: str) -> None:
        for f in spec.fields:
            value = msg.get(f.name) if isinstance(msg, Mapping) else getattr(msg, f.name, None)
            where = f"{path}.{f.name}"
            if f.kind == "scalar":
                self._encode_one(f, value, buf, where)
                continue
            if f.type in DTYPES:
                if value is None:
                    value = np.zeros(f.size if f.kind == "array" else 0)
                try:
                    value = np.asarray(value).astype(DTYPES[f.type]).ravel()
                except (TypeError, ValueError) as exc:
                    raise CdrError(f"{where}: not a list of {f.type} ({exc})") from None
            elif value is None:
                value = [None] * f.size if f.kind == "array" else []
            n = len(value)
            if f.kind == "array" and n != f.size:
                raise CdrError(f"{where}: fixed array of {f.size}, got {n} items")
            if f.kind == "bounded" and n > f.size:
                raise CdrError(f"{where}: at most {f.size} items, got {n}")
            if f.kind != "array":
                _pad(buf, 4)
                buf += _U32.pack(n)
            if f.type in DTYPES:
                if n:
                    _pad(buf, DTYPES[f.type].itemsize)
                    buf += value.tobytes()
            else:
                for i, item in enumerate(value):
                    self._encode_one(f, item, buf, f"{where}[{i}]")

    def _encode_one(self, f: Field, value: Any, buf: bytearray, where: str) -> None:
        if f.nested:
            self._encode(self.specs[f.type], value if value is not None else {}, buf, where)
        elif f.type == "string":
            data = ("" if value is None else str(value)).encode("utf-8")
            if f.string_bound and len(data) > f.string_bound:
                raise CdrError(f"{where}: string longer than {f.string_bound} bytes")
            _pad(buf, 4)
            buf += _U32.pack(len(data) + 1) + data + b"\x00"
        else:
            st = _STRUCTS[f.type]
            _pad(buf, st.size)
            try:
                buf += st.pack(0 if value is None else (value if f.type != "bool" else bool(value)))
            except struct.error as exc:
                raise CdrError(f"{where}: {value!r} is not a valid {f.type} ({exc})") from None

    # -- decoding --------------------------------------------------------------------------
    def decode(self, data: bytes) -> dict:
        return _Decoder(self.specs, data).message(self.specs[self.type_name])

    def layout(self, data: bytes) -> Layout:
        """The field offsets of this message's structure (see :class:`Layout`)."""
        dec = _Decoder(self.specs, data, Layout(len(data)))
        dec.message(self.specs[self.type_name])
        dec.layout.end = dec.pos
        return dec.layout


def _pad(buf: bytearray, align: int) -> None:
    rem = (len(buf) - 4) % align
    if rem:
        buf += b"\x00" * (align - rem)


class _Decoder:
    def __init__(self, specs: Mapping[str, MsgSpec], data: bytes, layout: Layout | None = None):
        if len(data) < 4:
            raise CdrError(f"payload of {len(data)} bytes is shorter than the CDR header")
        if data[1] != 1 or data[0] != 0:
            kind = ("big-endian CDR" if data[:2] == b"\x00\x00"
                    else f"encapsulation {bytes(data[:2]).hex()}")
            raise CdrError(f"{kind} is not supported (only little-endian CDR, header 00 01)")
        self.specs, self.data, self.pos, self.layout = specs, memoryview(data), 4, layout

    def _align(self, n: int) -> None:
        rem = (self.pos - 4) % n
        if rem:
            self.pos += n - rem

    def _take(self, n: int) -> int:
        start = self.pos
        self.pos += n
        if self.pos > len(self.data):
            raise CdrError(f"payload ends at byte {len(self.data)}, needed {self.pos}")
        return start

    def _count(self) -> int:
        self._align(4)
        start = self._take(4)
        (value,) = _U32.unpack_from(self.data, start)
        if self.layout is not None:
            self.layout.prefixes[start] = value
        return value

    def message(self, spec: MsgSpec, path: str = "") -> dict:
        out = {}
        for f in spec.fields:
            where = f"{path}{f.name}"
            if f.kind == "scalar":
                out[f.name] = self._one(f, where, scalar=True)
                continue
            n = f.size if f.kind == "array" else self._count()
            if f.type in DTYPES:
                dtype = DTYPES[f.type]
                if n:
                    self._align(dtype.itemsize)
                start = self._take(n * dtype.itemsize)
                out[f.name] = np.frombuffer(self.data, dtype, n, start).copy()
                if self.layout is not None and n:
                    self.layout.leaves[where] = (start, dtype, n, False)
            else:
                out[f.name] = [self._one(f, f"{where}[{i}]", scalar=False) for i in range(n)]
        return out

    def _one(self, f: Field, where: str, scalar: bool):
        if f.nested:
            return self.message(self.specs[f.type], where + ".")
        if f.type == "string":
            n = self._count()
            start = self._take(n)
            if n == 0 or self.data[start + n - 1] != 0:
                raise CdrError(f"{where}: string without its terminating NUL")
            return bytes(self.data[start:start + n - 1]).decode("utf-8", errors="replace")
        st = _STRUCTS[f.type]
        self._align(st.size)
        start = self._take(st.size)
        if self.layout is not None:
            self.layout.leaves[where] = (start, DTYPES[f.type], 1, True)
        return st.unpack_from(self.data, start)[0]
