"""A ``metadata.yaml`` (rosbag2's bag-file information) against what the data holds.

:func:`check_rosbag2_info` compares the per-topic message counts and types, the QoS strings,
the total count, the start and the duration with the topics of the data; the integrity pass
uses it for the ``rosbag2`` metadata record of a file, ``bag check`` for a directory's
``metadata.yaml``.
"""
from __future__ import annotations

from .metadata import parse_qos_yaml


def check_rosbag2_info(rep, info, data: dict, channels: dict, where: str) -> None:
    """Compare a ``metadata.yaml`` mapping (the ``rosbag2`` record or a directory's file) with
    ``data`` (topic -> :class:`.integrity.TopicData`) and ``channels`` (topic -> MCAP Channel);
    each problem goes to ``rep.add(check, where, detail)``."""
    if isinstance(info, dict) and "rosbag2_bagfile_information" in info:
        info = info["rosbag2_bagfile_information"]
    if not isinstance(info, dict):
        rep.add("rosbag2", where, "not a rosbag2 bag-file information mapping")
        return
    counted = {}
    for i, entry in enumerate(info.get("topics_with_message_count") or []):
        try:
            meta = entry["topic_metadata"]
            name, count = meta["name"], int(entry["message_count"])
        except (KeyError, TypeError, ValueError):
            rep.add("rosbag2", where, f"topics_with_message_count[{i}] lacks name or count")
            continue
        counted[name] = count
        t = data.get(name)
        have = t.count if t else 0
        if have != count:
            rep.add("rosbag2", f"{where}, topic {name}",
                    f"message_count is {count}, the data holds {have}")
        if t and meta.get("type") != t.msg_type:
            rep.add("rosbag2", f"{where}, topic {name}",
                    f"type is {meta.get('type')!r}, the schema is {t.msg_type!r}")
        channel = channels.get(name)
        if channel is not None and "offered_qos_profiles" in channel.metadata:
            listed = meta.get("offered_qos_profiles")
            listed = parse_qos_yaml(listed) if isinstance(listed, str) else listed
            if listed != parse_qos_yaml(channel.metadata["offered_qos_profiles"]):
                rep.add("rosbag2", f"{where}, topic {name}",
                        "offered_qos_profiles differ from the channel's")
    for name, t in data.items():
        if t.count and name not in counted:
            rep.add("rosbag2", f"{where}, topic {name}", f"{t.count} message(s) not listed")
    total = sum(t.count for t in data.values())
    if info.get("message_count") != total:
        rep.add("rosbag2", where, f"message_count is {info.get('message_count')}, "
                f"the data holds {total}")
    starts = [t.start_ns for t in data.values() if t.count]
    ends = [t.end_ns for t in data.values() if t.count]
    if starts:
        start, duration = min(starts), max(ends) - min(starts)
        got_start = (info.get("starting_time") or {}).get("nanoseconds_since_epoch")
        got_duration = (info.get("duration") or {}).get("nanoseconds")
        if got_start != start or got_duration != duration:
            rep.add("rosbag2", where, f"starting_time {got_start} ns / duration {got_duration} "
                    f"ns, the data spans {start} ns + {duration} ns")
