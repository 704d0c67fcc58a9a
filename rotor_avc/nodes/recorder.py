"""``recorder``: records the graph's traffic, raw, to one MCAP bag (rosbag2 profile).

Run: ``ros2 run rotor_avc recorder --ros-args -p scenario:=scenario_case3_steady -p
path:=bags/case3.mcap`` and start the plant with ``-p wait_for_recorder:=recorder`` (the
recorder's node name).

What it records: every topic of the machine's namespace, ``/clock`` and ``/diagnostics`` whose
type the bag format knows (rotor_avc.bag.msgdefs; other topics are skipped with one warning
each), as they appear (the topic list is polled every 50 ms). Messages are taken *raw*
(serialised CDR, never decoded and re-encoded): a subscription's callback only appends the bytes
to its topic's queue, and every ``flush_period_s`` the queues go to the bag
(:meth:`rotor_avc.bag.writer.BagWriter.write_raw`) at the message's sim time, read from the
bytes (rotor_avc.nodes.messages.raw_time_reader; the latest sim time seen for a message without
one). Each channel's ``offered_qos_profiles`` are the publishers' QoS as the graph reports them.
The scenario's whole configuration goes into the bag's metadata, so the bag is self-describing.

Two sources (parameter ``source``):

* ``dds`` (default): reliable KEEP_ALL subscriptions, made once a topic has a publisher, with
  transient-local durability where every publisher of the topic offers it (the lockstep topics
  do; ``/diagnostics`` is always volatile), the recorder in its own process or any;
* ``process``: the recorder is composed into one process with the nodes it records
  (rotor_avc.nodes.graph, ``composed``) and takes their messages from the in-process taps
  (rotor_avc.nodes.taps) as they are published -- lossless and about ten times cheaper than a
  DDS delivery per message. Messages of nodes in other processes are not recorded in this mode
  (a warning names such topics).

**Nothing is lost silently.** After every flush that took messages (and every
0.1 s) the recorder publishes on ``<ns>/recorder/progress`` how many messages it has taken per
topic (a labelled array: ``time_s``
then one count per topic, labelled with the topic names). A lockstep plant started with
``wait_for_recorder`` never runs more than its ``recorder_window`` samples ahead of these counts,
and the lockstep publishers keep a deeper history (rotor_avc.nodes.messages.LOCKSTEP_DEPTH), so
no DDS history on the way can overwrite a message before the recorder has taken it. Where
nothing waits (real time), messages DDS reports as lost to a subscription are counted per topic;
and from the publishers' side every node of the package reports what it published per topic on
``/diagnostics``, which the recorder reads. Lost messages (reported by DDS, or published but not
recorded) are said on ``/diagnostics``, in the log and in the bag: the ``rotor_avc_counts``
record holds per topic the messages published, recorded and lost.

**Lockstep, in the bag.** The plant reports its lockstep account on ``/diagnostics`` (status
``<plant>: lockstep``: the samples at which a fault policy stood in for an answer, answers that
changed, absent responders); the recorder writes the last report of the run into the bag's
``rotor_avc_lockstep`` record (rotor_avc.bag.lockstep), which ``rotor-avc bag check``,
``compare`` and ``replay --check`` read.

**One recorder per namespace.** While it has taken no message of the namespace's topics yet, a
recorder that finds another node publishing ``<ns>/recorder/progress`` (another recorder) does
not record: one error line, exit status 6, no bag left behind
(rotor_avc.nodes.namespace_guard).

Ending: SIGINT/SIGTERM take what is still queued (at most DRAIN_MAX_S), finish the file (last
chunk, counts, summary, indexes, rosbag2 metadata) and exit with status 0, whatever the graph
does meanwhile. After a SIGKILL (or a power cut) the file has
no summary and at most the messages of the last ``flush_period_s`` and the chunk being filled
are lost (``chunk_size_bytes`` of messages; every full chunk is flushed at once):
``rotor_avc.bag.recover_bag(path)`` (or ``mcap recover``) writes ``<name>.recovered.mcap`` with
everything before it.
"""
from __future__ import annotations

