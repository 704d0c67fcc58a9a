"""Replaying a bag into the ROS graph (the ROS part of ``rotor-avc replay``, rotor_avc.cli.replay).

The recorded messages are published *raw* (their CDR bytes, never decoded and re-encoded), in
log-time order, on their topics -- all of them or a selection, each optionally renamed -- in one of
two modes:

* **timed** (default): with the recorded timing scaled by ``rate``: the message logged at
  ``t`` goes out at wall time ``t0 + (t - t_first) / rate``, ``t0`` when the first one goes out
  (an absolute schedule: no drift; a message already due goes out at once; a reader thread
  keeps up to :data:`READ_AHEAD` messages read, so that reading a bag chunk, tens of ms, does
  not hold up the messages due meanwhile). A rate the replay or the graph cannot hold is
  measured and said, never hidden: the achieved rate (recorded time over wall time) and the log
  times published more than :data:`LATE_S` after their due time are counted in the result
  (:meth:`ReplayResult.rate_warning`). Answers are taken while publishing, and the replay never
  runs more than :data:`TIMED_WINDOW` unanswered triggers ahead of the graph (it waits for the
  answers, which the achieved rate then shows), so no queue overflows and every answer arrives:
  a comparison of the answers does not fail because of the rate;
* **lockstep** (``fast``): sample by sample, as fast as the graph answers: publish every message
  of one log time, wait until the answers they trigger have arrived, then the next log time.

The wait-for rule (lockstep): a replayed *trigger* topic is answered by an *answer* topic whose
message carries the trigger's sim time (header stamp, or ``time_s`` of a labelled array;
rotor_avc.nodes.messages.raw_time_reader). The default rules (:data:`DEFAULT_RULES`) are the
package's lockstep protocol (rotor_avc.nodes.lockstep):

* ``<ns>/foot/<id>/acceleration|velocity|displacement`` -> ``<ns>/foot/<id>/actuator_force``
  (the foot controller; one answer per foot and stamp, also when a foot has two signals);
* ``<ns>/plant/observables`` -> ``<ns>/balancer/command`` (the balancer, which also takes
  ``rotor/joint_state`` of the same sample).

An answer is awaited only when (1) its trigger is replayed, (2) the answer topic is not itself
replayed, and (3) some node publishes the answer topic when replay starts: a foot without a live
controller is not waited for (it is listed as unanswered). As the plant does, replay publishes an
unanswered trigger again after :data:`RESEND_AFTER_S` (the package's nodes answer a repeated
stamp from their cache without stepping twice); an answer missing after ``answer_timeout_s``
stops replay with a :class:`ReplayError` naming the topic and the stamp. Other rules can replace
the defaults (:class:`AnswerRule.exact`).

Start: replay first waits (at most ``discovery_timeout_s``) until every replayed topic has a
subscriber and every subscription the graph lists is matched to its publisher, then subscribes to
the live answer topics, waits until they are matched too, and lets :data:`SETTLE_S` pass, so
the first messages are not lost (topics are volatile). Before the first message a caller's gate
may read the answering nodes' configuration and stop the replay (``rotor-avc replay`` refuses a
node that does not run the bag's: rotor_avc.nodes.replay_config). The answers are taken by a
volatile subscription (answers published before this replay, e.g. to an earlier one, are not
taken for its own). In both modes the answers are collected;
:func:`rotor_avc.nodes.replay_check.compare_answers` checks them against the bag's recorded answers (the regression check of a
controller: same filter, same inputs -> the same forces).
"""
from __future__ import annotations

import importlib
import itertools
import re
import time
from dataclasses import dataclass, field

import numpy as np
import rclpy
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from ..bag.reader import BagReader
from ..block_kinds import KINDS
from . import messages as m
from . import taps
from .replay_config import read_answer_configs
from .replay_timing import LATE_S, Schedule, read_ahead
from .replay_topics import ReplayError, select_topics
from .runtime import make_executor, spin_until

