"""``synchronous_controller``: Sci. Rep. 2023's 1x feed-forward force generator as a ROS node.

Run: ``ros2 run rotor_avc synchronous_controller --ros-args -p scenario:=scenario_active_bearing``
(or ``python -m rotor_avc.nodes.synchronous_controller ...``).

A thin adapter over :class:`rotor_avc.control.synchronous.SynchronousForceGenerator` as the
scenario's ``simulation.feedforward`` builds it (the block the in-process loop runs): at every
``rotor/joint_state`` (shaft angle, speed at ``t_k``) it publishes the force of each of its
actuators on ``foot/<id>/actuator_force`` stamped ``t_k`` -- the plant waits for these answers in
lockstep as it does for foot controllers. A repeated stamp (the plant resending) is answered from
the cache; a non-finite angle or speed holds the last forces and says why. Joint states and
forces travel as serialised bytes (rotor_avc.nodes.messages: raw subscription and publishers,
the same messages on the wire); a malformed joint state is ignored and reported.
"""
from __future__ import annotations

import math

from rclpy.node import Node
from sensor_msgs.msg import JointState

from ..errors import RotorAvcError
from . import messages as m
from . import taps
from .runtime import COMMON_PARAMS, Param, declare_parameters, node_scenario, run_node
from .timing import LoopTiming

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config with `simulation.feedforward`"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine"),
)


class SynchronousController(Node):
    """The feed-forward node (see the module docstring)."""

    def __init__(self, name: str = "synchronous_controller", **kwargs):
        super().__init__(name, **kwargs)
        self.p = declare_parameters(self, PARAMS)
        self.executor_kind = self.p["executor"]
        sc = node_scenario(self, self.p["scenario"], "a scenario with `simulation.feedforward`")
        self.generator = sc.feedforward()
        if self.generator is None:
            raise RotorAvcError(f"{self.get_name()}: {sc.machine.config.source} has no "
                                "`simulation.feedforward` -- fix: use a feed-forward scenario")
        self.generator.reset()
        plant = sc.machine.plant
        ns = self.p["namespace"]
        self.outputs = []
        for act_id in self.generator.actuator_ids:
            force = m.Force(act_id, plant.actuator(act_id).axis)
            self.outputs.append((taps.publisher(self, m.STAMPED_TYPES["actuator_force"], m.foot_topic(
                act_id, "actuator_force", ns), m.LOCKSTEP_QOS), force))
        self.create_subscription(JointState, m.topic("rotor/joint_state", ns), self._on_joint,
                                 m.LOCKSTEP_QOS, raw=True)
        self.pub_diag = taps.publisher(self, m.DiagnosticArray, "/diagnostics", m.DIAGNOSTICS_QOS)
        self.create_timer(1.0, self._publish_diagnostics)
        self.timing = LoopTiming(None)
        self.last_stamp = -1
        self.forces = [0.0] * len(self.outputs)
        self.faults = 0
        self.last_fault = ""

    def _on_joint(self, data: bytes) -> None:
        try:
            stamp, position, velocity = m.joint_state(data)
        except m.MessageError as exc:
            self._fault(f"rotor/joint_state ignored: {exc}")
            return
        angle = position[0] if position else math.nan
        speed = velocity[0] if velocity else math.nan
        if stamp > self.last_stamp:
            self.timing.start()
            if math.isfinite(angle) and math.isfinite(speed):
                self.forces = self.generator.step(angle, speed).tolist()
            else:
                self._fault(f"non-finite shaft angle/speed at {stamp} ns: forces held")
            self.last_stamp = stamp
            self.timing.stop()
        elif stamp < self.last_stamp:
            return                                   # stale: the plant has moved on
        for (pub, force), value in zip(self.outputs, self.forces):
            pub.publish(force.fill(stamp, value))

    def _fault(self, text: str) -> None:
        self.faults += 1
        self.last_fault = text
        self.get_logger().warning(text)

    def _publish_diagnostics(self) -> None:
        stats = self.timing.summary()
        stats.update({"faults": self.faults, "in_table": self.generator.in_range})
        level, text = ("warn", self.last_fault) if self.last_fault else ("ok", "1x feed-forward")
        self.pub_diag.publish(m.diagnostics(max(self.last_stamp, 0), [
            (f"{self.get_name()}: feed-forward", level, text, stats), m.published_status(self)]))


def main(args=None) -> int:
    return run_node(SynchronousController, args)


if __name__ == "__main__":
    raise SystemExit(main())
