"""``recorder``: records the graph's traffic, raw, to one MCAP bag (rosbag2 profile).

Run: ``ros2 run rotor_avc recorder --ros-args -p scenario:=scenario_case3_steady -p
path:=bags/case3.mcap``.

It subscribes *raw* (serialised CDR, never decoded and re-encoded) to every topic of the
machine's namespace, ``/clock`` and ``/diagnostics`` whose type the bag format knows, as they
appear (the topic list is polled), and writes each message with
:meth:`rotor_avc.bag.writer.BagWriter.write_raw`. Log time = the message's sim time: the header
stamp of stamped messages, the ``time_s`` element of the labelled arrays. The scenario's whole
configuration goes into the bag's metadata, so the bag is self-describing.

SIGINT/SIGTERM finish the file (summary, indexes, rosbag2 metadata). After a SIGKILL at most the
last chunk is lost: ``rotor_avc.bag.recover_bag(path)`` (or ``mcap recover``) rebuilds the file.
Per-topic counts of recorded messages are reported on ``/diagnostics`` and kept in
:attr:`Recorder.counts`.
"""
from __future__ import annotations

import struct

import importlib

from rclpy.node import Node
from rclpy.serialization import deserialize_message

from ..bag.msgdefs import DEFINITIONS
from ..bag.writer import BagWriter
from ..errors import RotorAvcError
from ..sim.scenario import load_scenario
from . import messages as m
from .runtime import COMMON_PARAMS, Param, declare_parameters, run_node

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config of the run (stored in the bag's metadata)"),
    Param("path", "", "the .mcap file to write"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine"),
    Param("compression", "zstd", "chunk compression", choices=("zstd", "lz4", "none")),
    Param("chunk_size_bytes", 1 << 20, "uncompressed chunk size; a SIGKILL loses at most one",
          minimum=4096, maximum=1 << 28),
)
_STAMP = struct.Struct("<iI")


class Recorder(Node):
    """The recorder node (see the module docstring)."""

    def __init__(self, name: str = "recorder", **kwargs):
        super().__init__(name, **kwargs)
        self.p = declare_parameters(self, PARAMS)
        self.executor_kind = self.p["executor"]
        if not self.p["path"]:
            raise RotorAvcError(f"{self.get_name()}: parameter 'path' is empty -- fix: "
                                "-p path:=bags/run.mcap")
        if not self.p["scenario"]:
            raise RotorAvcError(f"{self.get_name()}: parameter 'scenario' is empty -- fix: give "
                                "the run's scenario config, so the bag describes itself")
        config = load_scenario(self.p["scenario"]).run_config()
        compression = "" if self.p["compression"] == "none" else self.p["compression"]
        self.writer = BagWriter(self.p["path"], config, compression=compression,
                                chunk_size=self.p["chunk_size_bytes"])
        self.prefix = m.topic("", self.p["namespace"]).rstrip("/") + "/"
        self.counts: dict[str, int] = {}
        self.last_time_ns = 0
        self._subs = {}
        self.pub_diag = self.create_publisher(type(m.diagnostics(0, [])), "/diagnostics", 10)
        self.create_timer(0.05, self._discover)
        self.create_timer(1.0, self._publish_diagnostics)
        self._discover()

    def _wanted(self, name: str, types) -> str | None:
        if not (name.startswith(self.prefix) or name in ("/clock", "/diagnostics")):
            return None
        for t in types:
            if t in DEFINITIONS:
                return t
        return None

    def _discover(self) -> None:
        for name, types in self.get_topic_names_and_types():
            if name in self._subs:
                continue
            msg_type = self._wanted(name, types)
            if msg_type is None:
                continue
            pkg, _, cls_name = msg_type.split("/")
            cls = getattr(importlib.import_module(f"{pkg}.msg"), cls_name)
            self.writer.add_topic(name, msg_type)
            self.counts[name] = 0
            self._subs[name] = self.create_subscription(
                cls, name, lambda data, n=name, c=cls, t=msg_type: self._on_raw(n, c, t, data),
                m.LOCKSTEP_QOS, raw=True)

    def _on_raw(self, name: str, cls, msg_type: str, data: bytes) -> None:
        if msg_type == "std_msgs/msg/Float64MultiArray":
            msg = deserialize_message(data, cls)
            time_ns = m.time_to_ns(msg.data[0]) if m.labels(msg)[:1] == ["time_s"] else self.last_time_ns
        else:                          # header stamp (or Clock.clock) right after the CDR header
            sec, nanosec = _STAMP.unpack_from(data, 4)
            time_ns = sec * 1_000_000_000 + nanosec
        self.last_time_ns = max(self.last_time_ns, time_ns)
        self.writer.write_raw(name, data, time_ns)
        self.counts[name] += 1

    def _publish_diagnostics(self) -> None:
        values = {k: v for k, v in sorted(self.counts.items())}
        self.pub_diag.publish(m.diagnostics(self.last_time_ns, [
            (f"{self.get_name()}: recording", "ok", self.p["path"], values)]))

    def close(self) -> None:
        """Finish the bag (also on SIGINT/SIGTERM, via run_node)."""
        self.writer.close()


def main(args=None) -> int:
    return run_node(Recorder, args)


if __name__ == "__main__":
    raise SystemExit(main())
