"""Run a scenario as a ROS graph, launch-free (the demo's engine), and record it.

Two layouts of the same nodes:

* **processes** (default): one process per node, as ``ros2 run`` would start them -- the
  recorder, one ``foot_controller`` per controlled foot, the ``synchronous_controller`` for a
  feed-forward scenario, the ``harmonic_controller`` for ``simulation.harmonic``, the
  ``balancer`` when the scenario has one, and the ``plant_simulator``
  in lockstep with ``wait_for_recorder``;
* **composed**: all of them in one process and one executor (:func:`run_composed`, like a ROS 2
  component container), the recorder taking the nodes' messages from their publishers
  (recorder ``source: process``). The messages on the wire and in the bag are the same; it runs
  several times faster, because a lockstep sample then needs no round trip between processes
  (bench/bench_ros_loop.py measures both).

Either way the bag holds every sample: the plant runs at most ``recorder_window`` samples ahead
of what the recorder has taken, waits at the end until it has taken the last one, and ends with
exit status 1 if the recorder disappears. Progress comes from the plant's ``/diagnostics``
(sample / samples_total), read by a small listener node in this process. When the plant has
finished, the other nodes get SIGINT (they publish their final counts), then the recorder,
which finishes the bag; :attr:`GraphRun.counts` are the bag's messages published and recorded
per topic.

Node processes start with SIGINT/SIGTERM blocked until their handlers are in place
(rotor_avc.nodes.signals.spawn). The caller sets the ROS environment
(``ROS_AUTOMATIC_DISCOVERY_RANGE``, ``ROS_DOMAIN_ID``); the children inherit it.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import rclpy
from diagnostic_msgs.msg import DiagnosticArray

from ..bag.reader import BagReader
from ..bag.sequence import check_sequence
from ..errors import RotorAvcError
from ..output_files import make_folder, output_errors
from ..scenario import load_scenario
from . import signals
from .graph_nodes import graph_nodes
from .runtime import make_executor

LAYOUTS = ("processes", "composed")
STOP_TIMEOUT_S = 30.0
#: after the plant has ended: how long the listener takes what it has received (the plant's last
#: /diagnostics, the run's final sample count, reached its subscription before the plant ended)
FINAL_PROGRESS_S = 0.2


@dataclass
class GraphRun:
    """What a graph run left behind."""

    bag: Path
    wall_s: float
    steps: int                       # samples of the run in the bag (rotor_avc.bag.sequence)
    logs: dict[str, str]
    counts: dict[str, dict[str, int | None]]

    def lost(self) -> dict[str, int]:
        """Topics whose recorded count is below the published one, with the difference."""
        return {t: c["published"] - c["recorded"] for t, c in self.counts.items()
                if c["published"] is not None and c["recorded"] < c["published"]}


def _start(command: list[str], log_dir: Path, name: str) -> tuple[subprocess.Popen, Path]:
    log = log_dir / f"{name}.log"
    with output_errors(log):
        fh = open(log, "w")
    with fh:
        proc = signals.spawn([sys.executable, *command], stdout=fh, stderr=subprocess.STDOUT,
                             env=dict(os.environ, PYTHONUNBUFFERED="1"))
    return proc, log


def node_commands(scenario, bag: Path, layout: str = "processes",
                  plant_params: dict | None = None) -> dict[str, list[str]]:
    """The processes of a run: name -> interpreter arguments (the plant last);
    ``plant_params``: more plant_simulator parameters (e.g. ``{"mode": "realtime"}``)."""
    if layout not in LAYOUTS:
        raise RotorAvcError(f"unknown graph layout {layout!r} -- fix: use one of "
                            + ", ".join(LAYOUTS))
    if layout == "composed":
        source = str(scenario.machine.config.source)
        extra = [a for k, v in (plant_params or {}).items() for a in ("-p", f"{k}:={v}")]
        return {"composed": ["-m", "rotor_avc.nodes.composed", "--ros-args",
                             "-p", f"scenario:={source}", "-p", f"path:={bag}", *extra]}
    return {spec.name: ["-m", f"rotor_avc.nodes.{spec.executable}", *spec.ros_args()]
            for spec in graph_nodes(scenario, bag, plant_params)}


def run_graph(scenario_name: str, bag: Path, log_dir: Path,
              progress: Callable[[int, int], None] | None = None,
              timeout_s: float = 3600.0, layout: str = "processes",
              plant_params: dict | None = None) -> GraphRun:
    """Run ``scenario_name`` (a config name or path) through the ROS graph, recording ``bag``
    (``layout``: processes or composed; ``plant_params``: more plant parameters)."""
    scenario = load_scenario(scenario_name)
    bag, log_dir = Path(bag), Path(log_dir)
    make_folder(log_dir)
    make_folder(bag.parent)
    if bag.exists():
        bag.unlink()
    cmds = node_commands(scenario, bag, layout, plant_params)
    listener = _Progress(progress)
    procs: dict[str, tuple[subprocess.Popen, Path]] = {}
    main_name = next(reversed(cmds))          # the plant, or the one composed process
    t0 = time.monotonic()
    try:
        for name, cmd in cmds.items():
            procs[name] = _start(cmd, log_dir, name)
        main = procs[main_name][0]
        while main.poll() is None:
            listener.spin(0.2)
            for name, (proc, log) in procs.items():
                if proc.poll() not in (None, 0):
                    raise RotorAvcError(f"node {name} stopped with status {proc.returncode}: "
                                        + _tail(log))
            if time.monotonic() - t0 > timeout_s:
                raise RotorAvcError(f"the graph run did not finish within {timeout_s:g} s")
        listener.spin(FINAL_PROGRESS_S)   # the plant's last report, acknowledged before it ended
        if main.returncode != 0:
            raise RotorAvcError(f"{main_name} stopped with status {main.returncode}: "
                                + _tail(procs[main_name][1]))
        wall = time.monotonic() - t0
    finally:
        # controllers and balancer first (their final published counts reach the recorder)
        _stop([p for n, (p, _) in procs.items() if n != "recorder"])
        _stop([p for n, (p, _) in procs.items() if n == "recorder"])
        listener.close()
    logs = {n: log.read_text() for n, (_, log) in procs.items()}
    recorder = "recorder" if "recorder" in procs else main_name
    if procs[recorder][0].returncode != 0:
        raise RotorAvcError(f"{recorder} stopped with status {procs[recorder][0].returncode}: "
                            + _tail(procs[recorder][1]))
    with BagReader(bag) as reader:
        counts = reader.counts or {}
        samples = check_sequence(reader).samples
    return GraphRun(bag, wall, samples, logs, counts)


def _stop(procs: list[subprocess.Popen]) -> None:
    for proc in procs:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    for proc in procs:
        try:
            proc.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _tail(log: Path, chars: int = 800) -> str:
    return log.read_text()[-chars:].strip()


class _Progress:
    """Listens to the plant's /diagnostics and reports (sample, samples_total)."""

    def __init__(self, callback):
        self.callback = callback
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("rotor_avc_graph_progress", context=self.context)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, 10)
        self.executor = make_executor("events", context=self.context)
        self.executor.add_node(self.node)

    def _on_diag(self, msg: DiagnosticArray) -> None:
        for st in msg.status:
            if st.name.endswith(": loop"):
                values = {kv.key: kv.value for kv in st.values}
                if "sample" in values and "samples_total" in values:
                    k, n = int(values["sample"]), int(values["samples_total"])
                    if self.callback is not None:
                        self.callback(k, n)

    def spin(self, seconds: float) -> None:
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            self.executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)
