"""``rotor-avc bag info|check|recover BAG``: inspect, check and recover bags.

* ``info`` -- what the file holds, from its summary section at once
  (:mod:`rotor_avc.bag.summary`; a rosbag2 directory: its ``metadata.yaml`` and each file's
  summary): profile, library,
  duration, topics with types, counts and rates, chunks, compression, metadata records; with
  ``--integrity`` from one streaming pass over the data (:mod:`rotor_avc.bag.integrity`) with
  the integrity summary;
* ``check`` -- the ``ros2 bag`` / Foxglove / PlotJuggler pitfalls (:mod:`rotor_avc.bag.check`),
  one line per check; exit status 0 when all pass, 4 otherwise;
* ``recover`` -- a new bag with every intact chunk (:mod:`rotor_avc.bag.recover`), kept and
  lost messages per topic.
"""
from __future__ import annotations

import sys
from pathlib import Path

from ..bag.check import bag_files, check_bag
from ..bag.errors import EXIT_CORRUPT
from ..bag.integrity import scan_bag
from ..bag.recover import recover_bag
from ..bag.summary import read_summary
from ..studies.progress import Bars

NAME = "bag"
HELP = "inspect (info), check (ros2 bag / Foxglove pitfalls, integrity) or recover a bag"
EXAMPLE = "rotor-avc bag check bags/run.mcap   (also: bag info BAG, bag recover BAG --out NEW)"
#: exit status of an interrupted command (128 + SIGINT)
EXIT_INTERRUPTED = 130


def add_arguments(p) -> None:
    sub = p.add_subparsers(dest="bag_command", metavar="ACTION", required=True)
    info = sub.add_parser("info", help="profile, topics, counts, rates, chunks (from the "
                                       "summary; --integrity: from the data)")
    info.add_argument("bag", help="a .mcap file or a rosbag2 directory")
    info.add_argument("--integrity", action="store_true",
                      help="read every record of the data and check it against the summary, "
                           "indexes, CRCs and schemas (exit 4 on a problem)")
    check = sub.add_parser("check", help="the ros2 bag / Foxglove / PlotJuggler pitfalls; exit "
                                         "4 unless all pass")
    check.add_argument("bag", help="a .mcap file or a rosbag2 directory")
    recover = sub.add_parser("recover", help="a new bag with every intact chunk")
    recover.add_argument("bag", help="the damaged or unfinished .mcap file")
    recover.add_argument("--out", type=Path, default=None,
                         help="the new file (default BAG with suffix .recovered.mcap); must "
                              "not exist")


def run(args) -> int:
    try:
        return {"info": _info, "check": _check, "recover": _recover}[args.bag_command](args)
    except KeyboardInterrupt:
        print("rotor-avc bag: interrupted; no output file was written", file=sys.stderr)
        return EXIT_INTERRUPTED


def _info(args) -> int:
    files, info = bag_files(args.bag)
    if args.integrity:
        return _info_integrity(files)
    if info is not None:
        _directory_lines(args.bag, info)
    listed = {str(e.get("path")): e.get("message_count")
              for e in (info or {}).get("files") or [] if isinstance(e, dict)}
    for path in files:
        s = read_summary(path)
        stats = s.statistics
        _header_lines(path, s.size_bytes, s.profile, s.library, s.duration_s,
                      stats.message_count, stats.chunk_count, s.compressions,
                      s.metadata_names)
        _topic_lines(sorted(s.topics, key=lambda t: t.topic))
        print(f"  from the summary (summary CRC {s.summary_crc}); the data is not read: "
              "`bag info --integrity` checks it")
        if path.name in listed and listed[path.name] != stats.message_count:
            print(f"  note: metadata.yaml lists {listed[path.name]} message(s) for this file, "
                  f"its statistics {stats.message_count}: `rotor-avc bag check` compares both "
                  "with the data")
    return 0


def _directory_lines(path, info: dict) -> None:
    """A rosbag2 directory's own lines, from its metadata.yaml."""
    start = (info.get("starting_time") or {}).get("nanoseconds_since_epoch")
    duration = (info.get("duration") or {}).get("nanoseconds")
    duration_s = f"{duration * 1e-9:.6g}" if isinstance(duration, int) else "?"
    print(f"{path}: rosbag2 directory, storage {info.get('storage_identifier')!r}, "
          f"{len(info.get('relative_file_paths') or [])} file(s); metadata.yaml: "
          f"{info.get('message_count')} messages, start {start} ns, duration {duration_s} s")


def _header_lines(path, size, profile, library, duration_s, messages, chunks, compressions,
                  metadata) -> None:
    print(f"{path}: {size} bytes, profile {profile!r}, library {library!r}")
    print(f"  duration {duration_s:.6g} s, {messages} messages, {chunks} chunk(s), "
          f"compression {', '.join(sorted(compressions)) or '-'}")
    print(f"  metadata records: {', '.join(sorted(metadata)) or '-'}")


def _topic_lines(topics) -> None:
    width = max((len(t.topic) for t in topics), default=5)
    for t in topics:
        rate = "-" if t.rate_hz is None else f"{t.rate_hz:.4g}"
        print(f"  {t.topic:<{width}}  {t.msg_type:<34} {t.count:>9}  {rate:>10} Hz")


def _info_integrity(files) -> int:
    status = 0
    for path in files:
        with Bars("MB") as bar:
            r = scan_bag(path, bar)
        topics = sorted(r.topics.values(), key=lambda t: t.topic)
        starts = [t.start_ns for t in topics if t.count]
        ends = [t.end_ns for t in topics if t.count]
        duration_s = (max(ends) - min(starts)) * 1e-9 if starts else 0.0
        _header_lines(path, r.size_bytes, r.profile, r.library, duration_s, r.message_count,
                      r.chunks, r.compressions, r.metadata)
        _topic_lines(topics)
        print("  integrity: " + ("ok (" + (", ".join(f"{k} CRC {v}" for k, v in
                                                     sorted(r.crcs.items())) or "no CRCs")
                                 + ", indexes, statistics and schemas match the data)"
                                 if r.ok else f"{r.problem_count} problem(s):\n    "
                                 + r.verdict().replace("\n", "\n    ")))
        status = status or (0 if r.ok else EXIT_CORRUPT)
    return status


def _check(args) -> int:
    lines = check_bag(args.bag)
    print(f"{args.bag}:")
    for line in lines:
        print(f"  {line}")
    failed = [line.name for line in lines if not line.ok]
    print(f"{len(lines) - len(failed)} of {len(lines)} checks pass"
          + (f"; problems: {', '.join(failed)}" if failed else ""))
    return EXIT_CORRUPT if failed else 0


def _recover(args) -> int:
    result = recover_bag(args.bag, args.out)
    print(f"recovered {result.messages} message(s) into {result.path} "
          f"({result.chunks_kept} chunk(s) kept, {len(result.lost_chunks)} damaged part(s) "
          f"dropped, {result.dropped_bytes} bytes)")
    at_least = "" if result.lost_counted or not result.dropped_bytes else ">= "
    for topic in sorted(set(result.kept) | set(result.lost)):
        print(f"  {topic}: kept {result.kept.get(topic, 0)}, "
              f"lost {at_least}{result.lost.get(topic, 0)}")
    if at_least:
        print("  (the source has no statistics: what the dropped bytes held is not known)")
    for offset, why in result.lost_chunks:
        print(f"  dropped at byte {offset}: {why}")
    for note in result.notes:
        print(f"  note: {note}")
    return 0
