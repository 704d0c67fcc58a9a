"""The regression check of a replay (free of ROS): the answers a replay collected against the
bag's recorded answers, matched by stamp, every numeric field compared."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..bag.cdr import CdrCodec, Layout
from ..bag.reader import BagReader
from ..bag.series import numeric_leaves
from . import messages as m
from .replay import ReplayPlan, ReplayResult


@dataclass(frozen=True)
class AnswerCheck:
    """Live answers of one topic against the bag's recorded answers, matched by stamp."""

    topic: str
    recorded_topic: str
    answers: int
    compared: int               # answers with a recorded message of the same stamp
    unmatched: int              # answers without one
    unanswered: int             # triggers replayed but never answered
    max_abs_diff: float         # over every numeric field of the compared messages
    max_abs_value: float        # largest recorded value of those fields (the scale)

    def passed(self, tolerance: float) -> bool:
        return (self.compared > 0 and self.unmatched == 0 and self.unanswered == 0
                and self.max_abs_diff <= tolerance)


def compare_answers(reader: BagReader, plan: ReplayPlan, result: ReplayResult) -> list[AnswerCheck]:
    """Compare every collected answer topic with its recorded counterpart in the bag (the bag
    read once for all of them; the fields of fixed-size messages compared as arrays)."""
    recorded_of = {a.topic: a.recorded for a in plan.answers.values()}
    wanted = {recorded_of.get(topic, topic) for topic in result.answers}
    present = sorted(t for t in wanted if t in reader.topics)
    recorded: dict[str, dict[int, bytes]] = {t: {} for t in present}
    time_of = {t: m.raw_time_reader(reader.topics[t].msg_type) for t in present}
    for msg in reader.raw_messages(present) if present else ():
        stamp = time_of[msg.topic](msg.data)
        recorded[msg.topic].setdefault(msg.time_ns if stamp is None else stamp, msg.data)
    checks = []
    for topic, answers in result.answers.items():
        recorded_topic = recorded_of.get(topic, topic)
        missing = result.missing.get(topic, 0)
        if recorded_topic not in recorded:
            checks.append(AnswerCheck(topic, recorded_topic, len(answers), 0, len(answers),
                                      missing, float("inf"), 0.0))
            continue
        by_stamp = recorded[recorded_topic]
        seen, live, kept, unmatched = set(), [], [], 0
        for stamp, data in answers:
            if stamp in seen:
                continue                   # a repeated answer (a resent trigger)
            seen.add(stamp)
            if stamp not in by_stamp:
                unmatched += 1
                continue
            live.append(data)
            kept.append(by_stamp[stamp])
        diff, scale = _difference(reader.codec(recorded_topic), live, kept)
        checks.append(AnswerCheck(topic, recorded_topic, len(answers), len(live), unmatched,
                                  missing, diff, scale))
    return checks


def _difference(codec: CdrCodec, live: list[bytes], recorded: list[bytes]) -> tuple[float, float]:
    """:func:`_leaf_difference` over pairs of messages: the largest difference and scale. Messages
    of one fixed-size structure (the answers' usual case) are compared field by field as arrays
    (rotor_avc.bag.cdr.Layout, one numpy copy per field); others message by message."""
    if not live:
        return 0.0, 0.0
    layout = codec.layout(recorded[0])
    a, b = _columns(layout, live), _columns(layout, recorded)
    if a is None or b is None:
        pairs = [_leaf_difference(codec.decode(x), codec.decode(y))
                 for x, y in zip(live, recorded)]
        return max(d for d, _ in pairs), max(s for _, s in pairs)
    diff = scale = 0.0
    for path, y in b.items():
        d = _abs_difference(a[path].astype(float), y.astype(float))
        diff = max(diff, float(d.max()))
        if y.dtype.kind == "f":
            scale = max(scale, float(np.abs(y).max()))
    return diff, scale


def _columns(layout: Layout, payloads: list[bytes]) -> dict[str, np.ndarray] | None:
    """Every numeric field of ``payloads`` as arrays, or None when they do not all have the
    structure of ``layout``."""
    if any(len(p) != layout.size for p in payloads):
        return None
    rows = np.frombuffer(b"".join(payloads), np.uint8).reshape(len(payloads), layout.size)
    return layout.decode(rows) if layout.matches(rows) else None


def _abs_difference(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``|x - y|`` with NaN equal to NaN only (one NaN against a number: inf)."""
    d = np.where(np.isnan(x) & np.isnan(y), 0.0, np.abs(x - y))
    return np.nan_to_num(d, nan=np.inf)


def _leaf_difference(live: dict, recorded: dict) -> tuple[float, float]:
    """(max |live - recorded| over every numeric field, max |recorded| over the floating-point
    fields, i.e. the values without the stamps); inf when the structures differ or only one
    of two values is NaN."""
    a, b = dict(numeric_leaves(live, "")), dict(numeric_leaves(recorded, ""))
    if a.keys() != b.keys():
        return float("inf"), 0.0
    diff = scale = 0.0
    for path, value in b.items():
        x, y = np.asarray(a[path], float), np.asarray(value, float)
        if x.shape != y.shape:
            return float("inf"), 0.0
        if y.size:
            diff = max(diff, float(np.max(_abs_difference(x, y))))
            if np.asarray(value).dtype.kind == "f" or isinstance(value, float):
                scale = max(scale, float(np.max(np.abs(y))))
    return diff, scale