#: after our side matched: time for the other sides to match us too (DDS matches each side on
#: its own; a message sent before the subscriber's side matched is not delivered to it)
SETTLE_S = 0.2
#: log times between two progress reports
PROGRESS_EVERY = 500
#: the answering topics are taken once their set has not changed for this long (discovery)
LIVE_STABLE_S = 1.0
#: lockstep: an unanswered trigger is published again after this wall time
RESEND_AFTER_S = 0.25
#: timed: at most this many triggers of one answer topic are unanswered at a time (well inside
#: the LOCKSTEP_DEPTH queues of the answering node and of this replay's answer subscription)
TIMED_WINDOW = 1000
#: timed: messages a reader thread keeps read ahead of the schedule (more than one bag chunk)
READ_AHEAD = 4096


@dataclass(frozen=True)
class AnswerRule:
    """``pattern`` (a regular expression over a whole published topic name, with named groups)
    -> the answer topic ``answer`` (a format string over those groups)."""

    pattern: str
    answer: str

    def match(self, topic: str) -> str | None:
        found = re.fullmatch(self.pattern, topic)
        return self.answer.format(**found.groupdict()) if found else None

    @classmethod
    def exact(cls, trigger: str, answer: str) -> "AnswerRule":
        """``trigger`` is answered on ``answer`` (both full topic names)."""
        return cls(re.escape(trigger), answer.replace("{", "{{").replace("}", "}}"))


#: the answers of the replayable block kinds (a foot signal -> that actuator's force, the
#: observables -> the balancer's command)
DEFAULT_RULES = tuple(AnswerRule(pattern, answer) for kind in KINDS if kind.replayable
                      for pattern, answer in kind.replay_rules())


@dataclass(frozen=True)
class Answer:
    topic: str          # where the answer is published (graph name)
    recorded: str       # the bag's topic holding the recorded answers (for the comparison)


@dataclass
class ReplayPlan:
    """What a replay publishes: bag topic -> published name and message class; which answer
    each published trigger may get."""

    topics: dict[str, str]
    classes: dict[str, type]
    answers: dict[str, Answer]


def plan_replay(reader: BagReader, topics=None, remap=None, rules=DEFAULT_RULES) -> ReplayPlan:
    """Check the selection against the bag (rotor_avc.nodes.replay_topics.select_topics) and
    the installed message types (ReplayError or BagError naming the topic and the fix)."""
    path = str(reader.path)
    published = select_topics(reader, topics, remap)
    classes = {t: _import_class(reader.topics[t].msg_type, f"{path}: topic {t}")
               for t in published}
    answers = {}
    for bag_topic, topic in published.items():
        for rule in rules:
            answer = rule.match(topic)
            if answer is not None:
                if answer not in published.values():
                    answers[topic] = Answer(answer, rule.match(bag_topic) or answer)
                break
    return ReplayPlan(published, classes, answers)


def _import_class(msg_type: str, what: str) -> type:
    """The rclpy message class of ``pkg/msg/Type`` (ReplayError when it is not installed)."""
    pkg, _, name = msg_type.rpartition("/msg/")
    try:
        return getattr(importlib.import_module(f"{pkg}.msg"), name)
    except (ImportError, AttributeError, ValueError):
        raise ReplayError(f"{what}: message type {msg_type} is not installed here -- fix: "
                          "source the ROS environment that provides it, or leave the topic out "
                          "with --topics") from None


