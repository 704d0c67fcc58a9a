"""Which of a bag's topics a replay publishes, and under which names, checked against the bag
alone (no rclpy: ``rotor-avc replay`` checks its command line with it before ROS is imported;
rotor_avc.nodes.replay plans on it).

Every topic the command line names must be one the replay can use: ``--topics`` and the FROM of
``--remap FROM:=TO`` name bag topics, the TRIGGER of ``--wait-for TRIGGER:=ANSWER`` a published
one (after remapping). A name that is none of them is refused with the closest valid one and the
list of them (:func:`rotor_avc.errors.did_you_mean`), never silently left unused.
"""
from __future__ import annotations

import re

from ..errors import RotorAvcError, did_you_mean

_NAME = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")


class ReplayError(RotorAvcError):
    """Replay cannot go on as asked: the message names the topic and the fix."""


def _require_known(path: str, option: str, names, valid, where: str) -> None:
    """ReplayError naming each of ``names`` not in ``valid``, its closest valid name and them all."""
    unknown = [n for n in names if n not in valid]
    if unknown:
        raise ReplayError(f"{path}: {option}: no topic "
                          + ", ".join(n + did_you_mean(n, valid) for n in unknown)
                          + f" {where} -- fix: use one of " + ", ".join(sorted(valid)))


def select_topics(reader, topics=None, remap=None, triggers=()) -> dict[str, str]:
    """Bag topic -> published name of a replay of ``topics`` (default: every topic with
    messages) renamed by ``remap``, each decodable; ``triggers``: the published topics the
    wait-for rules name. ReplayError or BagError naming the topic and the fix."""
    path = str(reader.path)
    info = reader.topics
    remap = dict(remap or {})
    selected = list(dict.fromkeys(topics)) if topics else [t for t, i in info.items() if i.count]
    _require_known(path, "--topics", selected, info, "in the bag")
    _require_known(path, "--remap", remap, info, "in the bag")
    stray = [t for t in remap if t not in selected]
    if stray:
        raise ReplayError(f"{path}: --remap names {', '.join(stray)}, which is not replayed -- "
                          "fix: add it to --topics or drop the remap")
    bad = [name for name in remap.values() if not _NAME.fullmatch(name)]
    if bad:
        raise ReplayError(f"remap target {bad[0]!r} is not an absolute topic name -- fix: e.g. "
                          "/avc_replay/foot/DL/acceleration")
    empty = [t for t in selected if info[t].count == 0]
    if empty:
        raise ReplayError(f"{path}: topic {empty[0]} holds no messages -- fix: select topics "
                          "with messages (see `--topics`)")
    published = {t: remap.get(t, t) for t in selected}
    if len(set(published.values())) != len(published):
        raise ReplayError("two replayed topics would be published under one name -- fix: "
                          "remap them to distinct names")
    _require_known(path, "--wait-for", triggers, set(published.values()),
                   "among the published topics")
    for t in selected:
        reader.codec(t)            # BagError for a schema that cannot be decoded (unknown)
    return published