import importlib
import time

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from std_msgs.msg import Float64MultiArray

from ..bag.errors import BagError
from ..bag.lockstep import LOCKSTEP_RECORD, LOCKSTEP_SUFFIX, merge_reports
from ..bag.msgdefs import DEFINITIONS
from ..bag.writer import BagWriter
from ..errors import RotorAvcError
from ..output_files import EXIT_OUTPUT, OutputError
from . import messages as m
from . import taps
from .namespace_guard import GraphStillness, NamespaceGuard
from .qos import offered_qos
from .runtime import COMMON_PARAMS, Param, declare_parameters, node_scenario, run_node

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config of the run (stored in the bag's metadata)"),
    Param("path", "", "the .mcap file to write (must not exist)"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine"),
    Param("source", "dds", "dds: subscribe to every topic; process: take the messages of the "
          "nodes composed into this process from their publishers", choices=("dds", "process")),
    Param("compression", "zstd", "chunk compression", choices=("zstd", "lz4", "none")),
    Param("chunk_size_bytes", 1 << 20, "uncompressed chunk size; a SIGKILL loses at most one",
          minimum=4096, maximum=1 << 28),
    Param("flush_period_s", 0.01, "how often the queued messages go to the bag and the progress "
          "is published", minimum=1e-3, maximum=1.0),
)
#: reliable and KEEP_ALL: messages not taken yet queue up instead of being overwritten; the
#: transient-local variant for topics whose every publisher offers it (the lockstep topics), so
#: nothing published before the subscription matched is missed
RECORD_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL,
                        reliability=ReliabilityPolicy.RELIABLE)
RECORD_QOS_LATE_JOINER = QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL,
                                    reliability=ReliabilityPolicy.RELIABLE,
                                    durability=DurabilityPolicy.TRANSIENT_LOCAL)
PROGRESS_EVERY_S = 0.1
DISCOVERY_PERIOD_S = 0.05
#: at the end: take what is queued until nothing came for this long (at most DRAIN_MAX_S)
DRAIN_QUIET_S, DRAIN_MAX_S = 0.1, 3.0


class _Channel:
    """One recorded topic: the queue its source appends to, and its counts."""

    def __init__(self, name: str, msg_type: str):
        self.name, self.msg_type = name, msg_type
        self.queue: list[bytes] = []
        self.time_of = m.raw_time_reader(msg_type)
        self.recorded = 0
        self.lost = 0                 # reported lost by DDS
        self.published_remote = {}    # node -> count, from the nodes' /diagnostics
        self.first_report = {}        # node -> the count in the first report received


