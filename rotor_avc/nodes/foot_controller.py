"""``foot_controller``: one foot's digital controller G_c(z) as a ROS node.

Run one per actuated foot: ``ros2 run rotor_avc foot_controller --ros-args -r
__node:=foot_controller_DL -p foot_id:=DL -p scenario:=scenario_case3_steady`` (or
``python -m rotor_avc.nodes.foot_controller ...``).

A thin adapter over :class:`rotor_avc.control.block.DigitalController` built from the same
scenario config as the plant (rotor_avc.control.block.build_digital_controllers), so its forces
equal the in-process loop's. It subscribes to its foot's signal of the controller's feedback kind
(``foot/<id>/acceleration|velocity|displacement``) and answers every sample with
``foot/<id>/actuator_force`` stamped like the measurement. With ``input: imu`` it takes the
measurement from a ``sensor_msgs/Imu`` as accelerometer drivers publish it (topic
``measurement_topic``, default ``foot/<id>/imu``): ``imu_sign * imu_scale *
linear_acceleration.<imu_axis>`` (``imu_scale`` 9.80665 for a driver that publishes in g); the
controller must have acceleration feedback.

The measurement subscription's QoS (``measurement_qos``, rotor_avc.nodes.messages.MEASUREMENT_QOS):
``sensor_data`` -- best effort, volatile, as rclpy's ``qos_profile_sensor_data``: it matches every
publisher (a driver's best-effort one, a default reliable one, a transient-local one), delivered
best effort; ``reliable`` -- reliable, volatile: reliable publishers of either durability;
``lockstep`` -- the lockstep QoS (reliable, transient-local), which only the plant's publishers
match. ``auto`` (default) is ``lockstep`` for the plant's stamped signal on its own topic (input
``stamped``, no ``measurement_topic``): the package's graph keeps reliable delivery and the
samples published before the subscription matched; and ``sensor_data`` for every external input
(``input: imu``, or a ``measurement_topic``). A publisher whose QoS the subscription cannot match
(its messages would never arrive) is an ERROR on ``/diagnostics`` and in the log, naming the
topic, the policy and the fix, for as long as such a publisher is in the graph.

Every measurement is screened before it reaches the filter (each rejected one is answered with
the safe output -- ``safe_output``: hold the last force, or zero -- counted, and said on
``/diagnostics`` and in the log; the next good sample steps the filter as if it had not come):

* ``wrong_frame`` -- ``header.frame_id`` is not ``frame_id`` (default ``foot_<id>``, as the
  plant stamps it; ``*`` takes any);
* ``implausible`` -- not finite, or beyond the controller's ``measurement_limit``
  (rotor_avc.control.block);
* ``stale`` / ``future`` -- stamped before the last sample, or more than ``max_stamp_jump_s``
  after it; ``resync`` -- ``resync_samples`` consecutive such stamps that agree with each other
  are a new time base: the filter is reset to rest and the stream taken from there
  (rotor_avc.control.stamps);
* ``repeated`` -- the same stamp again (the plant resending a sample) is answered from the cache,
  without stepping twice; ``malformed`` -- bytes that are not a measurement (no stamp to answer).

Overload: a controller that cannot keep up does not queue: the subscription keeps the newest
``LOCKSTEP_DEPTH`` messages (older ones are overwritten in the queue) and each one taken steps
the filter once, so its state stays what it is (a few floats). The samples that never reached
the callback show as gaps in the stamps (``dropped``, and ``dropped_per_s`` over the last
diagnostics period) and, where the middleware reports them, as DDS lost samples
(``dds_lost``). With ``initial_state: steady_state`` in the scenario the filter starts on the
loop's periodic solution, computed as the in-process loop does. The read-only parameter
``answer_config`` says what decides its answers (rotor_avc.compare.answer_config), which
``rotor-avc replay`` compares with a bag's before re-driving it.
"""
from __future__ import annotations

import time

from rclpy.node import Node

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import QoSCompatibility, qos_check_compatible, qos_policy_name_from_kind

from ..block_kinds import FEEDBACK
from ..compare.answer_config import answer_config
from ..control.block import SAFE_OUTPUTS, build_digital_controllers
from ..control.stamps import StampScreen
from ..errors import RotorAvcError
from ..sim.steady_state import start_in_steady_state
from . import messages as m
from . import taps
from .replay_config import declare_answer_config
from .runtime import (COMMON_PARAMS, Param, ParameterError, check_node_design,
                      declare_parameters, node_scenario, run_node)
from .timing import LoopTiming

