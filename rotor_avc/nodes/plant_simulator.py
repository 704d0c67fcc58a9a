"""``plant_simulator``: steps a machine model and publishes its foot measurements.

Run: ``ros2 run rotor_avc plant_simulator --ros-args --params-file config/ros_case3.yaml`` or
``python -m rotor_avc.nodes.plant_simulator --ros-args -p scenario:=scenario_case3_steady``.

A thin adapter over :class:`rotor_avc.sim.stepper.PlantStepper` following the sampling contract
(DESIGN.md 3) and the in-process loop's per-step functions (rotor_avc.sim.loop), so a lockstep run
reproduces ``rotor-avc simulate`` exactly.

* **lockstep** (default): publishes sample ``k`` (foot measurements, ``rotor/joint_state``,
  ``plant/observables``, ``/clock`` = ``t_k``) and steps when every controller of the scenario
  (and the balancer, with ``balancer: true``, and the harmonic controller, with
  ``harmonic: true``: its forces add to the feedback forces) has answered ``t_k``
  (:class:`rotor_avc.nodes.lockstep.AnswerBook`: resend, timeout, fault policy).
* **realtime**: steps on a wall-clock timer at the sample period with the latest forces received;
  a controller silent for longer than ``controller_timeout_s`` gets the fault policy.

Recording: with ``wait_for_recorder: <node name>`` the plant publishes sample 0 only when that
recorder (rotor_avc.nodes.recorder) subscribes to every topic of the run and the plant's own
publishers have matched its subscriptions, so the bag holds every sample (topics are volatile:
a message published before a subscriber matched is never delivered to it).

The lockstep messages travel as serialised bytes (rotor_avc.nodes.messages: raw publishers and
subscriptions, the same messages on the wire); a malformed answer is ignored and reported as a
fault.

Every node reports its loop timing and faults on ``/diagnostics`` once per second (wall clock).
With ``result_path`` set, the run's time series is saved there at the end (``.npz``, the format
of rotor_avc.sim.timeseries, or ``.mcap`` in the bag format).
"""
from __future__ import annotations

import math
import time

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from ..errors import RotorAvcError
from ..sim.loop import forces_from_answers, start, timeseries_from_run
from . import messages as m
from .lockstep import POLICIES, AnswerBook
from .runtime import COMMON_PARAMS, Param, declare_parameters, node_scenario, run_node
from .timing import LoopTiming

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config (path or shipped name): machine, controllers, "
          "simulation section"),
    Param("mode", "lockstep", "lockstep: step when every controller answered; realtime: step on "
          "the wall clock with the latest forces", choices=("lockstep", "realtime")),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine (/<namespace>/foot/...)"),
    Param("duration_s", 0.0, "simulated time in s; 0 = the scenario's duration", minimum=0.0),
    Param("controller_timeout_s", 1.0, "wall time without an answer before a controller is "
          "declared absent (then the fault policy applies)", minimum=1e-3, maximum=3600.0),
    Param("resend_after_s", 0.25, "lockstep: wall time after which an unanswered sample is "
          "published again", minimum=1e-3, maximum=3600.0),
    Param("fault_policy", "hold", "force of an absent controller: hold its last force or zero",
          choices=POLICIES),
    Param("discovery_timeout_s", 30.0, "wall time to wait for every controller (and the awaited "
          "recorder) to connect",
          minimum=0.0, maximum=3600.0),
    Param("balancer", False, "lockstep: also wait for the balancer's command at every sample"),
    Param("harmonic", False, "lockstep: also wait for the harmonic controller's forces "
          "(harmonic/forces, added to the feedback forces) at every sample"),
    Param("result_path", "", "save the run's time series here at the end (.npz or .mcap)"),
    Param("exit_when_done", True, "end the node when the run is complete"),
    Param("wait_for_recorder", "", "name of a recorder node that must subscribe to every topic "
          "of the run (the plant's, the controllers' forces, the balancer's) before sample 0, "
          "so the bag misses nothing; empty: do not wait"),
)


