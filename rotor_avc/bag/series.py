"""A topic's messages as numpy arrays (:class:`TopicSeries`), and messages of one topic decoded
one by one gathered into one (:func:`series_of_messages`: the numeric fields every message has
in one shape). rotor_avc.bag.reader decodes fixed-size messages with one numpy copy instead."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import BagError
from .topics import labels_of


@dataclass
class TopicSeries:
    """One topic as arrays: ``time_ns`` (log time) and every numeric field by path
    (``accel.linear.z``, ``position`` (N, count), ``header.stamp.sec`` ...). For a labelled
    array ``series["bearing_D_vz"]`` is that column of ``data``; ``"position[0]"`` picks one
    element of a sequence field."""

    topic: str
    msg_type: str
    time_ns: np.ndarray
    fields: dict[str, np.ndarray]
    labels: list[str]

    @property
    def time_s(self) -> np.ndarray:
        return self.time_ns * 1e-9

    def __getitem__(self, name: str) -> np.ndarray:
        if name in self.fields:
            return self.fields[name]
        if name in self.labels and "data" in self.fields:
            return self.fields["data"][:, self.labels.index(name)]
        base, _, rest = name.partition("[")
        if rest.endswith("]") and rest[:-1].isdigit() and base in self.fields:
            column = int(rest[:-1])
            values = self.fields[base]
            if values.ndim == 2 and column < values.shape[1]:
                return values[:, column]
        raise BagError(self.topic, f"no field {name!r}",
                       fix="use one of " + ", ".join(list(self.fields) + self.labels))


def series_of_messages(topic: str, msg_type: str, times, messages) -> TopicSeries:
    """Decoded messages (dicts) of one topic as a :class:`TopicSeries`."""
    flat, labels = [], []
    for msg in messages:
        flat.append(dict(numeric_leaves(msg, "")))
        labels = labels or labels_of(msg)
    common = set(flat[0]).intersection(*flat[1:])
    fields = {}
    for path in flat[0]:
        if path in common and len({np.shape(f[path]) for f in flat}) == 1:
            fields[path] = np.array([f[path] for f in flat])
    return TopicSeries(topic, msg_type, np.asarray(times, np.int64), fields, labels)


def numeric_leaves(msg: dict, prefix: str):
    """``(path, value)`` of every numeric field of a decoded message (``a.b``, ``c[0].d``)."""
    for key, value in msg.items():
        path = prefix + key
        if isinstance(value, dict):
            yield from numeric_leaves(value, path + ".")
        elif isinstance(value, np.ndarray):
            yield path, value
        elif isinstance(value, list):
            for i, item in enumerate(value):
                if isinstance(item, dict):
                    yield from numeric_leaves(item, f"{path}[{i}].")
        elif isinstance(value, (int, float, bool)):
            yield path, value