#: an incompatible-QoS error stays until the graph has shown no such publisher for this long
QOS_RECHECK_S = 5.0

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario or machine config (path or shipped name) holding this foot's "
          "controller"),
    Param("foot_id", "", "the actuator this node controls, e.g. DL"),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine (/<namespace>/foot/...)"),
    Param("safe_output", "hold", "force sent for a bad or stale measurement: hold the last "
          "force or zero", choices=SAFE_OUTPUTS),
    Param("input", "stamped", "measurement message: the plant's stamped vector of the feedback "
          "kind, or sensor_msgs/Imu (linear_acceleration)", choices=("stamped", "imu")),
    Param("measurement_topic", "", "topic of the measurement (default: foot/<id>/<kind>, with "
          "input imu foot/<id>/imu, in the namespace)"),
    Param("imu_axis", "z", "linear_acceleration component that is the foot's signal",
          choices=("x", "y", "z")),
    Param("imu_sign", 1, "sign of the Imu axis relative to the foot's axis (1 or -1)",
          minimum=-1, maximum=1),
    Param("imu_scale", 1.0, "factor from the Imu's unit to m/s^2 (9.80665 for g)",
          minimum=1e-12, maximum=1e12),
    Param("measurement_qos", "auto", "QoS of the measurement subscription: sensor_data (best "
          "effort, volatile: matches every publisher), reliable (reliable, volatile), lockstep "
          "(reliable, transient-local: the plant's); auto: lockstep for the plant's stamped "
          "signal on its own topic, sensor_data otherwise",
          choices=("auto",) + tuple(m.MEASUREMENT_QOS)),
    Param("frame_id", "", "expected header.frame_id of a measurement (empty: foot_<id>, as the "
          "plant stamps it; '*': any)"),
    Param("max_stamp_jump_s", 1.0, "a stamp more than this after the last sample is refused "
          "(future)", minimum=1e-6, maximum=1e6),
    Param("resync_samples", 10, "consecutive refused stamps that agree with each other taken "
          "as a new time base (filter reset)", minimum=1, maximum=1_000_000),
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
        check_node_design(self, sc)
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
        self.ctrl.safe_output = self.p["safe_output"]
        declare_answer_config(self, answer_config(sc, FEEDBACK.name, foot))
        self.foot = foot
        self.axis = sc.machine.plant.actuator(foot).axis
        ns = self.p["namespace"]
        self.kind = self.ctrl.feedback
        self._input(foot, ns)
        self.force = m.Force(foot, self.axis)
        self.pub = taps.publisher(self, m.STAMPED_TYPES["actuator_force"],
                                  m.actuator_topic(foot, "actuator_force", ns), m.LOCKSTEP_QOS)
        self.sub = self.create_subscription(
            self.msg_type, self.topic, self._on_measurement, m.MEASUREMENT_QOS[self.qos_name],
            raw=True, event_callbacks=SubscriptionEventCallbacks(
                message_lost=self._on_lost, incompatible_qos=self._on_incompatible_qos))
        self.qos_error = ""
        self.pub_diag = taps.publisher(self, m.DiagnosticArray, "/diagnostics", m.DIAGNOSTICS_QOS)
        self.create_timer(1.0, self._publish_diagnostics)
        self.timing = LoopTiming(None)
        self.stamps = StampScreen(sc.sample_period_s, self.p["max_stamp_jump_s"],
                                  self.p["resync_samples"])
        self.last_force = 0.0
        self.faults = {"malformed": 0, "wrong_frame": 0, "dds_lost": 0, "incompatible_qos": 0}
        self.last_fault = ""
        self._seen_implausible = 0
        self._dropped_then = (0, time.monotonic())
        self.dropped_per_s = 0.0

    def _input(self, foot: str, ns: str) -> None:
        """Message type, topic, value offset, factor and frame check of the measurement."""
        p = self.p
        if p["input"] == "imu":
            if self.kind != "acceleration":
                raise ParameterError(f"{self.get_name()}: parameter 'input' is imu, but the "
                                     f"controller of {foot} feeds back {self.kind} -- fix: use "
                                     "input:=stamped, or an acceleration-feedback controller")
            if p["imu_sign"] not in (-1, 1):
                raise ParameterError(f"{self.get_name()}: parameter 'imu_sign' must be 1 or -1 "
                                     f"(got {p['imu_sign']}) -- fix: -p imu_sign:=-1 for an "
                                     "axis mounted upside down")
            self.msg_type, self.value_axis, self.skip = m.Imu, p["imu_axis"], m.IMU_ACCELERATION_SKIP
            self.factor = p["imu_sign"] * p["imu_scale"]
            default_topic = m.topic(f"foot/{foot}/imu", ns)
        else:
            self.msg_type, self.value_axis, self.skip = m.MEASUREMENT_TYPES[self.kind], self.axis, 0
            self.factor = 1.0
            default_topic = m.actuator_topic(foot, self.kind, ns)
        self.topic = p["measurement_topic"] or default_topic
        external = p["input"] != "stamped" or bool(p["measurement_topic"])
        self.qos_name = p["measurement_qos"]
        if self.qos_name == "auto":
            self.qos_name = "sensor_data" if external else "lockstep"
        frame = p["frame_id"] or f"foot_{foot}"
        self.frame = None if frame == "*" else m.frame_id_prefix(frame)
        self.frame_name = frame

    def _on_measurement(self, data: bytes) -> None:
        self.timing.start()
        try:
            stamp, value = m.stamped_value(data, self.value_axis, self.skip)  # raw: StampedVector
        except ValueError as exc:                                # no stamp to answer: say why
            self.faults["malformed"] += 1
            self._report(f"malformed measurement ignored ({exc})")
            self.timing.stop()
            return
        ctrl = self.ctrl
        if self.frame is not None and not data.startswith(self.frame, 12):
            self.faults["wrong_frame"] += 1
            force = ctrl.safe_force_n()
            self._report(f"measurement at stamp {stamp} ns not from frame {self.frame_name!r}: "
                         f"{self._safe(force)}")
        else:
            verdict = self.stamps.classify(stamp)
            if verdict == "ok":
                force = self.last_force = ctrl.step(self.factor * value)
                if ctrl.faults["implausible"] != self._seen_implausible:
                    self._seen_implausible = ctrl.faults["implausible"]
                    self._report(f"implausible measurement {value} at stamp {stamp} ns (limit "
                                 f"+-{ctrl.measurement_limit:g}): {self._safe(force)}")
            elif verdict == "repeated":
                force = self.last_force
            elif verdict == "resync":
                ctrl.reset()
                force = self.last_force = ctrl.step(self.factor * value)
                self._report(f"new time base at stamp {stamp} ns after {self.stamps.resync_samples}"
                             " consistent out-of-order stamps: filter reset to rest")
            else:
                force = ctrl.safe_force_n()
                self._report(f"{verdict} measurement (stamp {stamp} ns, last sample "
                             f"{self.stamps.last_ns} ns): {self._safe(force)}")
        self.pub.publish(self.force.fill(stamp, force))
        self.timing.stop()

    def _safe(self, force: float) -> str:
        return f"answered the safe output {force:g} N ({self.ctrl.safe_output})"

    def _on_lost(self, info) -> None:
        self.faults["dds_lost"] = info.total_count
        self._report(f"the middleware lost {info.total_count_change} measurement(s) "
                     f"({info.total_count} in all)")

    def _on_incompatible_qos(self, info) -> None:
        """A publisher of the measurement topic whose QoS this subscription cannot match."""
        self.faults["incompatible_qos"] = info.total_count
        fix = ("-p measurement_qos:=sensor_data (best effort, volatile: matches every publisher)"
               if self.qos_name != "sensor_data" else
               "a publisher QoS a best-effort, volatile subscription matches")
        self.qos_error = (f"a publisher of {self.sub.topic_name} offers a QoS this subscription "
                          f"({self.qos_name}) cannot match (policy "
                          f"{qos_policy_name_from_kind(info.last_policy_kind)}; "
                          f"{info.total_count} such publisher(s) so far): its measurements never "
                          f"arrive -- fix: {fix}")
        self.t_qos_error = time.monotonic()
        self.get_logger().error(self.qos_error)
        self._publish_diagnostics()

    def _incompatible_publishers(self) -> int:
        """Publishers of the measurement topic in the graph this subscription cannot match."""
        qos = m.MEASUREMENT_QOS[self.qos_name]
        return sum(qos_check_compatible(info.qos_profile, qos)[0] == QoSCompatibility.ERROR
                   for info in self.get_publishers_info_by_topic(self.sub.topic_name))

    @property
    def counts(self) -> dict:
        """Every fault and overload counter (node, stamp screen, controller block)."""
        return {**self.faults, **self.stamps.counts, **self.ctrl.faults,
                "saturated": self.ctrl.saturated_samples}

    def _report(self, text: str) -> None:
        if text != self.last_fault:
            self.get_logger().warning(text)
        self.last_fault = text
        self.t_fault = time.monotonic()
        self._publish_diagnostics()

    def _publish_diagnostics(self) -> None:
        stats = self.timing.summary()
        counts = self.counts
        stats.update(counts)
        n0, t0 = self._dropped_then
        now = time.monotonic()
        if now > t0:
            self.dropped_per_s = (counts["dropped"] - n0) / (now - t0)
            self._dropped_then = (counts["dropped"], now)
        stats.update({"dropped_per_s": self.dropped_per_s, "force_n": self.last_force,
                      "gain": self.ctrl.gain})
        recent = self.last_fault and now - getattr(self, "t_fault", 0.0) < 5.0
        if counts["dropped"] > n0 and not recent:
            self.last_fault = (f"{counts['dropped'] - n0} measurement(s) dropped since the last "
                               f"report ({self.dropped_per_s:.0f}/s): measurements come faster "
                               "than this controller takes them")
            self.t_fault, recent = now, True
        if (self.qos_error and now - self.t_qos_error > QOS_RECHECK_S
                and not self._incompatible_publishers()):
            self.get_logger().info(f"no publisher of {self.sub.topic_name} with an incompatible "
                                   "QoS left")
            self.qos_error = ""
        level, text = ("warn", self.last_fault) if recent else ("ok", self.ctrl.describe())
        if self.qos_error:
            level, text = "error", self.qos_error
        self.pub_diag.publish(m.diagnostics(max(self.stamps.last_ns, 0),
                                            [(f"{self.get_name()}: {self.foot}", level, text, stats),
                                             m.published_status(self)]))


def main(args=None) -> int:
    return run_node(FootController, args)


if __name__ == "__main__":
    raise SystemExit(main())
