"""Helpers of the launch-free ROS integration tests: nodes in rclpy executors, node processes."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy", reason="ROS 2 Jazzy (rclpy) is not installed")
from rclpy.parameter import Parameter  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def params(**values) -> list:
    return [Parameter(k, value=v) for k, v in values.items()]


def make_executor(kind: str = "events"):
    from rotor_avc.nodes.runtime import make_executor as make
    return make(kind)


def spin_until(executor, condition, timeout_s: float = 60.0, step_s: float = 0.05) -> bool:
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        if condition():
            return True
        executor.spin_once(timeout_sec=step_s)
    return condition()


def node_process(module: str, *ros_args: str, env_extra: dict | None = None,
                 stdout=subprocess.PIPE) -> subprocess.Popen:
    """Start ``python -m rotor_avc.nodes.<module> --ros-args ...`` (ROS env of the test run)."""
    from rotor_avc.nodes.signals import spawn
    env = dict(os.environ, PYTHONUNBUFFERED="1", **(env_extra or {}))
    return spawn([sys.executable, "-m", f"rotor_avc.nodes.{module}", "--ros-args", *ros_args],
                 cwd=ROOT, env=env, stdout=stdout, stderr=subprocess.STDOUT, text=True)


def wait_for_nodes(names, timeout_s: float = 120.0, procs=()) -> bool:
    """Wait until every node of ``names`` is in the ROS graph (their readiness), seen by a
    listener node of this process in its own context; False on timeout or when one of
    ``procs`` has exited."""
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("test_graph_listener", context=context)
    try:
        t_end = time.monotonic() + timeout_s
        while time.monotonic() < t_end:
            if set(names) <= set(node.get_node_names()):
                return True
            if any(p.poll() is not None for p in procs):
                return False
            time.sleep(0.05)
        return False
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)


def stop(proc: subprocess.Popen, timeout_s: float = 10.0) -> str:
    if proc.poll() is None:
        proc.terminate()
    try:
        out, _ = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
    return out or ""
