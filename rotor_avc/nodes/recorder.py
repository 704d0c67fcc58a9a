"""``recorder``: records the graph's traffic, raw, to one MCAP bag (rosbag2 profile).

Run: ``ros2 run rotor_avc recorder --ros-args -p scenario:=scenario_case3_steady -p
path:=bags/case3.mcap`` and start the plant with ``-p wait_for_recorder:=recorder`` (the
recorder's node name), so that sample 0 is published only once the recorder is subscribed to
every topic of the run.

What it records: every topic of the machine's namespace, ``/clock`` and ``/diagnostics`` whose
type the bag format knows (rotor_avc.bag.msgdefs; other topics are skipped with one warning
each), as they appear (the topic list is polled every 50 ms). Messages are taken *raw*
(serialised CDR, never decoded and re-encoded) and appended with
:meth:`rotor_avc.bag.writer.BagWriter.write_raw`. Log time = the message's sim time, read from
the bytes (rotor_avc.nodes.messages.raw_time_reader): the header stamp of stamped messages, the
clock of ``/clock``, the ``time_s`` element of the labelled arrays (the latest sim time seen for
a message without one). Each channel's ``offered_qos_profiles`` are the publishers' QoS as the
graph reports them (DDS does not report history and depth: ``unknown``/0, as rosbag2 records
them). The scenario's whole configuration (machine, controllers, discretisation, balancer, speed
profile, unbalance, package version) goes into the bag's metadata, so the bag is
self-describing.

Nothing is lost: the subscriptions are reliable with KEEP_ALL history, so a burst the recorder
has not taken yet waits in its queue instead of being overwritten; with the plant waiting for the
recorder (above) every published message is in the bag (tested per topic under a 5 kHz lockstep
run, in one executor and as a separate process). The recorder must keep up on average: it takes
about 25,000 messages/s here; a lockstep run of three feet publishes nine messages per sample
(20,000 samples at ~2,800 samples/s recorded by a recorder process without a loss). A recorder
that falls far behind lets DDS drop messages its reader has not acknowledged (the publishers keep
the last 200 per topic).

Ending: SIGINT/SIGTERM finish the file (last chunk, summary, indexes, rosbag2 metadata) and exit
with status 0. After a SIGKILL (or a power cut) the file has no summary and at most the chunk
being filled is lost (``chunk_size_bytes`` of messages; every full chunk is flushed at once):
``rotor_avc.bag.recover_bag(path)`` (or ``mcap recover``) writes ``<name>.recovered.mcap`` with
everything before it. Per-topic counts of recorded messages are published on ``/diagnostics``
(one KeyValue per topic) and kept in :attr:`Recorder.counts`.
"""
from __future__ import annotations

import importlib

from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..bag.errors import BagError
from ..bag.metadata import qos_profiles
from ..bag.msgdefs import DEFINITIONS
from ..bag.writer import BagWriter
from ..errors import RotorAvcError
from . import messages as m
from .runtime import COMMON_PARAMS, Param, declare_parameters, node_scenario, run_node

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config of the run (stored in the bag's metadata)"),
    Param("path", "", "the .mcap file to write (must not exist)"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine"),
    Param("compression", "zstd", "chunk compression", choices=("zstd", "lz4", "none")),
    Param("chunk_size_bytes", 1 << 20, "uncompressed chunk size; a SIGKILL loses at most one",
          minimum=4096, maximum=1 << 28),
)
#: reliable and KEEP_ALL: messages not taken yet queue up instead of being overwritten
RECORD_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL,
                        reliability=ReliabilityPolicy.RELIABLE)
DISCOVERY_PERIOD_S = 0.05


class Recorder(Node):
    """The recorder node (see the module docstring)."""

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
        self.counts: dict[str, int] = {}
        self.last_time_ns = 0
        self._subs = {}
        self._skipped: set[str] = set()
        self.exit_requested = False
        self.pub_diag = self.create_publisher(type(m.diagnostics(0, [])), "/diagnostics", 10)
        self.create_timer(DISCOVERY_PERIOD_S, self._discover)
        self.create_timer(1.0, self._publish_diagnostics)
        self._discover()

    # -- topics ---------------------------------------------------------------------------------
    def _discover(self) -> None:
        for name, types in self.get_topic_names_and_types():
            if name in self._subs or name in self._skipped:
                continue
            if not (name.startswith(self.prefix) or name in ("/clock", "/diagnostics")):
                continue
            msg_type = next((t for t in types if t in DEFINITIONS), None)
            if msg_type is None:
                self._skipped.add(name)
                self.get_logger().warning(f"not recording {name}: type {', '.join(types)} is "
                                          "not one the bag format knows (rotor_avc.bag.msgdefs)")
                continue
            pkg, _, cls_name = msg_type.split("/")
            cls = getattr(importlib.import_module(f"{pkg}.msg"), cls_name)
            self.writer.add_topic(name, msg_type, self._offered_qos(name))
            self.counts[name] = 0
            self._subs[name] = self.create_subscription(cls, name, self._callback(name, msg_type),
                                                        RECORD_QOS, raw=True)

    def _offered_qos(self, name: str) -> list[dict] | None:
        """The QoS of the topic's publishers in the bag's form (None: the default profile)."""
        profiles = []
        for info in self.get_publishers_info_by_topic(name):
            q = info.qos_profile
            profiles.append({
                "history": q.history.name.lower(), "depth": q.depth,
                "reliability": q.reliability.name.lower(), "durability": q.durability.name.lower(),
                "deadline": _duration(q.deadline), "lifespan": _duration(q.lifespan),
                "liveliness": q.liveliness.name.lower(),
                "liveliness_lease_duration": _duration(q.liveliness_lease_duration),
                "avoid_ros_namespace_conventions": q.avoid_ros_namespace_conventions})
        try:
            return qos_profiles(profiles) if profiles else None
        except BagError as exc:
            self.get_logger().warning(f"{name}: offered QoS not recordable ({exc}); "
                                      "recording the default profile")
            return None

    def _callback(self, name: str, msg_type: str):
        """The raw subscription callback of one topic (kept small: it runs per message)."""
        time_of = m.raw_time_reader(msg_type)
        write = self.writer.write_raw
        counts = self.counts

        def on_raw(data: bytes) -> None:
            time_ns = time_of(data)
            if time_ns is None:
                time_ns = self.last_time_ns
            elif time_ns > self.last_time_ns:
                self.last_time_ns = time_ns
            write(name, data, time_ns)
            counts[name] += 1

        return on_raw

    # -- status, end ----------------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        values = dict(sorted(self.counts.items()))
        self.pub_diag.publish(m.diagnostics(self.last_time_ns, [
            (f"{self.get_name()}: recording", "ok", self.p["path"], values)]))

    def close(self) -> None:
        """Finish the bag (also on SIGINT/SIGTERM, via run_node)."""
        self.writer.close()


def _duration(d) -> dict:
    sec, nsec = divmod(d.nanoseconds, 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def main(args=None) -> int:
    return run_node(Recorder, args)


if __name__ == "__main__":
    raise SystemExit(main())
