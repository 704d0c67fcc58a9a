"""Does a bag open cleanly in ``ros2 bag``, Foxglove and PlotJuggler? The known pitfalls, checked.

:func:`check_bag` takes a ``.mcap`` file or a rosbag2 directory (``metadata.yaml`` and its
``.mcap`` files) and returns one :class:`CheckLine` per pitfall, each ok or a problem with its
fix: the integrity pass (:mod:`.integrity`: CRCs, indexes, statistics, schemas, duplicates
against the data); profile ``ros2``; one message encoding, ``cdr``; complete ``ros2msg``
schemas (every dependency's text present); ``offered_qos_profiles`` as rosbag2 writes them
(:func:`qos_problems`); statistics, summary and chunk indexes and message indexes present (a
file without them is read by scanning, and Foxglove cannot seek in it); log times in order on
every sampled topic (a topic with several publishers, like ``/diagnostics``, is listed); the
``metadata.yaml`` information (the ``rosbag2`` record of a single file, or a directory's
``metadata.yaml``, :mod:`.rosbag2_info`) consistent with the data: file list, per-file and per-topic
counts, start and duration, types, QoS strings; and, for the package's own bags, every sample
present (:mod:`.sequence`) and, for a graph run's, that it was lockstep (the
``rotor_avc_lockstep`` record, :mod:`.lockstep`: no fault policy stood in for an answer, no
answer changed, no responder absent).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import yaml

from .errors import BagError, no_such_bag
from .integrity import IntegrityReport, TopicData, scan_bag
from .lockstep import read_lockstep
from .metadata import CONFIG_RECORD, DEFAULT_QOS, QOS_CHOICES, load_yaml
from .reader import BagReader
from .rosbag2 import METADATA_FILE, bagfile_information, inside_bag, listed_files
from .rosbag2_info import check_rosbag2_info
from .sequence import check_sequence
from .topics import SAMPLED


@dataclass(frozen=True)
class CheckLine:
    name: str
    ok: bool
    detail: str = ""
    fix: str = ""

    def __str__(self) -> str:
        if self.ok:
            return f"ok       {self.name}" + (f": {self.detail}" if self.detail else "")
        return f"PROBLEM  {self.name}: {self.detail}" + (f" -- fix: {self.fix}" if self.fix else "")


def bag_files(path) -> tuple[list[Path], dict | None]:
    """The ``.mcap`` files of a bag and, for a directory, its ``metadata.yaml`` mapping; every
    file confined to the bag's folder (:func:`.rosbag2.inside_bag`)."""
    path = Path(path)
    if path.is_file():
        return [path], None
    if not path.is_dir():
        raise no_such_bag(path, "bag file or directory")
    body = bagfile_information(path)
    files = listed_files(path, body)
    if not files:
        files = [inside_bag(path, f.name, "the file") for f in sorted(path.glob("*.mcap"))]
    return files, body


def check_bag(path) -> list[CheckLine]:
    """One line per pitfall (see the module docstring)."""
    path = Path(path)
    files, info = bag_files(path)
    lines: list[CheckLine] = []
    missing = [f.name for f in files if not f.is_file()]
    if info is not None:
        lines.append(CheckLine("files", not missing, f"{len(files)} file(s) listed"
                               + (f"; missing: {', '.join(missing)}" if missing else ""),
                               "restore the files or rebuild metadata.yaml (`ros2 bag reindex`)"))
    reports = [scan_bag(f) for f in files if f.is_file()]
    lines += _format_lines(reports)
    lines += _qos_lines(reports)
    lines += _index_lines(reports)
    lines.append(_integrity_line(reports))
    lines.append(_metadata_line(path, reports, info))
    if len(reports) == 1 and CONFIG_RECORD in reports[0].metadata and reports[0].ok:
        lines.append(_samples_line(reports[0].path))
    lines += _lockstep_lines(reports)
    return lines


def _lockstep_lines(reports) -> list[CheckLine]:
    """The lockstep record's verdict (no line for a bag without one)."""
    out = []
    for r in reports:
        try:
            record = read_lockstep(r.metadata, r.path)
        except BagError as exc:
            out.append(CheckLine("lockstep", False, str(exc), "re-record the run"))
            continue
        if record is not None:
            out.append(CheckLine("lockstep", record.ok, record.verdict(),
                                 "record the run again with fault_policy wait (the default) and "
                                 "every responder running; a fault study's bag is not a "
                                 "lockstep run"))
    return out


