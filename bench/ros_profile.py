"""Where a lockstep sample's time goes in a graph of processes (bench_ros_loop.py uses it).

* **CPU per sample of every process** (:class:`CpuSpan`): user + system time from ``/proc``
  (Linux), the main thread (the node's Python: executor, callbacks, serialisation) apart from the
  other threads (the middleware's receive and event threads), taken at two moments of a run's
  steady state and divided by the samples between them -- start-up (imports, discovery) is not
  in it. On a machine with fewer cores than processes, the sum over the processes bounds the
  rate: ``cores / (CPU per sample)`` samples per second at best.
* **A per-sample timeline** (:class:`Tracer`): a process that takes every message of the named
  topics (best effort: no acknowledgement traffic) and keeps each message's publication sequence
  number and source timestamp (the publisher's clock at ``publish``). Sample ``k`` is the
  ``k``-th message of every topic (each publisher sends one per sample), so the timeline needs no
  stamp in the messages: from the plant's first message of sample ``k`` to its last (the plant
  publishing), from a controller's measurement to its answer (transport, wake-up, take, the
  controller's step, publish), from the last answer to the plant's first message of sample
  ``k + 1`` (transport back, the plant's wake-up, takes, the plant's step). The tracer is one
  more process taking messages, as a recorder is: it is used for the timeline runs only.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

CLOCK_TICK_S = 1.0 / os.sysconf("SC_CLK_TCK")


def _stat_fields(path: Path) -> list[str]:
    """The fields of a ``/proc/.../stat`` file after the command name (field 3 on)."""
    return path.read_text().rsplit(")", 1)[1].split()


def _cpu_s(fields: list[str]) -> float:
    return (int(fields[11]) + int(fields[12])) * CLOCK_TICK_S     # utime + stime


def process_cpu(pid: int) -> tuple[float, float]:
    """``(main thread, other threads)`` CPU seconds of process ``pid`` so far (the other
    threads' share includes threads that have ended)."""
    total = _cpu_s(_stat_fields(Path(f"/proc/{pid}/stat")))
    main = _cpu_s(_stat_fields(Path(f"/proc/{pid}/task/{pid}/stat")))
    return main, total - main


def role(pid: int) -> str:
    """What a child process is: its ROS node name (``__node:=``), else its last argument."""
    args = [a.decode() for a in Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0") if a]
    named = [a.split(":=", 1)[1] for a in args if a.startswith("__node:=")]
    return named[0] if named else args[-1]


def children() -> dict[int, str]:
    """This process's child processes: pid -> :func:`role`."""
    me, found = os.getpid(), {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if int(_stat_fields(entry / "stat")[1]) == me:
                found[int(entry.name)] = role(int(entry.name))
        except (OSError, IndexError, ValueError):      # ended meanwhile
            continue
    return found


class CpuSpan:
    """CPU of this process (role ``this``) and its children between :meth:`begin` and
    :meth:`end`, per sample."""

    def __init__(self):
        self.start: dict[int, tuple[str, tuple[float, float]]] = {}
        self.per_sample: dict[str, tuple[float, float]] = {}
        self.k0 = 0

    def _now(self) -> dict[int, tuple[str, tuple[float, float]]]:
        found = {os.getpid(): "this", **children()}
        now = {}
        for pid, name in found.items():
            try:
                now[pid] = (name, process_cpu(pid))
            except OSError:
                continue
        return now

    def begin(self, sample: int = 0) -> None:
        self.start, self.k0 = self._now(), sample

    def end(self, sample: int) -> None:
        """Per process role: ``(main, other)`` CPU seconds per sample since :meth:`begin`."""
        n = max(sample - self.k0, 1)
        self.per_sample = {}
        for pid, (name, (main, other)) in self._now().items():
            if pid in self.start:
                m0, o0 = self.start[pid][1]
                self.per_sample[name] = ((main - m0) / n, (other - o0) / n)

    def total(self) -> float:
        """CPU seconds per sample, all processes and threads."""
        return sum(a + b for a, b in self.per_sample.values())

    def lines(self) -> list[str]:
        """One line per process: main thread and other threads in us per sample."""
        return [f"  {name:28s} {1e6 * main:8.0f} {1e6 * other:8.0f} {1e6 * (main + other):8.0f}"
                for name, (main, other) in sorted(self.per_sample.items())]


TRACER = """
import importlib, json, select, sys
import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy, DurabilityPolicy
from rotor_avc.nodes.runtime import make_executor
topics, out = json.loads(sys.argv[1]), sys.argv[2]     # argv[3]: "tracer", its role
rclpy.init()
node = rclpy.create_node("bench_tracer")
qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT,
                 history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
rows = [[] for _ in topics]
for i, (name, kind) in enumerate(topics):
    pkg, _, cls = kind.split("/")
    node.create_subscription(
        getattr(importlib.import_module(pkg + ".msg"), cls), name, qos_profile=qos, raw=True,
        callback=lambda data, info, r=rows[i]: r.append(
            (info["publication_sequence_number"], info["source_timestamp"])))
ex = make_executor("single_threaded")     # the events executor gives no message info
ex.add_node(node)
print("ready", flush=True)
while rclpy.ok():
    ex.spin_once(timeout_sec=0.05)
    if select.select([sys.stdin], [], [], 0)[0] and not sys.stdin.read(1):
        break
np.savez(out, **{str(i): np.asarray(r, np.int64).reshape(-1, 2) for i, r in enumerate(rows)})
"""


class Tracer:
    """The tracing process (module docstring) over ``topics`` [(name, type), ...]: a context
    manager; :attr:`rows` holds, per topic, (sequence number, source time ns) rows after it."""

    def __init__(self, topics: list[tuple[str, str]]):
        self.topics = topics
        self.rows: list[np.ndarray] = []

    def __enter__(self):
        self.folder = tempfile.TemporaryDirectory()
        self.out = Path(self.folder.name) / "trace.npz"
        self.proc = subprocess.Popen(
            [sys.executable, "-c", TRACER, json.dumps(self.topics), str(self.out), "tracer"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        if self.proc.stdout.readline().strip() != "ready":
            raise RuntimeError("the tracing process did not start")
        return self

    def __exit__(self, *exc):
        self.proc.stdin.close()
        self.proc.wait(timeout=60)
        if self.out.exists():
            with np.load(self.out) as data:
                self.rows = [data[str(i)] for i in range(len(self.topics))]
        self.folder.cleanup()


def _by_sample(rows: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """Source times of sequence numbers ``samples + 1`` (the k-th message is sample k)."""
    seq, t = rows[:, 0], rows[:, 1]
    order = np.argsort(seq)
    return t[order][np.searchsorted(seq[order], samples + 1)]


def timeline(rows: list[np.ndarray], plant: list[int], answers: list[tuple[int, int]]) -> dict:
    """The per-sample timeline (module docstring) from a :class:`Tracer`'s rows: ``plant`` the
    indices of the plant's topics, ``answers`` (measurement index, answer index) per controller.
    Returns ``{segment: (median us, p90 us)}`` over the samples every topic traced (and the
    next sample's plant messages)."""
    common = np.unique(rows[0][:, 0]) - 1
    for r in rows[1:]:
        common = np.intersect1d(common, np.unique(r[:, 0]) - 1)
    k = common[np.isin(common + 1, common)]
    if len(k) < 10:
        raise RuntimeError(f"the tracer saw {len(k)} whole samples: too few for a timeline")
    pub = np.array([_by_sample(rows[i], k) for i in plant])
    pub_next = np.array([_by_sample(rows[i], k + 1) for i in plant])
    answered = np.array([_by_sample(rows[a], k) for _, a in answers])
    controller = answered - np.array([_by_sample(rows[m], k) for m, _ in answers])
    segments = {
        "plant publishes its messages (first to last)": pub.max(0) - pub.min(0),
        "measurement -> answer published (each controller)": controller.ravel(),
        "last answer -> plant's next sample published": pub_next.min(0) - answered.max(0),
        "whole sample (period)": pub_next.min(0) - pub.min(0),
    }
    return {name: (float(np.median(v)) * 1e-3, float(np.percentile(v, 90)) * 1e-3)
            for name, v in segments.items()}
