"""What every rotor_avc node shares: declared parameters, the executor, clean shutdown.

Parameters are declared once, each with a type, a description and bounds (as ros2_control's
generate_parameter_library does), read from ``--ros-args --params-file`` YAML, and refused with a
message naming the parameter and the fix. The executor is selectable per node (``executor``
parameter); the default is rclpy's ``EventsExecutor``, measured here at several times the
round-trip rate of the ``SingleThreadedExecutor`` (bench/bench_ros_loop.py) and tested with every
node. SIGINT and SIGTERM shut a node down cleanly (exit status 0).
"""
from __future__ import annotations

import gc
import math
import sys
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import rclpy
from rclpy.duration import Duration
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from ..errors import RotorAvcError
from ..scenario import load_scenario
from . import signals, transport
from .param_types import type_refusal

EXECUTORS = ("events", "single_threaded", "multi_threaded")
FINAL_DIAGNOSTICS_WAIT_S = 5.0       # returns as soon as every subscriber has the message


class ParameterError(RotorAvcError):
    """A node parameter is missing or out of range; the message names it and the fix."""


@dataclass(frozen=True)
class Param:
    """One declared parameter: name, default (its type is the parameter's type), description,
    optional numeric bounds or allowed string values."""

    name: str
    default: Any
    description: str
    minimum: float | None = None
    maximum: float | None = None
    choices: Sequence[str] = field(default_factory=tuple)

    def descriptor(self) -> ParameterDescriptor:
        text = self.description
        if self.choices:
            text += " (one of: " + ", ".join(self.choices) + ")"
        d = ParameterDescriptor(name=self.name, description=text)
        if isinstance(self.default, bool):
            return d
        lo = -math.inf if self.minimum is None else self.minimum
        hi = math.inf if self.maximum is None else self.maximum
        if isinstance(self.default, int) and (self.minimum is not None or self.maximum is not None):
            d.integer_range = [IntegerRange(from_value=int(max(lo, -2**62)),
                                            to_value=int(min(hi, 2**62)), step=0)]
        elif isinstance(self.default, float) and (self.minimum is not None or self.maximum is not None):
            d.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi),
                                                         step=0.0)]
        return d

    def check(self, value: Any, node_name: str) -> Any:
        where = f"{node_name}: parameter '{self.name}'"
        if isinstance(self.default, float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if type(value) is not type(self.default):
            raise ParameterError(type_refusal(self, node_name, value))
        if isinstance(value, float) and not math.isfinite(value):
            raise ParameterError(f"{where} must be finite (got {value})")
        if self.minimum is not None and value < self.minimum:
            raise ParameterError(f"{where} must be >= {self.minimum} (got {value}) -- fix: {self.description}")
        if self.maximum is not None and value > self.maximum:
            raise ParameterError(f"{where} must be <= {self.maximum} (got {value}) -- fix: {self.description}")
        if self.choices and value not in self.choices:
            raise ParameterError(f"{where}: unknown value {value!r} -- fix: use one of "
                                 + ", ".join(self.choices))
        return value


def declare_parameters(node: Node, params: Sequence[Param]) -> dict[str, Any]:
    """Declare every parameter with its descriptor and return the validated values. A value
    given with another type than the declared one, or outside the declared range, is refused by
    rclpy on declaration; the refusal is said in one line (rotor_avc.nodes.param_types,
    :meth:`Param.check`) with the value given (rclpy's parameter overrides)."""
    values = {}
    for p in params:
        try:
            node.declare_parameter(p.name, p.default, p.descriptor())
            value = node.get_parameter(p.name).value
        except Exception as exc:        # rclpy raises several types for bad overrides
            override = getattr(node, "_parameter_overrides", {}).get(p.name)
            given = None if override is None else override.value
            if isinstance(exc, InvalidParameterTypeException):
                raise ParameterError(type_refusal(p, node.get_name(), given)) from None
            if isinstance(exc, InvalidParameterValueException) and given is not None:
                p.check(given, node.get_name())       # out of range: refused by name and bound
            raise ParameterError(f"{node.get_name()}: parameter '{p.name}': {exc} -- fix: "
                                 f"{p.description}") from None
        values[p.name] = p.check(value, node.get_name())
    return values


COMMON_PARAMS = (
    Param("executor", "events", "rclpy executor that spins this node", choices=EXECUTORS),
)


def node_scenario(node: Node, name: str, needs: str):
    """The scenario every node is configured with (parameter ``scenario``), loaded and
    validated; an empty parameter is refused naming what this node ``needs`` from it."""
    if not name:
        raise ParameterError(f"{node.get_name()}: parameter 'scenario' is empty -- fix: give "
                             f"{needs}, e.g. -p scenario:=scenario_case3_steady")
    return load_scenario(name)


def check_node_design(node: Node, scenario) -> None:
    """Refuse an unstable or improper design before the node runs it (DesignError, exit status
    2), unless ``control.allow_unstable``; log the warnings (rotor_avc.analysis.design_check)."""
    from ..analysis.design_check import enforce_scenario      # not needed by every node
    for text in enforce_scenario(scenario, f"{node.get_name()}: {scenario.machine.config.source}"):
        node.get_logger().warning(text)


def make_executor(kind: str, context=None):
    """The executor ``kind`` (one of EXECUTORS) in ``context`` (default: rclpy's)."""
    if kind == "events":
        from rclpy.experimental import EventsExecutor
        return EventsExecutor(context=context)
    if kind == "multi_threaded":
        return MultiThreadedExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def spin_until(executor, condition, t_end: float) -> bool:
    """Spin ``executor`` until ``condition()`` holds (True) or the monotonic time ``t_end``
    has passed (then ``condition()``)."""
    while not condition():
        left = t_end - time.monotonic()
        if left <= 0:
            return condition()
        executor.spin_once(timeout_sec=min(left, 0.05))
    return True


#: topics every node has (ROS 2's own), left out of its ready line
_ROS_TOPICS = {"/rosout", "/parameter_events"}


def ready_line(node: Node) -> str:
    """``ready: publishes ...; subscribes ...``: the node's own topics, logged once it spins."""
    pubs = sorted({p.topic_name for p in node.publishers} - _ROS_TOPICS)
    subs = sorted({s.topic_name for s in node.subscriptions} - _ROS_TOPICS)
    return (f"ready: publishes {', '.join(pubs) or 'nothing'}; "
            f"subscribes {', '.join(subs) or getattr(node, 'subscribes_later', 'nothing')}")


def freeze_start_up() -> None:
    """Once a process's nodes are built: collect the start-up's garbage, then move every object
    left (modules, configs, models, matrices) out of the collector's reach (``gc.freeze``), so
    that a collection during the run walks only what the run itself allocates -- shorter
    pauses in a real-time loop."""
    gc.collect()
    gc.freeze()


def run_node(factory: Callable[[], Node], args=None) -> int:
    """``main()`` of a node: init, build, spin with the node's executor, shut down cleanly.

    A :class:`RotorAvcError` while building (bad parameter or config) is printed as one line and
    exits with status 2 (or the error's own ``exit_status``, e.g. 74 for an output that cannot be
    written); SIGINT/SIGTERM -- at any time, also during the imports and while the
    node is still being built (rotor_avc.nodes.signals) -- end the run after the current
    callback through the same clean shutdown (files closed) with status 0. A node that ends its
    run on its own sets ``exit_requested`` and, when the run failed, ``exit_status`` (non-zero,
    said in its log). Before the executor is shut down, a node's ``drain(executor)`` (if it has
    one) takes what is still queued for it."""
    signals.running()
    transport.use_loopback_profile()          # every UDP socket on 127.0.0.1
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    status = 0
    try:
        node = factory()
        executor = make_executor(getattr(node, "executor_kind", "events"))
        executor.add_node(node)
        node.get_logger().info(ready_line(node))
        freeze_start_up()
        try:
            while (rclpy.ok() and not signals.stop_requested()
                   and not getattr(node, "exit_requested", False)):
                executor.spin_once(timeout_sec=0.1)
            drain = getattr(node, "drain", None)
            if drain is not None and rclpy.ok():
                drain(executor)
        finally:
            executor.shutdown()
        status = getattr(node, "exit_status", 0)
    except RotorAvcError as exc:
        print(f"error: {exc}", file=sys.stderr)
        status = getattr(exc, "exit_status", 2)
    except (signals.Stop, KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        signals.shutting_down()
        if node is not None:
            if rclpy.ok():
                _final_diagnostics(node)
            closed = close_node(node)
            status = status or closed
        if rclpy.ok():
            rclpy.shutdown()
    return status


def close_node(node: Node) -> int:
    """Finish what the node has open (its ``close()``, e.g. a bag) and destroy it. A
    :class:`RotorAvcError` while finishing (a bag that cannot be written to the end: disk full,
    ...) is printed as one line; returns its exit status (else 0)."""
    close = getattr(node, "close", None)
    try:
        if close is not None:
            close()
    except RotorAvcError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return getattr(exc, "exit_status", 2)
    finally:
        node.destroy_node()
    return 0


def _final_diagnostics(node: Node) -> None:
    """A node's last ``/diagnostics`` (its final published counts, which a recorder puts in the
    bag), waited for until the subscribers have it (at most FINAL_DIAGNOSTICS_WAIT_S)."""
    publish, pub = getattr(node, "_publish_diagnostics", None), getattr(node, "pub_diag", None)
    if publish is None or pub is None or not getattr(node, "final_diagnostics", True):
        return
    publish()
    pub.wait_for_all_acked(Duration(seconds=FINAL_DIAGNOSTICS_WAIT_S))
