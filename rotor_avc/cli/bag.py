"""``rotor-avc bag info|check|recover BAG``: inspect, check and recover bags.

* ``info`` -- what the file holds, from one streaming pass over its data
  (:mod:`rotor_avc.bag.integrity`): profile, library, duration, topics with types, counts and
  rates, chunks, compression, metadata records and the integrity summary;
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

NAME = "bag"
HELP = "inspect (info), check (ros2 bag / Foxglove pitfalls, integrity) or recover a bag"
EXAMPLE = "rotor-avc bag check bags/run.mcap   (also: bag info BAG, bag recover BAG --out NEW)"
#: exit status of an interrupted command (128 + SIGINT)
EXIT_INTERRUPTED = 130


def add_arguments(p) -> None:
    sub = p.add_subparsers(dest="bag_command", metavar="ACTION", required=True)
    info = sub.add_parser("info", help="profile, topics, counts, rates, chunks, integrity")
    info.add_argument("bag", help="a .mcap file or a rosbag2 directory")
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
    files, _ = bag_files(args.bag)
    status = 0
    for path in files:
        r = scan_bag(path)
        topics = sorted(r.topics.values(), key=lambda t: t.topic)
        starts = [t.start_ns for t in topics if t.count]
        ends = [t.end_ns for t in topics if t.count]
        duration_s = (max(ends) - min(starts)) * 1e-9 if starts else 0.0
        print(f"{path}: {r.size_bytes} bytes, profile {r.profile!r}, library {r.library!r}")
        print(f"  duration {duration_s:.6g} s, {r.message_count} messages, {r.chunks} chunk(s), "
              f"compression {', '.join(sorted(r.compressions)) or '-'}")
        print(f"  metadata records: {', '.join(sorted(r.metadata)) or '-'}")
        width = max((len(t.topic) for t in topics), default=5)
        for t in topics:
            print(f"  {t.topic:<{width}}  {t.msg_type:<34} {t.count:>9}  {t.rate_hz:10.4g} Hz")
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