@dataclass
class ReplayResult:
    """What a replay did and received."""

    mode: str
    published: dict[str, int]                   # published topic -> messages sent
    samples: int                                # log times replayed
    wall_s: float
    waited_for: dict[str, str]                  # trigger -> answer topic (live answers)
    unanswered: list[str]                       # triggers whose answer topic no node publishes
    resends: int = 0                            # lockstep: triggers published again
    answers: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)
    missing: dict[str, int] = field(default_factory=dict)         # answer -> stamps unanswered
    rate: float | None = None                   # timed: the requested rate
    achieved_rate: float | None = None          # timed: recorded time / wall time taken
    late: int = 0                               # timed: log times published > LATE_S late
    max_lag_s: float = 0.0                      # timed: the most a log time went out late
    foreign: dict[str, int] = field(default_factory=dict)  # answer -> answers to stamps this
    #                                           replay had not sent (another publisher's), ignored

    def rate_warning(self) -> str | None:
        """Timed replay that did not hold its rate: the achieved rate and the late log times."""
        if self.rate is None or not self.late:
            return None
        achieved = ("" if self.achieved_rate is None else
                    f"achieved {self.achieved_rate:.2g}x of the requested {self.rate:g}x; ")
        return (f"could not hold --rate {self.rate:g}: {achieved}{self.late} of {self.samples} "
                f"log times published more than {LATE_S:g} s late (up to {self.max_lag_s:.3g} s "
                "behind the schedule)")


