"""The regression check of a replay (free of ROS): the answers a replay collected against the
bag's recorded answers, matched by stamp, every numeric field compared."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
    """Compare every collected answer topic with its recorded counterpart in the bag."""
    recorded_of = {a.topic: a.recorded for a in plan.answers.values()}
    checks = []
    for topic, answers in result.answers.items():
        recorded_topic = recorded_of.get(topic, topic)
        if recorded_topic not in reader.topics:
            checks.append(AnswerCheck(topic, recorded_topic, len(answers), 0, len(answers),
                                      result.missing.get(topic, 0), float("inf"), 0.0))
            continue
        codec = reader.codec(recorded_topic)
        time_of = m.raw_time_reader(reader.topics[recorded_topic].msg_type)
        recorded = {}
        for msg in reader.raw_messages(recorded_topic):
            stamp = time_of(msg.data)
            recorded.setdefault(msg.time_ns if stamp is None else stamp, msg.data)
        seen, diff, scale, compared, unmatched = set(), 0.0, 0.0, 0, 0
        for stamp, data in answers:
            if stamp in seen:
                continue                   # a repeated answer (a resent trigger)
            seen.add(stamp)
            if stamp not in recorded:
                unmatched += 1
                continue
            d, s = _leaf_difference(codec.decode(data), codec.decode(recorded[stamp]))
            diff, scale, compared = max(diff, d), max(scale, s), compared + 1
        checks.append(AnswerCheck(topic, recorded_topic, len(answers), compared, unmatched,
                                  result.missing.get(topic, 0), diff, scale))
    return checks


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
            d = np.where(np.isnan(x) & np.isnan(y), 0.0, np.abs(x - y))   # NaN = NaN only
            diff = max(diff, float(np.max(np.nan_to_num(d, nan=np.inf))))
            if np.asarray(value).dtype.kind == "f" or isinstance(value, float):
                scale = max(scale, float(np.max(np.abs(y))))
    return diff, scale