def _format_lines(reports: list[IntegrityReport]) -> list[CheckLine]:
    profiles = sorted({r.profile for r in reports})
    encodings = sorted({c.message_encoding for r in reports for c in r.channels.values()})
    schemas = sorted({s.encoding for r in reports for s in r.schemas.values()})
    undecodable = {t: why for r in reports for t, why in r.undecodable.items()}
    undecodable.update({p.where: p.detail for r in reports for p in r.problems
                        if p.check == "schema"})
    return [
        CheckLine("profile", profiles == ["ros2"], f"profile {', '.join(profiles) or '(none)'}",
                  "write the bag with rosbag2's MCAP plugin or this package (profile ros2)"),
        CheckLine("message encoding", encodings in (["cdr"], []),
                  f"channels encode {', '.join(encodings) or 'nothing'}",
                  "record every topic as cdr (ros2 bag play and Foxglove's ROS 2 decoders "
                  "read only cdr)"),
        CheckLine("schemas", not undecodable and schemas in (["ros2msg"], []),
                  "; ".join(f"{t}: {why}" for t, why in sorted(undecodable.items()))
                  or f"{sum(len(r.schemas) for r in reports)} ros2msg schema(s), complete",
                  "store each type's full ros2msg text with every dependency after a "
                  "`MSG: pkg/Type` line, as rosbag2 does"),
    ]


def qos_problems(text: str | None) -> list[str]:
    """What keeps an ``offered_qos_profiles`` entry from being decoded as rosbag2 writes it: a
    YAML list of profiles with every key of :data:`.metadata.DEFAULT_QOS`, enumerated values
    rosbag2 knows (:data:`.metadata.QOS_CHOICES`; ``unknown`` history with depth 0 is what
    ``ros2 bag record`` itself stores for a publisher), an integer depth >= 0 and durations as
    ``{sec, nsec}`` of non-negative integers."""
    if text is None:
        return ["no offered_qos_profiles"]
    try:
        profiles = load_yaml(text) if isinstance(text, str) else text
    except yaml.YAMLError as exc:
        return [f"not YAML ({exc})"]
    if not isinstance(profiles, list) or not profiles:
        return ["not a non-empty list of profiles"]
    out = []
    for i, p in enumerate(profiles):
        if not isinstance(p, dict):
            out.append(f"profile {i} is not a mapping")
            continue
        missing = [k for k in DEFAULT_QOS if k not in p]
        if missing:
            out.append(f"profile {i} lacks {', '.join(missing)}")
        for key, choices in QOS_CHOICES.items():
            if key in p and p[key] not in choices:
                out.append(f"profile {i}: {key} {p[key]!r} is not one of {', '.join(choices)}")
        depth = p.get("depth")
        if "depth" in p and not (isinstance(depth, int) and not isinstance(depth, bool)
                                 and depth >= 0):
            out.append(f"profile {i}: depth {depth!r} is not an integer >= 0")
        for key in ("deadline", "lifespan", "liveliness_lease_duration"):
            value = p.get(key)
            if key in p and not (isinstance(value, dict) and set(value) == {"sec", "nsec"}
                                 and all(isinstance(v, int) and v >= 0 for v in value.values())):
                out.append(f"profile {i}: {key} is not {{sec, nsec}} of integers >= 0")
    return out


def _qos_lines(reports) -> list[CheckLine]:
    problems = [f"{c.topic}: {p}" for r in reports for c in r.channels.values()
                for p in qos_problems(c.metadata.get("offered_qos_profiles"))]
    return [CheckLine("offered_qos_profiles", not problems, "; ".join(problems[:5])
                      + (f" (+{len(problems) - 5} more)" if len(problems) > 5 else "")
                      or "every channel, in rosbag2's form",
                      "store each channel's offered QoS as rosbag2's YAML list (every key, "
                      "rosbag2's enumeration strings, durations as {sec, nsec})")]


def _index_lines(reports) -> list[CheckLine]:
    absent = sorted({f"{r.path.name}: {k}" for r in reports for k, present in r.summary.items()
                     if not present})
    unread = [f"{r.path.name}: not reached (the file is broken before it)" for r in reports
              if not r.summary]
    unindexed = sum(r.chunks_without_index for r in reports)
    backwards = {t.topic: t.backwards for r in reports for t in r.topics.values() if t.backwards}
    sampled = {t: n for t, n in backwards.items() if SAMPLED.match(t)}
    others = "; ".join(f"{t}: {n} step(s) back (several publishers; readers sort by log time)"
                       for t, n in sorted(backwards.items()) if t not in sampled)
    return [
        CheckLine("summary", not absent and not unread,
                  "; ".join(absent + unread) or "statistics, chunk indexes, schemas, channels "
                  "and metadata indexes present",
                  "finish the file (`rotor-avc bag recover BAG` rebuilds the summary)"),
        CheckLine("message indexes", not unindexed,
                  f"{unindexed} chunk(s) without message indexes" if unindexed
                  else "every chunk indexed",
                  "rewrite the bag with message indexes (`rotor-avc bag recover BAG`)"),
        CheckLine("log times in order", not sampled,
                  "; ".join(f"{t}: {n} step(s) back" for t, n in sorted(sampled.items()))
                  or "every sampled topic" + (f"; {others}" if others else ""),
                  "write each topic's messages in log-time order"),
    ]


