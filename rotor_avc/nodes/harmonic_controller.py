"""``harmonic_controller``: the adaptive harmonic (1x, nx) controller as a ROS node.

Run: ``ros2 run rotor_avc harmonic_controller --ros-args -p
scenario:=scenario_harmonic_case2_steady`` (or ``python -m rotor_avc.nodes.harmonic_controller ...``); the plant runs with
``-p harmonic:=true``.

A thin adapter over :class:`rotor_avc.harmonic.block.HarmonicController` as the scenario's
``simulation.harmonic`` builds it (the block the in-process loop runs). For every sample ``t_k``
it takes the shaft angle and speed from ``rotor/joint_state`` and its sensor signals from
``plant/observables`` (the labelled measurement vector), steps the block once both have
arrived, and publishes its forces on ``harmonic/forces`` (labelled array ``time_s,
<actuator>_f<axis>...``), which the plant adds to the feedback controllers' forces -- in lockstep
the plant waits for it as for a foot controller. A repeated stamp is answered from the cache;
after each update ``harmonic/status`` (labelled array: ``time_s, mode, updates, |E| per
harmonic and sensor, |U| per harmonic and actuator, fallbacks``; mode 0 off, 1 adapting,
2 frozen, 3 fading, 4 identifying; ``fallbacks`` the supervisor's fall-backs, see
:mod:`rotor_avc.harmonic.supervisor`) and ``/diagnostics`` (mode, reason, fall-backs) carry the
estimate's state. Malformed messages are ignored and
reported.

Commission mode (``-p commission:=true``, with ``-p commission_out:=DIR`` and optionally
``-p model:=CONFIG``, the controller's model of the margin check): the node first commissions
at the scenario's constant speed on the signals it receives
(:func:`rotor_avc.reports.commission_files.live_commissioning`, the procedure of
``rotor-avc harmonic commission``): the test level is checked against the limits before any
topic exists (refused: exit status 2, with the reason), then its test phasors go out on
``harmonic/forces``; ``harmonic/status`` after each test revolution has mode 5 (commissioning),
``updates`` the revolutions so far, ``E`` that revolution's phasors and ``U`` the test phasors
applied; ``/diagnostics`` says the step (``i of n``: baseline or actuator, harmonic and test
level, phase and revolutions). At the end it writes ``commission.json`` and, accepted,
``commissioned.yaml`` into ``commission_out``, and after the last test phasor's fade-out adapts
with that config's controller (its ``start_s`` counted from the switch); refused (margin
below ``harmonic.commission.min_phase_margin_deg``, or the test stopped) it stays at zero force
with mode 6 (refused) and ``/diagnostics`` ERROR with the reason. The margin is computed in the
callback of the last test sample (in lockstep the plant waits for it).
"""
from __future__ import annotations

import math

from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from ..bag.array_labels import TIME_LABEL, harmonic_force_labels, harmonic_status_labels
from ..errors import ModelError
from ..harmonic.commission_block import MODES
from ..sim.stepper import MeasurementLayout
from . import messages as m
from . import taps
from .feature_node import FeatureNode
from .runtime import COMMON_PARAMS, Param, run_node

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config with `simulation.harmonic: true`"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine"),
    Param("commission", False, "commission first at the scenario's constant speed (test "
          "phasors, margin check: harmonic.commission), then adapt with the identified table"),
    Param("commission_out", "out/commission", "commission: folder of commission.json and "
          "commissioned.yaml"),
    Param("model", "", "commission: the controller's model config of the margin check "
          "(default: the scenario's machine)"),
)


