"""``foot_controller``: one foot's digital controller G_c(z) as a ROS node.

Run one per actuated foot: ``ros2 run rotor_avc foot_controller --ros-args -r
__node:=foot_controller_DL -p foot_id:=DL -p scenario:=scenario_case3_steady`` (or
``python -m rotor_avc.nodes.foot_controller ...``).

A thin adapter over :class:`rotor_avc.control.block.DigitalController` built from the same
scenario config as the plant (rotor_avc.control.block.build_digital_controllers), so its forces
equal the in-process loop's. It subscribes to its foot's signal of the controller's feedback kind
(``foot/<id>/acceleration|velocity|displacement``) and answers every sample with
``foot/<id>/actuator_force`` stamped like the measurement.

Faults: a measurement that is not finite, or older than the last one processed (stale), does not
step the filter: the node answers with its safe output (``safe_output``: hold the last force or
zero) and says why on ``/diagnostics`` and in its log. A repeated stamp (the plant resending a
sample) is answered from the cache, without stepping twice. With ``initial_state:
steady_state`` in the scenario the filter starts on the loop's periodic solution, computed as the
in-process loop does.
"""
from __future__ import annotations

import math
import time

from rclpy.node import Node

from ..control.block import build_digital_controllers
from ..errors import RotorAvcError
from ..sim.steady_state import start_in_steady_state
from . import messages as m
from . import taps
from .runtime import (COMMON_PARAMS, Param, ParameterError, declare_parameters, node_scenario,
                      run_node)
from .timing import LoopTiming

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario or machine config (path or shipped name) holding this foot's "
          "controller"),
    Param("foot_id", "", "the actuator this node controls, e.g. DL"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine (/<namespace>/foot/...)"),
    Param("safe_output", "hold", "force sent for a bad or stale measurement: hold the last "
          "force or zero", choices=("hold", "zero")),
)


class FootController(Node):
    """One foot's controller node (see the module docstring)."""

    def __init__(self, name: str = "foot_controller", **kwargs):
        super().__init__(name, **kwargs)
        self.p = declare_parameters(self, PARAMS)
        self.executor_kind = self.p["executor"]
        foot = self.p["foot_id"]
        if not foot:
            raise ParameterError(f"{self.get_name()}: parameter 'foot_id' is empty -- fix: "
                                 "-p foot_id:=DL (a foot with a controller in the scenario)")
        sc = node_scenario(self, self.p["scenario"], "the scenario holding this foot's controller")
        controllers = build_digital_controllers(sc.machine, sc.sample_period_s)
        if foot not in controllers:
            raise RotorAvcError(f"{self.get_name()}: foot_id {foot!r} has no controller in "
                                f"{sc.machine.config.source} -- fix: use one of "
                                + (", ".join(controllers) or "(none: loops open)"))
        if sc.initial_state == "steady_state":
            start_in_steady_state(sc.stepper(), controllers)
        else:
            controllers[foot].reset()
        self.ctrl = controllers[foot]
        self.foot = foot
        self.axis = sc.machine.plant.actuator(foot).axis
        ns = self.p["namespace"]
        self.kind = self.ctrl.feedback
        self.force = m.Force(foot, self.axis)
        self.pub = taps.publisher(self, m.STAMPED_TYPES["actuator_force"],
                                         m.foot_topic(foot, "actuator_force", ns), m.LOCKSTEP_QOS)
        self.create_subscription(m.MEASUREMENT_TYPES[self.kind], m.foot_topic(foot, self.kind, ns),
                                 self._on_measurement, m.LOCKSTEP_QOS, raw=True)
        self.pub_diag = taps.publisher(self, m.DiagnosticArray, "/diagnostics", m.DIAGNOSTICS_QOS)
        self.create_timer(1.0, self._publish_diagnostics)
        self.timing = LoopTiming(None)
        self.last_stamp = -1
        self.last_force = 0.0
        self.faults = {"not_finite": 0, "stale": 0, "repeated": 0, "malformed": 0}
        self.last_fault = ""

    def _on_measurement(self, data: bytes) -> None:
        self.timing.start()
        try:
            stamp, value = m.stamped_value(data, self.axis)      # raw: see messages.StampedVector
        except ValueError as exc:                                # no stamp to answer: say why
            self.faults["malformed"] += 1
            self._report(f"malformed measurement ignored ({exc})")
            self.timing.stop()
            return
        if stamp == self.last_stamp:
            self.faults["repeated"] += 1
            force = self.last_force
        elif stamp < self.last_stamp or not math.isfinite(value):
            kind = "stale" if stamp < self.last_stamp else "not_finite"
            self.faults[kind] += 1
            force = self.last_force if self.p["safe_output"] == "hold" else 0.0
            why = (f"stale measurement (stamp {stamp} ns after {self.last_stamp} ns)"
                   if kind == "stale" else f"measurement {value} at stamp {stamp} ns")
            self._report(f"{why}: holding the safe output {force:g} N ({self.p['safe_output']})")
        else:
            force = self.ctrl.step(value)
            self.last_stamp = stamp
            self.last_force = force
        self.pub.publish(self.force.fill(stamp, force))
        self.timing.stop()

    def _report(self, text: str) -> None:
        if text != self.last_fault:
            self.get_logger().warning(text)
        self.last_fault = text
        self.t_fault = time.monotonic()
        self._publish_diagnostics()

    def _publish_diagnostics(self) -> None:
        stats = self.timing.summary()
        stats.update(self.faults)
        stats.update({"force_n": self.last_force, "gain": self.ctrl.gain})
        recent = self.last_fault and time.monotonic() - getattr(self, "t_fault", 0.0) < 5.0
        level, text = ("warn", self.last_fault) if recent else ("ok", self.ctrl.describe())
        self.pub_diag.publish(m.diagnostics(max(self.last_stamp, 0),
                                            [(f"{self.get_name()}: {self.foot}", level, text, stats),
                                             m.published_status(self)]))


def main(args=None) -> int:
    return run_node(FootController, args)


if __name__ == "__main__":
    raise SystemExit(main())
