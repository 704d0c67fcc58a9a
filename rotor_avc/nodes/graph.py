"""Run a scenario as a ROS graph of separate processes, launch-free (the demo's engine).

One process per node, as ``ros2 run`` would start them: the recorder, one ``foot_controller`` per
controlled foot, the ``synchronous_controller`` for a feed-forward scenario, the ``balancer``
when the scenario has one, and the ``plant_simulator`` in
lockstep, which waits until the recorder listens to every topic of the run
(``wait_for_recorder``), so the bag holds every sample. Progress comes from the plant's
``/diagnostics`` (sample / samples_total), read by a small listener node in this process. When
the plant has finished, the other nodes get SIGINT, which finalises the bag.

The caller sets the ROS environment (``ROS_AUTOMATIC_DISCOVERY_RANGE``, ``ROS_DOMAIN_ID``); the
children inherit it.
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

from ..errors import RotorAvcError
from ..scenario import load_scenario
from .runtime import make_executor


@dataclass
class GraphRun:
    """What a graph run left behind."""

    bag: Path
    wall_s: float
    steps: int
    logs: dict[str, str]


def _start(module: str, args: list[str], log_dir: Path, name: str) -> tuple[subprocess.Popen, Path]:
    log = log_dir / f"{name}.log"
    fh = open(log, "w")
    proc = subprocess.Popen([sys.executable, "-m", f"rotor_avc.nodes.{module}", "--ros-args",
                             "-r", f"__node:={name}", *args], stdout=fh, stderr=subprocess.STDOUT,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    fh.close()
    return proc, log


def run_graph(scenario_name: str, bag: Path, log_dir: Path,
              progress: Callable[[int, int], None] | None = None,
              timeout_s: float = 3600.0) -> GraphRun:
    """Run ``scenario_name`` (a config name or path) through the ROS graph, recording ``bag``."""
    scenario = load_scenario(scenario_name)
    source = str(scenario.machine.config.source)
    bag, log_dir = Path(bag), Path(log_dir)
    log_dir.mkdir(parents=True, exist_ok=True)
    bag.parent.mkdir(parents=True, exist_ok=True)
    if bag.exists():
        bag.unlink()
    common = ["-p", f"scenario:={source}"]
    procs: dict[str, tuple[subprocess.Popen, Path]] = {}
    procs["recorder"] = _start("recorder", common + ["-p", f"path:={bag}"], log_dir, "recorder")
    for foot in scenario.machine.controllers:
        procs[f"foot_controller_{foot}"] = _start(
            "foot_controller", common + ["-p", f"foot_id:={foot}"], log_dir, f"foot_controller_{foot}")
    if scenario.feedforward_actuators():
        procs["synchronous_controller"] = _start("synchronous_controller", common, log_dir,
                                                 "synchronous_controller")
    plant_args = common + ["-p", "wait_for_recorder:=recorder"]
    if scenario.use_balancer:
        procs["balancer"] = _start("balancer", common, log_dir, "balancer")
        plant_args += ["-p", "balancer:=true"]
    procs["plant_simulator"] = _start("plant_simulator", plant_args, log_dir, "plant_simulator")
    plant = procs["plant_simulator"][0]
    listener = _Progress(progress)
    t0 = time.monotonic()
    try:
        while plant.poll() is None:
            listener.spin(0.2)
            for name, (proc, log) in procs.items():
                if proc.poll() not in (None, 0):
                    raise RotorAvcError(f"node {name} stopped with status {proc.returncode}: "
                                        + log.read_text()[-600:].strip())
            if time.monotonic() - t0 > timeout_s:
                raise RotorAvcError(f"the graph run did not finish within {timeout_s:g} s")
        if plant.returncode != 0:
            log = procs["plant_simulator"][1]
            raise RotorAvcError(f"plant_simulator stopped with status {plant.returncode}: "
                                + log.read_text()[-600:].strip())
        wall = time.monotonic() - t0
    finally:
        for name, (proc, _) in procs.items():
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        for name, (proc, _) in procs.items():
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
        listener.close()
    return GraphRun(bag, wall, listener.total, {n: log.read_text() for n, (_, log) in procs.items()})


class _Progress:
    """Listens to the plant's /diagnostics and reports (sample, samples_total)."""

    def __init__(self, callback):
        self.callback = callback
        self.total = 0
        rclpy.init()
        self.node = rclpy.create_node("rotor_avc_graph_progress")
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, 10)
        self.executor = make_executor("events")
        self.executor.add_node(self.node)

    def _on_diag(self, msg: DiagnosticArray) -> None:
        for st in msg.status:
            if st.name.endswith(": loop"):
                values = {kv.key: kv.value for kv in st.values}
                if "sample" in values and "samples_total" in values:
                    k, n = int(values["sample"]), int(values["samples_total"])
                    self.total = n
                    if self.callback is not None:
                        self.callback(k, n)

    def spin(self, seconds: float) -> None:
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            self.executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown()