class HarmonicControllerNode(FeatureNode):
    """The harmonic controller node (see the module docstring)."""

    PARAMS = PARAMS
    NEEDS = "`simulation.harmonic: true`"
    TITLE = "harmonic"

    def __init__(self, name: str = "harmonic_controller", **kwargs):
        super().__init__(name, **kwargs)
        sc = self.scenario
        self.block.reset()
        layout_names = MeasurementLayout(sc.machine.plant).names
        self.obs_label = ",".join((TIME_LABEL,) + tuple(layout_names))
        self.sensor_at = [1 + layout_names.index(s) for s in self.block.sensors]
        ns = self.namespace
        plant = sc.machine.plant
        self.forces_msg = m.LabelledBytes(harmonic_force_labels(
            [(a, plant.actuator(a).axis) for a in self.block.actuator_ids]))
        H, M, N = len(self.block.harmonics), len(self.block.sensors), len(self.block.actuator_ids)
        self.status_msg = m.LabelledBytes(harmonic_status_labels(
            self.block.harmonics, self.block.sensors, self.block.actuator_ids))
        self.pub_forces = taps.publisher(self, Float64MultiArray, m.topic("harmonic/forces", ns),
                                         m.LOCKSTEP_QOS)
        self.pub_status = taps.publisher(self, Float64MultiArray, m.topic("harmonic/status", ns),
                                         m.LOCKSTEP_QOS)
        self.create_subscription(JointState, m.topic("rotor/joint_state", ns), self._on_joint,
                                 m.LOCKSTEP_QOS, raw=True)
        self.create_subscription(Float64MultiArray, m.topic("plant/observables", ns),
                                 self._on_observables, m.LOCKSTEP_QOS, raw=True)
        self.shape = (H, M, N)
        self.pending: dict[int, list] = {}          # stamp -> [angle/speed or None, signals]
        self.forces = [0.0] * N
        self.said_mode = self.block.mode

    def build(self, scenario):
        if not self.p["commission"]:
            return scenario.harmonic()
        if not scenario.use_harmonic:
            return None
        from ..machine import load_machine
        from ..reports.commission_files import live_commissioning
        model = load_machine(self.p["model"]) if self.p["model"] else None
        return live_commissioning(scenario, self.p["commission_out"], model)

    # -- inputs ------------------------------------------------------------------------------
    def _on_joint(self, data: bytes) -> None:
        joint = self.joint(data)
        if joint is None:
            return
        stamp, position, velocity = joint
        if not (position and velocity):
            self.fault(f"rotor/joint_state at {stamp} ns without angle or speed: ignored")
            return
        self._arrived(stamp, 0, (position[0], velocity[0]))

    def _on_observables(self, data: bytes) -> None:
        try:
            label, values = m.labelled_array(data)
            if label != self.obs_label:
                raise m.MessageError("labels differ from the scenario's measurement vector")
            stamp = m.received_time_ns(values[0])
        except m.MessageError as exc:
            self.fault(f"plant/observables ignored: {exc}")
            return
        self._arrived(stamp, 1, [values[i] for i in self.sensor_at])

    def _arrived(self, stamp: int, part: int, value) -> None:
        if stamp < self.last_stamp:
            return                                   # stale: the plant has moved on
        if stamp == self.last_stamp:
            self._publish(stamp)                     # the plant resends: answer from the cache
            return
        parts = self.pending.setdefault(stamp, [None, None])
        parts[part] = value
        if parts[0] is not None and parts[1] is not None:
            del self.pending[stamp]
            for old in [s for s in self.pending if s < stamp]:
                del self.pending[old]
            self._step(stamp, *parts)

    # -- the block ---------------------------------------------------------------------------
    def _step(self, stamp: int, rotor, signals) -> None:
        angle, speed = rotor
        self.timing.start()
        updates = self.block.n_updates
        if all(map(math.isfinite, (angle, speed, *signals))):
            try:
                self.forces = list(self.block.step(signals, angle, speed))
            except ModelError as exc:
                self.fault(f"at {stamp} ns: {exc}; forces held")
        else:
            self.fault(f"non-finite angle, speed or signal at {stamp} ns: forces held")
        self.last_stamp = stamp
        self.timing.stop()
        self._publish(stamp)
        if self.block.n_updates != updates:
            b = self.block
            st = b.status
            self.pub_status.publish(self.status_msg.fill(stamp * 1e-9, [
                MODES.index(st["mode"]), b.n_updates, *abs(b.E).ravel().tolist(),
                *abs(b.U).ravel().tolist(), st["fallbacks"]]))
            if "commissioning" in st and st["mode"] != self.said_mode:
                self.said_mode = st["mode"]
                say = self.get_logger().error if st["mode"] == "refused" else \
                    self.get_logger().info
                say(f"commissioning: {st['commissioning']['progress']}")

    def _publish(self, stamp: int) -> None:
        self.pub_forces.publish(self.forces_msg.fill(stamp * 1e-9, self.forces))

    def status(self) -> tuple[str, str, dict]:
        st = self.block.status
        level = "warn" if self.last_fault or st["fallbacks"] or st["mode"] in (
            "frozen", "fading", "identifying") else "ok"
        text = self.last_fault or f"harmonic control: {st['mode']}"
        values = {"mode": st["mode"], "updates": st["updates"], "saturated": st["saturated"],
                  "reason": st["reason"], "fallbacks": st["fallbacks"]}
        com = st.get("commissioning")
        if com is not None:
            if st["mode"] == "refused":
                level, text = "error", f"commissioning {com['progress']}"
            elif st["mode"] == "commissioning":
                text = self.last_fault or f"commissioning: {com['progress']}"
            values.update({f"commission_{k}": v for k, v in com.items()})
        return level, text, values


def main(args=None) -> int:
    return run_node(HarmonicControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
