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

from sensor_msgs.msg import JointState

from . import messages as m
from . import taps
from .feature_node import FeatureNode
from .runtime import COMMON_PARAMS, Param, run_node

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config with `simulation.feedforward`"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine"),
)


class SynchronousController(FeatureNode):
    """The feed-forward node (see the module docstring)."""

    PARAMS = PARAMS
    NEEDS = "`simulation.feedforward`"
    TITLE = "feed-forward"

    def __init__(self, name: str = "synchronous_controller", **kwargs):
        super().__init__(name, **kwargs)
        self.generator = self.block
        self.generator.reset()
        plant = self.scenario.machine.plant
        ns = self.namespace
        self.outputs = []
        for act_id in self.generator.actuator_ids:
            force = m.Force(act_id, plant.actuator(act_id).axis)
            topic = m.actuator_topic(act_id, "actuator_force", ns)
            self.outputs.append((taps.publisher(self, m.STAMPED_TYPES["actuator_force"], topic,
                                                m.LOCKSTEP_QOS), force))
        self.create_subscription(JointState, m.topic("rotor/joint_state", ns), self._on_joint,
                                 m.LOCKSTEP_QOS, raw=True)
        self.forces = [0.0] * len(self.outputs)

    def build(self, scenario):
        return scenario.feedforward()

    def _on_joint(self, data: bytes) -> None:
        joint = self.joint(data)
        if joint is None:
            return
        stamp, position, velocity = joint
        angle = position[0] if position else math.nan
        speed = velocity[0] if velocity else math.nan
        if stamp > self.last_stamp:
            self.timing.start()
            if math.isfinite(angle) and math.isfinite(speed):
                self.forces = self.generator.step(angle, speed).tolist()
            else:
                self.fault(f"non-finite shaft angle/speed at {stamp} ns: forces held")
            self.last_stamp = stamp
            self.timing.stop()
        elif stamp < self.last_stamp:
            return                                   # stale: the plant has moved on
        for (pub, force), value in zip(self.outputs, self.forces):
            pub.publish(force.fill(stamp, value))

    def status(self) -> tuple[str, str, dict]:
        level, text = ("warn", self.last_fault) if self.last_fault else ("ok", "1x feed-forward")
        return level, text, {"in_table": self.generator.in_range}


def main(args=None) -> int:
    return run_node(SynchronousController, args)


if __name__ == "__main__":
    raise SystemExit(main())
