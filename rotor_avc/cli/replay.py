"""``rotor-avc replay``: publish a bag's messages into the ROS graph (rotor_avc.nodes.replay).

The bag is a ``.mcap`` file or a rosbag2 directory (``ros2 bag record``: metadata.yaml and split
files, rotor_avc.bag.rosbag2), e.g. a recording of a real machine whose driver topics
``--remap`` renames to the controllers' inputs. It is checked first, without ROS (a truncated
file, an unknown schema, an empty bag: one-line error, exit status 2; for a bag with this
package's run configuration, samples missing on a sampled topic or published but not recorded:
one verdict, exit status 3, rotor_avc.bag.sequence), and so are the topics the command line
names (``--topics``, ``--remap``, ``--wait-for``: a topic the bag does not hold is refused with
the closest one, rotor_avc.nodes.replay_topics); rclpy is imported only then, so the rest of the
command line works without ROS. With ``--check TOL`` the answers the graph gives (e.g. a
foot controller re-driven with the recorded foot accelerations) are compared with the recorded
answers of the same stamps, and the exit status is 1 when any differs by more than TOL, or when
the bag says its run was not lockstep (rotor_avc.bag.lockstep: the plant stepped without some
of the recorded answers, so they are no reference), said before anything is replayed. A timed
replay that cannot hold ``--rate`` says so (a warning with the achieved rate and the late log
times); that alone never fails the check (rotor_avc.nodes.replay).

Before it publishes anything, replay reads the configuration of every node answering a replayed
topic (its read-only ``answer_config`` parameter, rotor_avc.nodes.replay_config) and compares it
with the bag's recorded one (rotor_avc.compare.answer_config: the sample rate, ``G_c``, the
feedback quantity, the limits, the initial state ...): a node that differs -- or whose
configuration cannot be read -- is refused with exit status 2, one line per field (the bag's
value, the node's, the command that starts the node with the bag's configuration); ``--force``
replays anyway and says which fields differed, also in the check's verdict.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from ..bag.lockstep import read_lockstep
from ..bag.metadata import CONFIG_RECORD
from ..bag.rosbag2 import open_bag
from ..bag.sequence import require_complete
from ..compare.answer_config import BagAnswers, NodeCheck
from ..errors import RotorAvcError
from ..nodes.replay_topics import select_topics
from ..studies.progress import Progress
from .common import nonnegative_float

NAME = "replay"
#: an answering node refused (README's exit statuses: input refused)
EXIT_REFUSED = 2
HELP = ("Publish a bag's recorded messages into the ROS graph, raw, with their recorded timing "
        "(scaled by --rate) or lockstep as fast as the graph answers (--fast); compare the "
        "answers with the recorded ones (--check); a node answering with another "
        "configuration than the bag's is refused first (--force: replay anyway).")
EXAMPLE = ("rotor-avc replay bags/reference/case3_stepped.mcap --fast --topics "
           "/avc/foot/DL/acceleration --check 1e-12   # with `foot_controller --ros-args -p "
           "scenario:=scenario_reference -p foot_id:=DL` running\n"
           "  rotor-avc replay recording/ --fast --topics /accel_dl/data "
           "--remap /accel_dl/data:=/avc/foot/DL/acceleration   # a ros2 bag record directory")


def pair(text: str) -> tuple[str, str]:
    """``a:=b`` -> (a, b)."""
    a, sep, b = text.partition(":=")
    if not sep or not a or not b:
        raise argparse.ArgumentTypeError(f"{text!r} is not FROM:=TO (e.g. /avc/clock:=/clock)")
    return a, b


def positive_float(text: str) -> float:
    value = nonnegative_float(text)
    if value == 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
    return value


def add_arguments(p) -> None:
    p.add_argument("bag", type=Path, help="the bag: a .mcap file (rosbag2 MCAP profile) or a "
                                          "rosbag2 directory (metadata.yaml + .mcap files)")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--rate", type=positive_float, default=1.0,
                      help="timed replay at RATE x the recorded speed (default 1)")
    mode.add_argument("--fast", action="store_true",
                      help="lockstep: publish one log time's messages, wait for the answers "
                           "(foot measurement -> that foot's actuator_force, plant/observables "
                           "-> balancer/command, stamped alike; only from nodes that publish "
                           "them), then the next")
    p.add_argument("--topics", nargs="+", metavar="TOPIC",
                   help="replay only these bag topics (default: every topic with messages)")
    p.add_argument("--remap", nargs="+", type=pair, action="extend", default=[],
                   metavar="FROM:=TO", help="publish bag topic FROM as TO")
    p.add_argument("--wait-for", nargs="+", type=pair, action="extend", default=[],
                   metavar="TRIGGER:=ANSWER",
                   help="--fast: replace the default wait-for rules: after TRIGGER (a published "
                        "topic) wait for ANSWER stamped alike")
    p.add_argument("--check", type=nonnegative_float, metavar="TOL",
                   help="fail (exit 1) unless every answer equals the recorded one of the same "
                        "stamp within TOL (absolute, in the fields' units)")
    p.add_argument("--discovery-timeout", type=nonnegative_float, default=3.0, metavar="S",
                   help="wait at most S seconds for subscribers before starting (default 3)")
    p.add_argument("--answer-timeout", type=positive_float, default=5.0, metavar="S",
                   help="give up when an answer takes longer than S seconds (--fast; timed: when "
                        "waiting for the graph to catch up) (default 5)")
    p.add_argument("--executor", choices=("events", "single_threaded"), default="events",
                   help="rclpy executor (default events)")
    p.add_argument("--force", action="store_true",
                   help="replay even when an answering node runs another configuration than "
                        "the bag's (said in the output and the check's verdict)")


def run(args) -> int:
    with open_bag(args.bag, require_messages=True, integrity=True) as reader:
        if CONFIG_RECORD in reader.metadata:
            for note in require_complete(reader).notes:
                print(f"note: {note}")
            lockstep = read_lockstep(reader.metadata, args.bag)
            if lockstep is not None and not lockstep.ok:
                if args.check is not None:
                    print(f"check: FAIL -- the recorded answers are no reference: "
                          f"{lockstep.verdict()}")
                    return 1
                print(f"note: {lockstep.verdict()}")
        else:
            print("note: the bag carries no rotor_avc run configuration (a recording of another "
                  "source): its sample sequence and the answering nodes' configuration are not "
                  "checked")
        select_topics(reader, args.topics, dict(args.remap), [a for a, _ in args.wait_for])
        try:
            from ..nodes import replay as R          # rclpy: imported only here
            from ..nodes.replay_check import compare_answers
        except ImportError as exc:
            raise RotorAvcError(f"replay needs ROS 2 Jazzy's rclpy ({exc}) -- fix: install the "
                                "`ros` extra or source a ROS 2 installation") from None
        rules = ([R.AnswerRule.exact(a, b) for a, b in args.wait_for] if args.wait_for
                 else R.DEFAULT_RULES)
        plan = R.plan_replay(reader, args.topics, dict(args.remap), rules)
        print(f"replay {args.bag}: {len(plan.topics)} topic(s), "
              + ("lockstep (--fast)" if args.fast else f"timed x{args.rate:g}"))
        gate = ConfigGate(reader, args.bag, args.force)
        bar = Progress(sum(reader.topics[t].count for t in plan.topics), unit="messages")
        result = R.replay_bag(reader, plan, executor_kind=args.executor, fast=args.fast,
                              rate=args.rate, discovery_timeout_s=args.discovery_timeout,
                              answer_timeout_s=args.answer_timeout, gate=gate,
                              progress=bar.update)
        bar.close()
        if result is None:
            return EXIT_REFUSED
        sent = sum(result.published.values())
        print(f"published {sent} messages at {result.samples} log times in {result.wall_s:.2f} s"
              f" ({result.samples / max(result.wall_s, 1e-9):.0f} log times/s)")
        if result.rate_warning():                     # said, never a failure by itself
            print(f"warning: {result.rate_warning()}")
        for trigger, answer in result.waited_for.items():
            print(f"  {trigger} -> {answer}")
        for trigger in result.unanswered:
            print(f"  {trigger}: no node publishes {plan.answers[trigger].topic}; not awaited")
        for topic, n in result.foreign.items():
            print(f"  {topic}: {n} answer(s) to stamps this replay had not sent (another "
                  "publisher's), ignored")
        checks = compare_answers(reader, plan, result)
    for c in checks:
        print(f"{c.topic}: {c.answers} answers, {c.compared} compared with {c.recorded_topic}: "
              f"max |difference| {c.max_abs_diff:.3g} (largest recorded value "
              f"{c.max_abs_value:.3g}); {c.unmatched} without a recorded message, "
              f"{c.unanswered} triggers unanswered")
    if args.check is None:
        return 0
    if not checks:
        print("check: FAIL -- no answers to compare (no node answered the replayed topics)")
        return 1
    failed = [c.topic for c in checks if not c.passed(args.check)]
    print(f"check (tolerance {args.check:g}): " + (f"FAIL on {', '.join(failed)}" if failed
                                                     else "every answer equals the recording")
          + gate.forced_note())
    return 1 if failed else 0


class ConfigGate:
    """Replay's gate (rotor_avc.nodes.replay.Replayer.run): every answering node's
    configuration against the bag's, said line by line; False (refused) when one differs,
    unless ``force``."""

    def __init__(self, reader, path: Path, force: bool):
        self.bag = BagAnswers(reader.config, path) if CONFIG_RECORD in reader.metadata else None
        self.force = force
        self.differing: list[NodeCheck] = []

    def __call__(self, nodes) -> bool:
        if self.bag is None:
            return True
        checks = [self.bag.check(n.name, n.answer_topic, n.text, n.unread) for n in nodes]
        for c in checks:
            if not c.differences:
                print(f"configuration: {c.node} (answering {c.answer_topic}) runs the bag's")
                continue
            head = "warning (--force)" if self.force else "refused"
            print(f"{head}: {c.node} answers {c.answer_topic} with another configuration than "
                  "the bag's" + ("; replayed anyway:" if self.force else
                                 ", so its answers would differ from the recorded ones; "
                                 "nothing was published:"))
            for d in c.differences:
                print(f"  {d.line()}" + ("" if self.force else
                                         f" -- fix: {c.command}, or --force"))
        self.differing = [c for c in checks if c.differences]
        return self.force or not self.differing

    def forced_note(self) -> str:
        """The verdict's note of a forced replay: which node differed in which fields."""
        if not self.differing:
            return ""
        return (" (replayed with --force: the configuration differed from the bag's in "
                + "; ".join(f"{c.node}: " + ", ".join(d.field for d in c.differences)
                            for c in self.differing) + ")")