class Recorder(Node):
    """The recorder node (see the module docstring)."""

    #: what its ready line says: it subscribes to each topic of the run as discovery shows it
    subscribes_later = "every topic of the namespace as it appears"

    #: no last /diagnostics at the end (it could not be recorded any more); the log says all
    final_diagnostics = False

    def __init__(self, name: str = "recorder", **kwargs):
        super().__init__(name, **kwargs)
        self.p = declare_parameters(self, PARAMS)
        self.executor_kind = self.p["executor"]
        if not self.p["path"]:
            raise RotorAvcError(f"{self.get_name()}: parameter 'path' is empty -- fix: "
                                "-p path:=bags/run.mcap")
        config = node_scenario(self, self.p["scenario"],
                               "the run's scenario config, so the bag describes itself").run_config()
        compression = "" if self.p["compression"] == "none" else self.p["compression"]
        self.writer = BagWriter(self.p["path"], config, compression=compression,
                                chunk_size=self.p["chunk_size_bytes"])
        self.prefix = m.topic("", self.p["namespace"]).rstrip("/") + "/"
        self.progress_topic = m.topic(m.RECORDER_PROGRESS, self.p["namespace"])
        self.channels: dict[str, _Channel] = {}
        self._baseline = taps.process_counts()      # published in this process before the recording
        self.last_time_ns = 0
        self._subs = {}
        self._skipped: set[str] = set()
        self._warned_remote: set[str] = set()
        self._last_progress, self._progress_at = None, 0.0
        self.lockstep_reports: dict[str, dict[str, str]] = {}   # plant -> its last account
        self.exit_requested = False
        self.exit_status = 0
        self.guard = NamespaceGuard(self, "records", self.p["namespace"])
        self.stillness = GraphStillness()    # the namespace's publishers unchanged
        self._settled_once = False
        self.write_error: OutputError | None = None
        self.pub_diag = taps.publisher(self, m.DiagnosticArray, "/diagnostics", m.DIAGNOSTICS_QOS)
        self.pub_progress = taps.publisher(self, Float64MultiArray, self.progress_topic,
                                           m.LOCKSTEP_QOS)
        self._unwatch = None
        self._untap: list = []
        if self.p["source"] == "process":
            self._unwatch = taps.watch_publishers(self._tap_publisher)
        self.create_timer(DISCOVERY_PERIOD_S, self._discover)
        self.create_timer(self.p["flush_period_s"], self.flush)
        self.create_timer(1.0, self._publish_diagnostics)
        self._discover()

    @property
    def counts(self) -> dict[str, int]:
        """Messages taken per topic (written to the bag or queued for it)."""
        return {name: ch.recorded + len(ch.queue) for name, ch in self.channels.items()}

    # -- topics ---------------------------------------------------------------------------------
    def _recordable(self, name: str) -> bool:
        return ((name.startswith(self.prefix) or name in ("/clock", "/diagnostics"))
                and name != self.progress_topic and name not in self._skipped)

    def _channel(self, name: str, types) -> _Channel | None:
        """The channel of topic ``name`` (registered in the bag on first sight), or None when
        its type is not one the bag format knows."""
        ch = self.channels.get(name)
        if ch is not None:
            return ch
        msg_type = next((t for t in types if t in DEFINITIONS), None)
        if msg_type is None:
            self._skipped.add(name)
            self.get_logger().warning(f"not recording {name}: type {', '.join(types)} is "
                                      "not one the bag format knows (rotor_avc.bag.msgdefs)")
            return None
        self.writer.add_topic(name, msg_type, offered_qos(self, name))
        ch = self.channels[name] = _Channel(name, msg_type)
        return ch

    def _namespace_taken(self) -> bool:
        """Start-up (nothing of the namespace taken yet): another recorder publishes this
        namespace's progress -> do not record (True; refused once it is named)."""
        if self.guard.refusal:
            return True
        if any(ch.recorded or ch.queue for n, ch in self.channels.items()
               if n.startswith(self.prefix)):
            return False
        return self.guard.taken([self.progress_topic])

    def _settled(self, topics) -> bool:
        """source dds: the namespace's publishers have stayed the same for DISCOVERY_SETTLE_S
        since its topics were first seen (discovery is slow on a loaded host: another recorder
        is seen before this one subscribes, rotor_avc.nodes.namespace_guard); once settled,
        it stays so."""
        if self._settled_once:
            return True
        seen = tuple(sorted((n, self.count_publishers(n)) for n, _ in topics
                            if n.startswith(self.prefix)))
        if not any(n != self.progress_topic for n, _ in seen):
            return False
        self._settled_once = self.stillness.held(seen, time.monotonic())
        return self._settled_once

    def _discover(self) -> None:
        if self._namespace_taken():
            return
        topics = self.get_topic_names_and_types()
        if self.p["source"] == "dds" and not self._settled(topics):
            return
        for name, types in topics:
            if not self._recordable(name):
                continue
            if self.p["source"] == "process":
                if (name not in self._warned_remote
                        and self.count_publishers(name) > taps.local_publishers(name)):
                    self._warned_remote.add(name)
                    self.get_logger().warning(f"{name} has publishers in other processes: "
                                              "source 'process' does not record their messages")
                continue
            if name in self._subs:
                continue
            infos = self.get_publishers_info_by_topic(name)
            if not infos:                # seen through a subscriber only: wait for a publisher,
                continue                 # whose QoS decides the subscription's
            ch = self._channel(name, types)
            if ch is None:
                continue
            pkg, _, cls_name = ch.msg_type.split("/")
            cls = getattr(importlib.import_module(f"{pkg}.msg"), cls_name)
            events = SubscriptionEventCallbacks(
                message_lost=lambda info, c=ch: self._lost(c, info),
                incompatible_qos=lambda info, n=name: self.get_logger().error(
                    f"{n}: a publisher's QoS is incompatible with the recording subscription "
                    f"({info.last_policy_kind}): its messages are not recorded"))
            late = name != "/diagnostics" and all(
                i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
            self._subs[name] = self.create_subscription(
                cls, name, ch.queue.append, RECORD_QOS_LATE_JOINER if late else RECORD_QOS,
                raw=True, event_callbacks=events)

    def _tap_publisher(self, pub) -> None:
        """source 'process': record a publisher of this process (existing or new)."""
        name = pub.topic_resolved
        if not self._recordable(name) or name in self.channels:
            return
        ch = self._channel(name, [pub.type_name])
        if ch is not None:
            self._untap.append(taps.add_tap(name, ch.queue.append))

    def _lost(self, ch: _Channel, info) -> None:
        ch.lost += info.total_count_change
        self.get_logger().error(f"{ch.name}: DDS lost {info.total_count_change} message(s) "
                                f"before the recorder took them ({ch.lost} in all)")

    # -- the bag --------------------------------------------------------------------------------
    def flush(self) -> None:
        """Write the queued messages to the bag and publish the progress. A bag that cannot be
        written (disk full, ...) ends the run: one error line, exit status EXIT_OUTPUT, the file
        kept as far as it got."""
        if self.write_error is not None:
            return
        try:
            self._flush()
        except OutputError as exc:
            self.write_error = exc
            self.get_logger().error(f"{exc}; the bag keeps what was written before "
                                    "(`rotor-avc bag recover` finishes it)")
            self.exit_requested, self.exit_status = True, EXIT_OUTPUT

    def _flush(self) -> None:
        write = self.writer.write_raw
        for ch in self.channels.values():
            n = len(ch.queue)
            if not n:
                continue
            batch = ch.queue[:n]
            del ch.queue[:n]             # sources only append: nothing taken meanwhile is lost
            time_of, last = ch.time_of, self.last_time_ns
            for data in batch:
                t = time_of(data)
                if t is None:
                    t = last
                elif t > last:
                    last = t
                write(ch.name, data, t)
            self.last_time_ns = last
            ch.recorded += n
            if ch.name == "/diagnostics":
                self._read_published(batch)
        counts = [float(ch.recorded) for ch in self.channels.values()]
        now = time.monotonic()
        if counts != self._last_progress or now - self._progress_at >= PROGRESS_EVERY_S:
            self._last_progress, self._progress_at = counts, now
            labels = ["time_s"] + list(self.channels)
            self.pub_progress.publish(m.Labelled(labels).fill([self.last_time_ns * 1e-9] + counts))

    def _read_published(self, batch: list[bytes]) -> None:
        """The publishers' counts from the nodes' /diagnostics (rotor_avc.nodes.messages
        .published_status)."""
        for data in batch:
            try:
                msg = deserialize_message(data, m.DiagnosticArray)
            except Exception:            # not ours to judge: it is recorded as it came
                continue
            for st in msg.status:
                if st.name.endswith(LOCKSTEP_SUFFIX):
                    self.lockstep_reports[st.name[:-len(LOCKSTEP_SUFFIX)]] = {
                        kv.key: kv.value for kv in st.values}
                if not st.name.endswith(m.PUBLISHED_SUFFIX):
                    continue
                here = any(kv.key == m.PROCESS_KEY and kv.value == m.PROCESS_ID
                           for kv in st.values)
                node = st.name[:-len(m.PUBLISHED_SUFFIX)]
                for kv in st.values:
                    ch = self.channels.get(kv.key)
                    if ch is None or not kv.value.isdigit():
                        continue
                    count = int(kv.value)
                    if ch.name == "/diagnostics":  # from the node's first report received on
                        first = ch.first_report.setdefault(node, count)
                        count = count - first + 1
                    elif here:                     # this process: counted from its publishers
                        continue
                    ch.published_remote[node] = max(count, ch.published_remote.get(node, 0))

    def published(self) -> dict[str, int | None]:
        """Messages published per topic, from the publishers' side: by the counted publishers of
        this process since the recorder was created, plus what the nodes of other processes
        reported on /diagnostics; None when no publisher reported. ``/diagnostics`` itself is
        subscribed volatile (tools outside the package publish it so) and every node's count
        on it -- this process's too -- runs from the first to the latest of its reports the
        recorder took: messages of one publisher arrive in order, so all between were taken,
        and what a node said before the recording began is not the recording's loss."""
        local = {t: n - self._baseline.get(t, 0) for t, n in taps.process_counts().items()}
        local.pop("/diagnostics", None)          # every node's count comes from its reports
        out = {}
        for name, ch in self.channels.items():
            if name in local or ch.published_remote:
                out[name] = local.get(name, 0) + sum(ch.published_remote.values())
            else:
                out[name] = None
        return out

    def losses(self) -> dict[str, int]:
        """Messages lost per topic: reported by DDS, or published but not recorded."""
        published = self.published()
        out = {}
        for name, ch in self.channels.items():
            taken = ch.recorded + len(ch.queue)
            missing = 0 if published[name] is None else max(0, published[name] - taken)
            if max(ch.lost, missing):
                out[name] = max(ch.lost, missing)
        return out

    # -- status, end ----------------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        lost = self.losses()
        values = {f"{name} recorded": n for name, n in sorted(self.counts.items())}
        values.update({f"{name} lost": n for name, n in sorted(lost.items())})
        level, text = (("error", f"lost messages on {', '.join(sorted(lost))}") if lost
                       else ("ok", self.p["path"]))
        self.pub_diag.publish(m.diagnostics(self.last_time_ns, [
            (f"{self.get_name()}: recording", level, text, values), m.published_status(self)]))

    def drain(self, executor) -> None:
        """Take what is still queued for the subscriptions (before the executor stops)."""
        t_end = time.monotonic() + DRAIN_MAX_S
        quiet_since = time.monotonic()
        last = sum(self.counts.values())
        while time.monotonic() < t_end and time.monotonic() - quiet_since < DRAIN_QUIET_S:
            executor.spin_once(timeout_sec=0.02)
            now = sum(self.counts.values())
            if now != last:
                last, quiet_since = now, time.monotonic()

    def close(self) -> None:
        """Finish the bag (also on SIGINT/SIGTERM, via run_node) with its message counts."""
        if self._unwatch is not None:
            self._unwatch()
        for untap in self._untap:
            untap()
        self.flush()
        if self.guard.refusal:                # recorded nothing: leave no bag behind
            self.writer.close()
            self.writer.path.unlink(missing_ok=True)
            return
        published, lost = self.published(), self.losses()
        log = self.get_logger()
        for name, ch in sorted(self.channels.items()):
            pub = "?" if published[name] is None else published[name]
            text = f"{name}: recorded {ch.recorded} of {pub} published"
            if name in lost:
                log.error(f"{text}; LOST {lost[name]}")
            else:
                log.info(text)
        lockstep = self._lockstep_record()
        self.writer.close(published, lost,
                          {LOCKSTEP_RECORD: lockstep} if lockstep is not None else None)

    def _lockstep_record(self) -> dict[str, str] | None:
        """The plants' last lockstep reports as the bag's record, its verdict logged (None when
        no plant reported)."""
        try:
            record = merge_reports(self.lockstep_reports)
        except BagError as exc:
            self.get_logger().error(f"the bag has no lockstep record: {exc}")
            return None
        if record is None:
            return None
        log = self.get_logger()
        (log.info if record.ok else log.error)(f"lockstep: {record.verdict()}")
        return record.encode()


def main(args=None) -> int:
    return run_node(Recorder, args)


if __name__ == "__main__":
    raise SystemExit(main())