class Replayer(Node):
    """Publishes a bag's messages (see the module docstring); spun by the caller's executor."""

    def __init__(self, reader: BagReader, plan: ReplayPlan, name: str = "rotor_avc_replay",
                 **kwargs):
        super().__init__(name, **kwargs)
        self.reader, self.plan = reader, plan
        self.pubs = {t: taps.publisher(self, plan.classes[t], out, m.LOCKSTEP_QOS)
                     for t, out in plan.topics.items()}
        self.stamp_of = {t: m.raw_time_reader(reader.topics[t].msg_type) for t in plan.topics}
        self.live: dict[str, Answer] = {}
        self.answers: dict[str, list[tuple[int, bytes]]] = {}
        self.awaiting: dict[str, set[int]] = {}
        self.sent: dict[str, set[int]] = {}         # answer topic -> stamps published for it
        self.foreign: dict[str, int] = {}
        self.connected = False

    # -- start ----------------------------------------------------------------------------------
    def connect(self, executor, discovery_timeout_s: float) -> None:
        """Wait for subscribers of the replayed topics, then subscribe to the live answers."""
        t_end = time.monotonic() + discovery_timeout_s
        spin_until(executor, self._subscribed, t_end)
        # a node's publishers may be discovered after its subscriptions: take the answering
        # topics once the set has been stable for LIVE_STABLE_S (bounded by the timeout)
        live, since = None, time.monotonic()
        t_live_end = max(t_end, since + 2 * LIVE_STABLE_S)
        while time.monotonic() < t_live_end:
            graph = dict(self.get_topic_names_and_types())
            now_live = {trigger: a for trigger, a in self.plan.answers.items()
                        if self.count_publishers(a.topic) > 0 and a.topic in graph}
            if live is None or now_live.keys() != live.keys():
                live, since = now_live, time.monotonic()
            elif time.monotonic() - since >= LIVE_STABLE_S:
                break
            executor.spin_once(timeout_sec=0.05)
        graph = dict(self.get_topic_names_and_types())
        self.live = {trigger: a for trigger, a in (live or {}).items() if a.topic in graph}
        subs = {}
        for topic in {a.topic for a in self.live.values()}:
            msg_type = graph[topic][0]
            cls = _import_class(msg_type, f"answer topic {topic}")
            self.answers[topic] = []
            self.awaiting[topic] = set()
            self.sent[topic] = set()
            self.foreign[topic] = 0
            subs[topic] = self.create_subscription(
                cls, topic, self._on_answer(topic, m.raw_time_reader(msg_type)),
                m.RELIABLE_QOS, raw=True)
        spin_until(executor, lambda: all(s.get_publisher_count() >= self.count_publishers(t)
                                         for t, s in subs.items()),
                   time.monotonic() + max(discovery_timeout_s, 1.0))
        spin_until(executor, lambda: False, time.monotonic() + SETTLE_S)
        self.connected = True

    def _subscribed(self) -> bool:
        """Every replayed topic has a subscriber, and every subscription the graph lists is
        matched to our publisher."""
        for pub in self.pubs.values():
            n = pub.get_subscription_count()
            if n < 1 or n < len(self.get_subscriptions_info_by_topic(pub.topic_name)):
                return False
        return True

    def _on_answer(self, topic: str, time_of):
        answers, awaiting, sent = self.answers[topic], self.awaiting[topic], self.sent[topic]

        def on_raw(data: bytes) -> None:
            stamp = time_of(data)
            if stamp not in sent:            # not an answer to us (e.g. a late one to an
                self.foreign[topic] += 1     # earlier replay of the same bag): counted, ignored
                return
            answers.append((stamp, data))
            awaiting.discard(stamp)

        return on_raw

    # -- publishing -----------------------------------------------------------------------------
    def _publish(self, msg) -> None:
        """Publish one recorded message; note the answer it awaits (for its own stamp)."""
        self.pubs[msg.topic].publish(msg.data)
        self.published[msg.topic] += 1
        answer = self.live.get(self.plan.topics[msg.topic])
        if answer is not None:
            stamp = self._stamp(msg)
            self.awaiting[answer.topic].add(stamp)
            self.sent[answer.topic].add(stamp)

    def _resend(self, group) -> None:
        """Publish again the messages of ``group`` whose answer has not arrived."""
        for msg in group:
            answer = self.live.get(self.plan.topics[msg.topic])
            if answer is not None and self._stamp(msg) in self.awaiting[answer.topic]:
                self.pubs[msg.topic].publish(msg.data)
                self.resends += 1

    def _stamp(self, msg) -> int:
        stamp = self.stamp_of[msg.topic](msg.data)
        return msg.time_ns if stamp is None else stamp

    def run(self, executor, *, fast: bool = False, rate: float = 1.0,
            discovery_timeout_s: float = 3.0, answer_timeout_s: float = 5.0,
            gate=None, progress=None) -> ReplayResult | None:
        """Replay the whole plan (after :meth:`connect`, called here unless the caller did);
        ``executor`` spins this node (and may spin others). ``gate``: called once connected,
        before anything is published, with the answer configuration of every node answering a
        replayed topic (rotor_avc.nodes.replay_config, read within ``answer_timeout_s``); when
        it returns False nothing is published and the result is None. ``progress``: called with
        the number of messages published so far, every :data:`PROGRESS_EVERY` log times."""
        if not fast and not (rate > 0 and np.isfinite(rate)):
            raise ReplayError(f"rate {rate} must be a positive number -- fix: e.g. --rate 0.5")
        if not self.connected:
            self.connect(executor, discovery_timeout_s)
        if gate is not None and not gate(read_answer_configs(
                self, executor, {a.topic for a in self.live.values()}, answer_timeout_s)):
            return None
        self.published = dict.fromkeys(self.plan.topics, 0)
        self.resends = 0
        t_start = time.monotonic()
        schedule = None if fast else Schedule(rate)
        messages = self.reader.raw_messages(list(self.plan.topics))
        if not fast:
            messages = read_ahead(messages, READ_AHEAD)
        try:
            samples = self._publish_all(executor, messages, schedule, answer_timeout_s, progress)
        finally:
            messages.close()              # a reader thread ends before the bag may be closed
        if not fast:
            spin_until(executor, lambda: not any(self.awaiting.values()),
                       time.monotonic() + answer_timeout_s)
        wall = time.monotonic() - t_start
        for pub in self.pubs.values():     # delivered before the node may go away
            pub.wait_for_all_acked(Duration(seconds=answer_timeout_s))
        return ReplayResult(
            "lockstep" if fast else f"timed x{rate:g}",
            {self.plan.topics[t]: n for t, n in self.published.items()}, samples, wall,
            {trigger: a.topic for trigger, a in self.live.items()},
            [t for t in self.plan.answers if t not in self.live], self.resends, self.answers,
            {t: len(s) for t, s in self.awaiting.items() if s},
            *(() if fast else (rate, schedule.achieved_rate(), schedule.late, schedule.max_lag_s)),
            foreign={t: n for t, n in self.foreign.items() if n})

    def _publish_all(self, executor, messages, schedule: "Schedule | None",
                     answer_timeout_s: float, progress=None) -> int:
        """Publish every log time's messages, timed by ``schedule`` or (None) in lockstep; the
        number of log times."""
        samples = 0
        for time_ns, group in itertools.groupby(messages, key=lambda msg: msg.time_ns):
            samples += 1
            group = list(group)
            if schedule is not None:
                due = schedule.due(time_ns)
                while (left := due - time.monotonic()) > 0:
                    if self.live:                 # answers arrive while waiting
                        executor.spin_once(timeout_sec=left)
                    else:
                        time.sleep(left)
                self._hold_window(executor, answer_timeout_s, time_ns)
            for msg in group:
                self._publish(msg)
            if schedule is None:
                self._wait_answers(executor, group, answer_timeout_s, time_ns)
            else:
                schedule.published(time_ns, due)
                if self.live:
                    executor.spin_once(timeout_sec=0)    # take the answers that came meanwhile
            if progress is not None and not samples % PROGRESS_EVERY:
                progress(sum(self.published.values()))
        return samples

    def _hold_window(self, executor, timeout_s: float, time_ns: int) -> None:
        """Timed: wait (spinning) while an answer topic has TIMED_WINDOW unanswered triggers;
        ReplayError when none of them is answered within ``timeout_s``."""
        def full():
            return any(len(s) >= TIMED_WINDOW for s in self.awaiting.values())
        while full():
            n_before = sum(map(len, self.awaiting.values()))
            progress = lambda: sum(map(len, self.awaiting.values())) < n_before  # noqa: E731
            if not spin_until(executor, progress, time.monotonic() + timeout_s):
                topics = ", ".join(t for t, s in self.awaiting.items() if len(s) >= TIMED_WINDOW)
                raise ReplayError(
                    f"no answer within {timeout_s:g} s on {topics} with {TIMED_WINDOW} triggers "
                    f"unanswered (before the messages logged at {time_ns} ns) -- fix: check that "
                    "the node answering it runs, or leave its trigger out with --topics")

    def _wait_answers(self, executor, group, timeout_s: float, time_ns: int) -> None:
        """Lockstep: spin until the group's answers are in; publish the unanswered triggers
        again every RESEND_AFTER_S (a message lost while a subscriber was still connecting;
        the package's nodes answer a repeated stamp from their cache, as for the plant's
        resends); ReplayError after ``timeout_s``."""
        t_end = time.monotonic() + timeout_s
        done = lambda: not any(self.awaiting.values())     # noqa: E731
        while not spin_until(executor, done, min(t_end, time.monotonic() + RESEND_AFTER_S)):
            if time.monotonic() >= t_end:
                late = {t: sorted(s) for t, s in self.awaiting.items() if s}
                raise ReplayError(
                    "no answer within {:g} s on {} (messages logged at {} ns) -- fix: check "
                    "that the node answering it runs and uses the bag's configuration, or leave "
                    "its trigger out with --topics".format(
                        timeout_s, ", ".join(f"{t} for stamp {s[0]} ns" for t, s in late.items()),
                        time_ns))
            self._resend(group)


def replay_bag(reader: BagReader, plan: ReplayPlan, *, executor_kind: str = "events",
               **options) -> ReplayResult | None:
    """Run a replay in its own rclpy context (usable in a process that already runs rclpy);
    ``options`` as :meth:`Replayer.run`."""
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    executor = make_executor(executor_kind, context)
    try:
        node = Replayer(reader, plan, context=context)
        executor.add_node(node)
        return node.run(executor, **options)
    finally:
        executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown(context=context)
