"""``balancer``: the one-plane active balancer (RLS estimate + switching law) as a ROS node.

Run: ``ros2 run rotor_avc balancer --ros-args -p scenario:=scenario_balance_runup`` with the plant
started with ``-p balancer:=true`` (lockstep: the plant waits for the balancer at every sample).

A thin adapter over :class:`rotor_avc.balancing.loop_block.LoopBalancer` (the block the
in-process loop runs): it pairs ``rotor/joint_state`` (shaft angle, speed) and
``plant/observables`` (the measurement vector) of the same sample by their sample time, steps the
block, and publishes

* ``balancer/command`` -- the correction its plane applies, labelled ``time_s,
  static_re, static_im, moment_re, moment_im`` (kg m, kg m^2), stamped by ``time_s``, at every
  plant sample (the plant waits for it);
* ``balancer/estimate`` -- the estimated unbalance in the same layout, at every balancer sample
  (every ``balancer.sample_period_s``, when the estimate can change: the block updates only
  then), stamped by the plant sample that brought it.

A repeated sample (the plant resending) is answered from the cache without stepping twice. All
four topics travel as serialised bytes (rotor_avc.nodes.messages: raw subscriptions and
publishers, the same messages on the wire); a malformed message is ignored and reported. The
read-only parameter ``answer_config`` says what decides its commands
(rotor_avc.nodes.replay_config).
"""
from __future__ import annotations

import math

from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from ..bag.array_labels import balancer_labels
from ..balancing.loop_block import LoopBalancer
from ..balancing.scenario import machine_setup
from ..block_kinds import BALANCER
from ..blocks import LoopSample
from ..compare.answer_config import answer_config
from . import messages as m
from . import taps
from .feature_node import FeatureNode
from .replay_config import declare_answer_config
from .runtime import COMMON_PARAMS, Param, run_node

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config with a `balancer:` section"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine"),
)


class Balancer(FeatureNode):
    """The balancer node (see the module docstring)."""

    PARAMS = PARAMS
    NEEDS = "a `balancer:` section"
    TITLE = "balancer"

    def __init__(self, name: str = "balancer", **kwargs):
        super().__init__(name, **kwargs)
        declare_answer_config(self, answer_config(self.scenario, BALANCER.name))
        self.excitations = [e.name for e in self.scenario.machine.plant.excitations]
        names = balancer_labels(self.excitations)
        self.command = m.LabelledBytes(names)
        self.estimate = m.LabelledBytes(names)
        ns = self.namespace
        self.pub_cmd = taps.publisher(self, Float64MultiArray, m.topic("balancer/command", ns),
                                             m.LOCKSTEP_QOS)
        self.pub_est = taps.publisher(self, Float64MultiArray, m.topic("balancer/estimate", ns),
                                             m.LOCKSTEP_QOS)
        self.create_subscription(JointState, m.topic("rotor/joint_state", ns), self._on_joint,
                                 m.LOCKSTEP_QOS, raw=True)
        self.create_subscription(Float64MultiArray, m.topic("plant/observables", ns),
                                 self._on_observables, m.LOCKSTEP_QOS, raw=True)
        self.joints: dict[int, tuple[float, float]] = {}
        self.values: dict[int, tuple[float, ...]] = {}
        self.observables_label = ""
        self.names: tuple[str, ...] = ()          # of the observables after time_s
        self.k = 0
        self.last_answer: bytes | None = None

    def build(self, scenario):
        if "balancer" not in scenario.machine.config.data:
            return None
        return LoopBalancer(machine_setup(scenario.machine), scenario.sample_period_s)

    def _on_joint(self, data: bytes) -> None:
        joint = self.joint(data)
        if joint is None:
            return
        stamp, position, velocity = joint
        if len(position) < 1 or len(velocity) < 1:
            self.fault("rotor/joint_state without position/velocity")
            return
        self.joints[stamp] = (position[0], velocity[0])
        self._try(stamp)

    def _on_observables(self, data: bytes) -> None:
        try:
            label, values = m.labelled_array(data)
            if label != self.observables_label:       # the plant's layout: read once
                names = tuple(label.split(","))
                if names[0] != "time_s":
                    raise m.MessageError(f"labelled {label!r}: no leading time_s element")
                self.observables_label, self.names = label, names[1:]
            if len(values) != len(self.names) + 1:
                raise m.MessageError(f"{len(values)} values for the {len(self.names) + 1} "
                                     f"labels {label!r}")
            stamp = m.received_time_ns(values[0])
        except m.MessageError as exc:
            self.fault(f"plant/observables ignored: {exc}")
            return
        self.values[stamp] = values
        self._try(stamp)

    def _try(self, stamp: int) -> None:
        if stamp not in self.joints or stamp not in self.values:
            return
        angle, speed = self.joints.pop(stamp)
        values = self.values.pop(stamp)
        t_s, signals = values[0], values[1:]              # t_s = k T exactly as the plant has it
        if stamp == self.last_stamp and self.last_answer is not None:
            self.pub_cmd.publish(self.last_answer)        # the plant resent this sample
            return
        if stamp < self.last_stamp:
            self.fault(f"stale sample {stamp} ns after {self.last_stamp} ns: ignored")
            return
        updated = self.block.last_output
        if not all(map(math.isfinite, signals)) or not math.isfinite(speed):
            self.fault(f"non-finite measurement at {stamp} ns: correction held")
            corr = self.block.correction
        else:
            self.timing.start()
            corr = self.block.step(LoopSample(self.k, t_s, angle, speed, 0.0, signals, self.names))
            self.timing.stop()
            self.k += 1
        self.last_stamp = stamp
        self.last_answer = self.command.fill(t_s, self._parts(corr))
        self.pub_cmd.publish(self.last_answer)
        if self.block.last_output is not updated:          # a balancer sample: a new estimate
            self.pub_est.publish(self.estimate.fill(t_s, self._parts(self.block.estimate())))
        if self.joints:                                  # unpaired older samples: drop them
            for old in [s for s in self.joints if s < stamp]:
                del self.joints[old]
        if self.values:
            for old in [s for s in self.values if s < stamp]:
                del self.values[old]

    def _parts(self, amplitudes: dict[str, complex]) -> list[float]:
        """``re, im`` of each excitation's amplitude in the labels' order."""
        return [x for e in self.excitations for x in (amplitudes[e].real, amplitudes[e].imag)]

    def status(self) -> tuple[str, str, dict]:
        out = self.block.last_output
        level, text = ("warn", self.last_fault) if self.last_fault else ("ok", "balancing")
        return level, text, {"mode": out.mode if out else "estimate"}


def main(args=None) -> int:
    return run_node(Balancer, args)


if __name__ == "__main__":
    raise SystemExit(main())