class PlantSimulator(Node):
    """The plant node (see the module docstring)."""

    def __init__(self, name: str = "plant_simulator", **kwargs):
        super().__init__(name, **kwargs)
        self.p = declare_parameters(self, PARAMS)
        self.executor_kind = self.p["executor"]
        self.scenario = node_scenario(self, self.p["scenario"], "a scenario config")
        sc = self.scenario
        self.T = sc.sample_period_s
        self.n_steps = (max(1, int(round(self.p["duration_s"] / self.T))) if self.p["duration_s"]
                        else sc.n_steps)
        self.stepper = sc.stepper()
        plant = self.stepper.plant
        self.axis = {a.id: a.axis for a in plant.actuators}
        self.feedback = {foot: ctrl.feedback for foot, ctrl in sc.machine.controllers.items()}
        # actuators whose force the plant waits for: feedback controllers and the feed-forward
        # node's (synchronous_controller, seed 002), which answers rotor/joint_state
        ff = sc.feedforward_actuators()
        self.driven = tuple(self.feedback) + tuple(ff)
        ns = self.p["namespace"]
        lay = self.stepper.layout
        # foot measurements: acceleration of every actuated foot, plus each controller's signal
        self.meas = []                       # (publisher, reusable message, index in y)
        for act in plant.actuators:
            kinds = {"acceleration", self.feedback.get(act.id, "acceleration")}
            for kind in sorted(kinds):
                self.meas.append((self.create_publisher(m.MEASUREMENT_TYPES[kind],
                                                        m.foot_topic(act.id, kind, ns),
                                                        m.LOCKSTEP_QOS),
                                  m.Measurement(kind, act.id, act.axis),
                                  lay.feedback_index(act.id, kind)))
        self.rotor = m.RotorBytes()           # joint_state, clock, observables: raw as self.meas
        self.pub_joint = self.create_publisher(JointState, m.topic("rotor/joint_state", ns),
                                               m.LOCKSTEP_QOS)
        self.pub_clock = self.create_publisher(Clock, "/clock", m.LOCKSTEP_QOS)
        self.observables = m.LabelledBytes(lay.names)
        self.pub_obs = self.create_publisher(Float64MultiArray, m.topic("plant/observables", ns),
                                             m.LOCKSTEP_QOS)
        self.pub_diag = self.create_publisher(type(m.diagnostics(0, [])), "/diagnostics", 10)
        responders = (self.driven + (("balancer",) if self.p["balancer"] else ())
                      + (("harmonic",) if self.p["harmonic"] else ()))
        self._setup_harmonic(sc, ns)
        ids = [a.id for a in plant.actuators]
        self._fed = {ids.index(a) for a in self.driven}
        self.book = AnswerBook(responders, self.p["fault_policy"], self.p["controller_timeout_s"],
                               self.p["resend_after_s"])
        for foot in self.driven:
            self.create_subscription(WrenchStamped, m.foot_topic(foot, "actuator_force", ns),
                                     lambda data, f=foot: self._on_force(f, data), m.LOCKSTEP_QOS,
                                     raw=True)
        command = ["time_s"] + [f"{e.name}_{part}" for e in plant.excitations
                                for part in ("re", "im")]
        self.command_label, self.command_size = ",".join(command), len(command)
        if self.p["balancer"]:
            self.create_subscription(Float64MultiArray, m.topic("balancer/command", ns),
                                     self._on_balancer, m.LOCKSTEP_QOS, raw=True)
        self.last_force_time = {foot: None for foot in self.driven}
        self.timing = LoopTiming(self.T if self.p["mode"] == "realtime" else None)
        self.Y = np.empty((self.n_steps, len(lay.names)))
        self.U = np.empty((self.n_steps, self.stepper.n_inputs))
        self.C = (np.zeros((self.n_steps, len(plant.excitations)), complex)
                  if self.p["balancer"] else None)
        self.applied = None                   # the balancer's answer applied last (raw values)
        self.correction = None                # and the stepper's correction since (C's row)
        self.k = 0
        self.y = None
        self.started = False
        self.finished = False
        self.exit_requested = False
        self.t_created = time.monotonic()
        self.fault_log: list[str] = []
        self.create_timer(0.01, self._tick_waiting)
        self.create_timer(1.0, self._publish_diagnostics)
        if self.p["mode"] == "realtime":
            self.create_timer(self.T, self._tick_realtime)

    def _setup_harmonic(self, sc, ns: str) -> None:
        """``harmonic: true``: the harmonic controller's forces (added to the others)."""
        self.harmonic_at = []
        if not self.p["harmonic"]:
            return
        if self.p["mode"] == "realtime":
            raise RotorAvcError(f"{self.get_name()}: harmonic: true runs in lockstep only "
                                "-- fix: use mode lockstep")
        from ..harmonic.config import harmonic_actuators
        from .harmonic_controller import force_names
        acts = harmonic_actuators(sc.machine)
        ids = [a.id for a in self.stepper.plant.actuators]
        self.harmonic_at = [ids.index(a) for a in acts]
        self.harmonic_label = ",".join(["time_s"] + force_names(self.stepper.plant, acts))
        self.create_subscription(Float64MultiArray, m.topic("harmonic/forces", ns),
                                 self._on_harmonic, m.LOCKSTEP_QOS, raw=True)

    def _on_harmonic(self, data: bytes) -> None:
        try:
            label, values = m.labelled_array(data)
            if label != self.harmonic_label or not all(map(math.isfinite, values)):
                raise m.MessageError(f"labelled {label!r} (expected {self.harmonic_label!r}) "
                                     "or not finite")
            stamp = m.received_time_ns(values[0])
        except m.MessageError as exc:
            self._fault(f"harmonic forces ignored: {exc}")
            return
        if self.started and not self.finished and self.book.receive("harmonic", stamp,
                                                                    values[1:]):
            self._advance()

    # -- start ----------------------------------------------------------------------------------
    def _connected(self) -> bool:
        ns = self.p["namespace"]
        for pub, msg, idx in self.meas:       # each controller's own signal must be heard
            if self.feedback.get(msg.foot_id) == msg.kind and pub.get_subscription_count() < 1:
                return False
        for foot in self.driven:
            if self.count_publishers(m.foot_topic(foot, "actuator_force", ns)) < 1:
                return False
        if self.p["balancer"] and self.count_publishers(m.topic("balancer/command", ns)) < 1:
            return False
        if len(self.driven) > len(self.feedback) and self.pub_joint.get_subscription_count() < 1:
            return False                       # the feed-forward node answers joint_state
        if self.p["harmonic"] and (self.count_publishers(m.topic("harmonic/forces", ns)) < 1
                                   or self.pub_obs.get_subscription_count() < 1
                                   or self.pub_joint.get_subscription_count() < 1):
            return False
        return not self._unrecorded()

    def _unrecorded(self) -> list[str]:
        """Topics of the run the ``wait_for_recorder`` node does not receive yet: it has no
        subscription on them, or (the plant's own topics) a listed subscription is not matched
        to the plant's publisher yet. Empty when no recorder is awaited."""
        name = self.p["wait_for_recorder"]
        if not name:
            return []
        ns = self.p["namespace"]
        own = [pub for pub, _, _ in self.meas] + [self.pub_joint, self.pub_clock, self.pub_obs]
        others = [m.foot_topic(foot, "actuator_force", ns) for foot in self.driven]
        if self.p["balancer"]:
            others += [m.topic("balancer/command", ns), m.topic("balancer/estimate", ns)]
        missing = []
        for topic, pub in [(p.topic_name, p) for p in own] + [(t, None) for t in others]:
            infos = self.get_subscriptions_info_by_topic(topic)
            names = {i.node_name for i in infos} | {
                i.node_namespace.rstrip("/") + "/" + i.node_name for i in infos}
            if name not in names or (pub is not None and pub.get_subscription_count() < len(infos)):
                missing.append(topic)
        return missing

    def _start(self) -> None:
        sc = self.scenario
        # the periodic steady state depends on the controllers: the plant builds its own copies
        # of them for that computation only (the controller nodes compute the same)
        self.y = start(self.stepper, sc.controllers(), sc.initial_state)
        self.correction = list(self.stepper.correction.values())
        self.started = True
        self.t_start = time.monotonic()
        self._publish_sample()

    # -- lockstep -------------------------------------------------------------------------------
    def _publish_sample(self, begin: bool = True) -> None:
        """Publish sample k (again, with ``begin=False``: a resend of the same stamp). In
        lockstep this is the timed loop iteration; real time times its whole tick."""
        timed = begin and self.p["mode"] == "lockstep"
        if timed:
            self.timing.start()
        k, y = self.k, self.y
        t_ns = m.sample_ns(k, self.T)
        for pub, msg, idx in self.meas:
            pub.publish(msg.fill(t_ns, y.item(idx)))
        speed, _, angle = self.stepper.speed_state()
        joint, clock = self.rotor.fill(t_ns, angle, speed)
        self.pub_joint.publish(joint)
        self.pub_clock.publish(clock)
        self.pub_obs.publish(self.observables.fill(k * self.T, y))
        if begin:
            self.book.begin(t_ns, time.monotonic())
        if timed:
            self.timing.stop()

    def _on_force(self, foot: str, data: bytes) -> None:
        try:
            stamp, value = m.stamped_value(data, self.axis[foot])   # raw: messages.StampedVector
        except ValueError as exc:
            self._fault(f"{foot}: actuator force ignored: {exc}")
            return
        self.last_force_time[foot] = time.monotonic()
        if self.p["mode"] == "realtime":
            if not self.book.responders[foot].present:
                self.book.responders[foot].present = True
            self.book.responders[foot].last_value = value
            return
        if self.started and not self.finished and self.book.receive(foot, stamp, value):
            self._advance()

    def _on_balancer(self, data: bytes) -> None:
        """The balancer's answer: ``(re, im)`` per excitation after ``time_s`` (raw, see
        messages.labelled_array); applied as a correction in :meth:`_advance`."""
        try:
            label, values = m.labelled_array(data)
            if label != self.command_label or len(values) != self.command_size:
                raise m.MessageError(f"labelled {label!r} with {len(values)} values, not "
                                     f"{self.command_label!r}")
            if not all(map(math.isfinite, values)):
                raise m.MessageError(f"{values} is not finite")
            stamp = m.received_time_ns(values[0])
        except m.MessageError as exc:
            self._fault(f"balancer command ignored: {exc}")
            return
        if (self.started and not self.finished
                and self.book.receive("balancer", stamp, values[1:])):
            self._advance()

    def _forces(self) -> np.ndarray:
        u = forces_from_answers(self.stepper, {foot: self.book.value(foot, 0.0)
                                               for foot in self.driven})
        if self.harmonic_at:               # as rotor_avc.sim.loop.harmonic_forces adds them
            for pos, f in zip(self.harmonic_at, self.book.value("harmonic", None) or
                              [0.0] * len(self.harmonic_at)):
                u[pos] = u[pos] + f if pos in self._fed else f
        return u

    def _advance(self) -> None:
        """All answers of sample k are in: record, hold u_k, step to k+1, publish it."""
        u = self._forces()
        if self.C is not None:
            values = self.book.value("balancer", None)
            if values is not None and values != self.applied:     # unchanged: nothing to set
                self.stepper.set_correction({e.name: complex(values[2 * j], values[2 * j + 1])
                                             for j, e in enumerate(self.stepper.plant.excitations)})
                self.applied = values
                self.correction = list(self.stepper.correction.values())
            self.C[self.k] = self.correction
        self.Y[self.k] = self.y
        self.U[self.k] = u
        self.y = self.stepper.step(u)
        self.k += 1
        if self.k >= self.n_steps:
            self._finish()
            return
        self._publish_sample()

    def _tick_waiting(self) -> None:
        if self.finished:
            return
        now = time.monotonic()
        if not self.started:
            if self._connected():
                self._start()
            elif now - self.t_created > self.p["discovery_timeout_s"]:
                missing = [f for f in self.driven if self.count_publishers(
                    m.foot_topic(f, "actuator_force", self.p["namespace"])) < 1]
                unrecorded = self._unrecorded()
                if missing or not unrecorded:
                    self._fault(f"controllers did not connect within "
                                f"{self.p['discovery_timeout_s']:g} s: {missing}; starting with "
                                "the fault policy for them")
                if unrecorded:
                    self._fault(f"recorder {self.p['wait_for_recorder']!r} did not subscribe "
                                f"within {self.p['discovery_timeout_s']:g} s to {unrecorded}; "
                                "starting without recording them")
                self._start()
            return
        if self.p["mode"] == "realtime":
            return
        resend, absent = self.book.poll(now)
        for name in absent:
            self._fault(f"{name}: {self.book.responders[name].fault_reason}")
        if resend:
            self._publish_sample(begin=False)
        # with responders absent the plant no longer waits for them: advance a batch per tick
        for _ in range(64):
            if self.finished or not self.book.ready():
                break
            self._advance()

    # -- real time ------------------------------------------------------------------------------
    def _tick_realtime(self) -> None:
        if not self.started or self.finished:
            return
        now = time.monotonic()
        for foot, t_last in self.last_force_time.items():
            r = self.book.responders[foot]
            if r.present and (t_last is None and now - self.t_start > self.p["controller_timeout_s"]
                              or t_last is not None and now - t_last > self.p["controller_timeout_s"]):
                r.present = False
                r.faults += 1
                r.fault_reason = f"silent for more than {self.p['controller_timeout_s']:g} s"
                self._fault(f"{foot}: {r.fault_reason}; policy: {self.book.policy}")
        u = forces_from_answers(self.stepper, {f: self._latest_force(f) for f in self.driven})
        self.timing.start()
        self._publish_sample()
        self.Y[self.k] = self.y
        self.U[self.k] = u
        self.y = self.stepper.step(u)
        self.k += 1
        self.timing.stop()
        if self.k >= self.n_steps:
            self._finish()

    def _latest_force(self, foot: str) -> float:
        """Real time: the latest force a present controller sent; the policy for an absent one."""
        r = self.book.responders[foot]
        if r.last_value is None or (not r.present and self.book.policy == "zero"):
            return 0.0
        return r.last_value

    # -- end, faults, diagnostics ---------------------------------------------------------------
    def _fault(self, text: str) -> None:
        self.fault_log.append(text)
        self.get_logger().warning(text)
        self._publish_diagnostics()

    def _finish(self) -> None:
        self.finished = True
        self.wall_s = time.monotonic() - self.t_start
        self._publish_diagnostics()
        if self.p["result_path"]:
            self.result().save(self.p["result_path"])
        self.exit_requested = self.p["exit_when_done"]

    def result(self):
        """The run so far as a :class:`rotor_avc.sim.timeseries.TimeSeries`."""
        sc = self.scenario
        meta = {"scenario": sc.machine.config.source, "config": sc.machine.config.data,
                "mode": self.p["mode"], "faults": self.fault_log}
        C = self.C[:self.k] if self.C is not None else None
        return timeseries_from_run(self.stepper, self.Y[:self.k], self.U[:self.k], C, meta,
                                   sc.initial_state, sc.machine.controllers)

    def _publish_diagnostics(self) -> None:
        stats = self.timing.summary()
        stats.update({"sample": self.k, "samples_total": self.n_steps,
                      "resends": self.book.resends})
        level, text = "ok", "running" if self.started else "waiting for controllers"
        absent = self.book.absent()
        if absent:
            level = "error"
            text = "; ".join(f"{a}: {self.book.responders[a].fault_reason}" for a in absent)
        elif self.fault_log:
            level, text = "warn", self.fault_log[-1]
        if self.finished and not absent:
            text = "run complete" + (f" ({len(self.fault_log)} faults)" if self.fault_log else "")
        per = [(f"{self.get_name()}: {name}", "error" if not r.present else "ok",
                r.fault_reason or "answering", {"faults": r.faults})
               for name, r in self.book.responders.items()]
        self.pub_diag.publish(m.diagnostics(m.sample_ns(self.k, self.T),
                                            [(f"{self.get_name()}: loop", level, text, stats)] + per))


def main(args=None) -> int:
    return run_node(PlantSimulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