def _integrity_line(reports) -> CheckLine:
    problems = [f"{r.path.name}: {p}" for r in reports for p in r.problems]
    count = sum(r.problem_count for r in reports)
    crcs = sorted({f"{k} {v}" for r in reports for k, v in r.crcs.items()})
    return CheckLine("integrity", count == 0,
                     f"{count} problem(s): " + "; ".join(problems[:3]) if count
                     else "data match indexes, statistics and schemas; CRCs: "
                          + (", ".join(crcs) or "chunk"),
                     "the file is damaged or was altered: `rotor-avc bag recover BAG` keeps "
                     "every intact chunk")


def _metadata_line(path: Path, reports, info) -> CheckLine:
    if info is None:
        report = reports[0]
        record = report.metadata.get("rosbag2", {}).get("serialized_metadata")
        ok = record is not None
        return CheckLine("metadata.yaml", ok, "the rosbag2 record is present (the integrity line "
                         "checks it against the data)"
                         if ok else "no rosbag2 metadata record (ros2 bag info shows less)",
                         "write the rosbag2 record on close, as rosbag2's MCAP plugin does")
    merged = IntegrityReport(path / METADATA_FILE)
    data, channels = _merge(reports)
    check_rosbag2_info(merged, {"rosbag2_bagfile_information": info}, data, channels,
                       METADATA_FILE)
    if info.get("storage_identifier") != "mcap":
        merged.add("rosbag2", METADATA_FILE, f"storage_identifier "
                   f"{info.get('storage_identifier')!r}, not mcap")
    by_name = {r.path.name: r for r in reports}
    for i, entry in enumerate(info.get("files") or []):
        r = by_name.get(Path(str((entry or {}).get("path", ""))).name)
        if r is None:
            merged.add("rosbag2", f"{METADATA_FILE} files[{i}]", "names no file of the bag")
            continue
        _file_entry(merged, entry, r, f"{METADATA_FILE} files[{i}] ({r.path.name})")
    return CheckLine("metadata.yaml", merged.ok, merged.verdict().replace("\n", "; ")
                     or "file list, counts, start, duration, types and QoS match the files",
                     "rebuild it from the files (`ros2 bag reindex DIR`)")


def _file_entry(rep, entry, report: IntegrityReport, where: str) -> None:
    count = report.message_count
    starts = [t.start_ns for t in report.topics.values() if t.count]
    ends = [t.end_ns for t in report.topics.values() if t.count]
    want = {"message_count": count,
            "starting_time": min(starts) if starts else 0,
            "duration": max(ends) - min(starts) if starts else 0}
    have = {"message_count": entry.get("message_count"),
            "starting_time": (entry.get("starting_time") or {}).get("nanoseconds_since_epoch"),
            "duration": (entry.get("duration") or {}).get("nanoseconds")}
    for key in want:
        if have[key] != want[key]:
            rep.add("rosbag2", where, f"{key} is {have[key]}, the file has {want[key]}")


def _merge(reports) -> tuple[dict[str, TopicData], dict]:
    data: dict[str, TopicData] = {}
    channels = {}
    for r in reports:
        for t in r.topics.values():
            m = data.setdefault(t.topic, TopicData(t.topic, t.msg_type, t.channel_id))
            if t.count:
                m.start_ns = t.start_ns if m.start_ns is None else min(m.start_ns, t.start_ns)
                m.end_ns = t.end_ns if m.end_ns is None else max(m.end_ns, t.end_ns)
            m.count += t.count
        channels.update({c.topic: c for c in r.channels.values()})
    return data, channels


def _samples_line(path: Path) -> CheckLine:
    with BagReader(path) as reader:
        report = check_sequence(reader)
    return CheckLine("samples", report.ok, report.verdict().replace("\n", "; ")
                     or f"{report.samples} sample(s) on every sampled topic",
                     "record the run again (samples were lost)")
