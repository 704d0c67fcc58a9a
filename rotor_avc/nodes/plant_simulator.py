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
  (:class:`rotor_avc.nodes.lockstep.AnswerBook`: resend, timeout, fault policy). With
  ``fault_policy: wait`` (the default) it waits however long an answer takes, saying for whom,
  at which sample and how long in its log and on ``/diagnostics`` (rotor_avc.nodes.plant_watch);
  a responder that has left the graph ends the run (exit status 5), one that never connected
  within ``discovery_timeout_s`` keeps it from starting (exit status 5). ``hold`` and ``zero``
  step on without an absent responder (fault studies): such a run, or one in which an answer
  changed after it was given, is not lockstep -- said in the log, on ``/diagnostics`` (status
  ``<plant>: lockstep``, which the recorder writes into the bag: rotor_avc.bag.lockstep) and by
  exit status 4.
* **one plant per namespace**: a plant that finds another node publishing its sampled topics
  while it starts does not start (one error line, exit status 6:
  rotor_avc.nodes.namespace_guard).
* **realtime**: steps on a wall-clock timer at the sample period with the latest forces received;
  a controller silent for longer than ``controller_timeout_s`` gets the fault policy.

Recording: with ``wait_for_recorder: <node name>`` the plant publishes sample 0 only when that
recorder (rotor_avc.nodes.recorder) records every topic of the run -- it subscribes to them and
the plant's own publishers have matched its subscriptions, or, composed into this process, it
taps their publishers -- so the bag holds every sample (topics are volatile: a message published
before a subscriber matched is never delivered to it). In lockstep the recording is then part of
the handshake: the plant never runs more than ``recorder_window`` samples ahead of the messages
the recorder reports as taken (``recorder/progress``), which is less than the publishers'
history (messages.LOCKSTEP_DEPTH), so no message can be overwritten before the recorder has it;
at the end the plant waits until the recorder has taken the last sample. A recorder that
disappears, or takes nothing for ``recorder_timeout_s``, ends the run with exit status 1 and a
message saying which sample the bag stops at.

Real time: sample ``k`` is due at ``t_0 + k T`` on the wall clock (an absolute schedule: no
drift however late single ticks are; a late sample is taken at once and the next ones catch up,
none is skipped). After the first ``RATE_CHECK_S`` of the run the plant checks that it holds
the rate (at most ``RATE_CHECK_OVERRUNS`` of the samples more than a period late); if not, it
says so with the numbers on ``/diagnostics`` and in the log and goes on, or, with
``realtime_overload: abort``, ends the run (exit status 3). Lateness percentiles and overruns
are on ``/diagnostics`` and in the final log line.

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

from ..bag.array_labels import TIME_LABEL, balancer_labels, harmonic_force_labels
from ..block_kinds import KINDS
from ..errors import RotorAvcError
from ..sim.loop import check_run_memory, forces_from_answers, start, timeseries_from_run
from . import messages as m
from . import taps
from .lockstep import AnswerBook
from .namespace_guard import GraphStillness
from .plant_params import PARAMS
from .plant_realtime import RealtimeMixin
from .plant_startup import PlantStartupMixin
from .plant_recorder_window import RecorderWindowMixin
from .plant_watch import PlantWatchMixin
from .runtime import check_node_design, declare_parameters, node_scenario, run_node
from .timing import LoopTiming, Schedule

class PlantSimulator(PlantStartupMixin, PlantWatchMixin, RecorderWindowMixin, RealtimeMixin,
                     Node):
    """The plant node (see the module docstring)."""

    def __init__(self, name: str = "plant_simulator", **kwargs):
        super().__init__(name, **kwargs)
        self.p = declare_parameters(self, PARAMS)
        self.executor_kind = self.p["executor"]
        self.scenario = node_scenario(self, self.p["scenario"], "a scenario config")
        check_node_design(self, self.scenario)
        sc = self.scenario
        self.T = sc.sample_period_s
        self.n_steps = (max(1, int(round(self.p["duration_s"] / self.T))) if self.p["duration_s"]
                        else sc.n_steps)
        self.stepper = sc.stepper()
        plant = self.stepper.plant
        self.axis = {a.id: a.axis for a in plant.actuators}
        self.feedback = {a: ctrl.feedback for a, ctrl in sc.machine.controllers.items()}
        # actuators whose force the plant waits for: feedback controllers and the feed-forward
        # node's (synchronous_controller, Sci. Rep. 2023), which answers rotor/joint_state
        ff = sc.feedforward_actuators()
        self.driven = tuple(self.feedback) + tuple(ff)
        ns = self.p["namespace"]
        lay = self.stepper.layout
        # actuator signals: the acceleration at every actuator, plus each controller's signal
        self.meas = []                       # (publisher, reusable message, index in y)
        for act in plant.actuators:
            kinds = {"acceleration", self.feedback.get(act.id, "acceleration")}
            for kind in sorted(kinds):
                self.meas.append((taps.publisher(self, m.MEASUREMENT_TYPES[kind],
                                                        m.actuator_topic(act.id, kind, ns),
                                                        m.LOCKSTEP_QOS),
                                  m.Measurement(kind, act.id, act.axis),
                                  lay.feedback_index(act.id, kind)))
        self.rotor = m.RotorBytes()           # joint_state, clock, observables: raw as self.meas
        self.pub_joint = taps.publisher(self, JointState, m.topic("rotor/joint_state", ns),
                                               m.LOCKSTEP_QOS)
        self.pub_clock = taps.publisher(self, Clock, "/clock", m.LOCKSTEP_QOS)
        self.observables = m.LabelledBytes(lay.names)
        self.pub_obs = taps.publisher(self, Float64MultiArray, m.topic("plant/observables", ns),
                                             m.LOCKSTEP_QOS)
        self.pub_diag = taps.publisher(self, m.DiagnosticArray, "/diagnostics", m.DIAGNOSTICS_QOS)
        # the machine-wide kinds this plant waits for (plant parameters harmonic, balancer)
        self.waited_kinds = tuple(k for k in KINDS if k.plant_flag and self.p[k.plant_flag])
        responders = self.driven + tuple(k.name for k in self.waited_kinds)
        self._setup_harmonic(sc, ns)
        ids = [a.id for a in plant.actuators]
        self._fed = {ids.index(a) for a in self.driven}
        self.book = AnswerBook(responders, self.p["fault_policy"], self.p["controller_timeout_s"],
                               self.p["resend_after_s"])
        self.force_topics = {a: m.actuator_topic(a, "actuator_force", ns) for a in self.driven}
        self.command_topic = m.topic("balancer/command", ns)
        for actuator in self.driven:
            self.create_subscription(WrenchStamped, self.force_topics[actuator],
                                     lambda data, a=actuator: self._on_force(a, data),
                                     m.LOCKSTEP_QOS, raw=True)
        command = [TIME_LABEL] + balancer_labels([e.name for e in plant.excitations])
        self.command_label, self.command_size = ",".join(command), len(command)
        if self.p["balancer"]:
            self.create_subscription(Float64MultiArray, m.topic("balancer/command", ns),
                                     self._on_balancer, m.LOCKSTEP_QOS, raw=True)
        # the recorder handshake: what it has taken, against what the run has sent
        self.progress_topic = m.topic(m.RECORDER_PROGRESS, ns)
        self.recorder_taken: dict[str, int] = {}
        self.received = {topic: 0 for topic in self.force_topics.values()}
        self.received.update({m.topic(k.answer_topic, ns): 0 for k in self.waited_kinds})
        self.allowance = self.p["recorder_window"]
        self.stalled_since = None            # wall time the plant began waiting for the recorder
        self.recorder_lagging = False        # lockstep: a sample is held back for the recorder
        self.draining = False                # the run is complete; the recorder takes the rest
        self.exit_status = 0
        if self.p["wait_for_recorder"]:
            self.create_subscription(Float64MultiArray, self.progress_topic, self._on_progress,
                                     m.LOCKSTEP_QOS, raw=True)
        self.last_force_time = {actuator: None for actuator in self.driven}
        self.timing = LoopTiming(self.T if self.p["mode"] == "realtime" else None)
        self.schedule = Schedule(self.T)
        check_run_memory(self.stepper, self.n_steps, self.p["balancer"])
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
        self.waiting_text = ""
        self.stillness = GraphStillness()     # every responder seen, the namespace unchanged
        self.stray_answers, self.stray_since_s, self.stray_last_s = 0, None, None
        self._init_watch()
        self.create_timer(0.01, self._tick_waiting)
        self.create_timer(1.0, self._publish_diagnostics)
        if self.p["mode"] == "realtime":
            self.create_timer(min(self.T, 1e-3), self._tick_realtime)

    def _setup_harmonic(self, sc, ns: str) -> None:
        """``harmonic: true``: the harmonic controller's forces (added to the others)."""
        self.harmonic_at = []
        self.harmonic_topic = m.topic("harmonic/forces", ns)
        if not self.p["harmonic"]:
            return
        if self.p["mode"] == "realtime":
            raise RotorAvcError(f"{self.get_name()}: harmonic: true runs in lockstep only "
                                "-- fix: use mode lockstep")
        from ..harmonic.config import harmonic_actuators
        acts = harmonic_actuators(sc.machine)
        ids = [a.id for a in self.stepper.plant.actuators]
        self.harmonic_at = [ids.index(a) for a in acts]
        self.harmonic_label = ",".join([TIME_LABEL] + harmonic_force_labels(
            [(a, self.stepper.plant.actuator(a).axis) for a in acts]))
        self.create_subscription(Float64MultiArray, self.harmonic_topic, self._on_harmonic,
                                 m.LOCKSTEP_QOS, raw=True)

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
        self.received[self.harmonic_topic] += 1
        if self.started and not self.finished and self.book.receive("harmonic", stamp,
                                                                    values[1:]):
            self._advance()

    # -- start ----------------------------------------------------------------------------------
    def _start(self) -> None:
        sc = self.scenario
        # the periodic steady state depends on the controllers: the plant builds its own copies
        # of them for that computation only (the controller nodes compute the same)
        self.y = start(self.stepper, sc.controllers(), sc.initial_state)
        self.correction = list(self.stepper.correction.values())
        self.started = True
        self.t_start = time.monotonic()
        self._note_answer_nodes()
        if self.p["mode"] == "realtime":
            self.schedule.begin(time.perf_counter())
            return                            # the real-time tick takes sample 0 when due
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
            self.book.begin(t_ns, time.monotonic(), k)
        if timed:
            self.timing.stop()

    def _on_force(self, actuator: str, data: bytes) -> None:
        try:
            stamp, value = m.stamped_value(data, self.axis[actuator])  # raw: m.StampedVector
        except ValueError as exc:
            self._fault(f"{actuator}: actuator force ignored: {exc}")
            return
        self.last_force_time[actuator] = time.monotonic()
        self.received[self.force_topics[actuator]] += 1
        if self.p["mode"] == "realtime":
            self.book.latest(actuator, value)
            return
        if self.started and not self.finished and self.book.receive(actuator, stamp, value):
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
        self.received[self.command_topic] += 1
        if (self.started and not self.finished
                and self.book.receive("balancer", stamp, values[1:])):
            self._advance()

    def _forces(self) -> np.ndarray:
        u = forces_from_answers(self.stepper, {actuator: self.book.value(actuator, 0.0)
                                               for actuator in self.driven})
        if self.harmonic_at:               # as rotor_avc.sim.loop.harmonic_forces adds them
            for pos, f in zip(self.harmonic_at, self.book.value("harmonic", None) or
                              [0.0] * len(self.harmonic_at)):
                u[pos] = u[pos] + f if pos in self._fed else f
        return u

    def _advance(self) -> None:
        """All answers of sample k are in (or, policy hold/zero, stood in for): record, hold
        u_k, step to k+1, publish it."""
        self.book.settle()
        self._waited()
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
        self.allowance -= 1                  # one more sample ahead of the recorder's progress
        if self._recorder_holds_back():
            return
        self._publish_sample()

    def _tick_waiting(self) -> None:
        if self.finished:
            return
        now = time.monotonic()
        if not self.started:
            self._tick_start(now)
            return
        if self.p["mode"] == "realtime":
            return
        if self.recorder_lagging or self.draining:
            self._check_recorder(now)
            return
        resend, absent = self.book.poll(now)
        for name in absent:
            self._fault(f"{name}: {self.book.reason(name)}")
        if self.p["fault_policy"] == "wait":
            self._watch_waiting(now)
            if self.finished:
                return
        if resend:
            self._publish_sample(begin=False)
        # with responders absent the plant no longer waits for them: advance a batch per tick
        for _ in range(64):
            if self.finished or self.recorder_lagging or self.draining or not self.book.ready():
                break
            self._advance()

    # -- end, faults, diagnostics ---------------------------------------------------------------
    def _fault(self, text: str) -> None:
        self.fault_log.append(text)
        self.get_logger().warning(text)
        self._publish_diagnostics()

    def _finish(self, complete: bool = True) -> None:
        """End of the run; a complete lockstep run with a recorder first waits until the
        recorder has taken every message of it (``draining``)."""
        if (complete and self.p["wait_for_recorder"] and self.p["mode"] == "lockstep"
                and not self.draining and self._recorder_lag() > 0):
            self.draining = True
            self.stalled_since = time.monotonic()
            return
        self.finished = True
        self.wall_s = time.monotonic() - self.t_start if self.started else 0.0
        if complete:
            self._judge_lockstep()
        sent = self._sent()
        state = ("ENDED EARLY" if not complete else
                 "complete, NOT LOCKSTEP" if self.exit_status else "complete")
        self.get_logger().info(
            f"run {state}: {self.k} of {self.n_steps} samples "
            f"in {self.wall_s:.2f} s ({self.k / max(self.wall_s, 1e-9):.0f} samples/s); published "
            + ", ".join(f"{t} {n}" for t, n in sorted(sent.items())
                        if t not in self.received)
            + ("; the recorder took every message" if self.p["wait_for_recorder"]
               and complete and self.p["mode"] == "lockstep" else ""))
        if self.p["mode"] == "realtime":
            st = self.schedule.summary()
            if st.get("samples"):
                self.get_logger().info(
                    f"real time {1 / self.T:g} Hz: mean period "
                    f"{1e6 * st.get('period_mean_s', 0):.3f} "
                    f"us ({100 * st.get('period_error', 0):+.3f} %), lateness p50 "
                    f"{1e6 * st['late_p50_s']:.0f} / p99 {1e6 * st['late_p99_s']:.0f} / max "
                    f"{1e6 * st['late_max_s']:.0f} us, {st['overruns']} overruns "
                    f"({st['overruns_per_10k']:.0f} per 10,000 samples)")
        self._publish_diagnostics()
        if self.p["result_path"]:
            self.result().save(self.p["result_path"])
        self.exit_requested = self.p["exit_when_done"]

    def result(self):
        """The run so far as a :class:`rotor_avc.sim.timeseries.TimeSeries`."""
        sc = self.scenario
        meta = {"scenario": sc.machine.config.source, "config": sc.machine.config.data,
                "mode": self.p["mode"], "faults": self.fault_log,
                "lockstep": self.lockstep_record().encode()}
        C = self.C[:self.k] if self.C is not None else None
        return timeseries_from_run(self.stepper, self.Y[:self.k], self.U[:self.k], C, meta,
                                   sc.initial_state, sc.machine.controllers)

    def _publish_diagnostics(self) -> None:
        stats = self.timing.summary()
        stats.update({"sample": self.k, "samples_total": self.n_steps,
                      "resends": self.book.resends})
        if self.p["mode"] == "realtime":
            stats.update({f"schedule_{k}": v for k, v in self.schedule.summary().items()})
        level, text = "ok", "running" if self.started else "waiting for controllers"
        if self.recorder_lagging or self.draining:
            text = f"waiting for recorder {self.p['wait_for_recorder']!r}"
        elif self.waiting_text:
            level, text = "warn", self.waiting_text
        absent = self.book.absent()
        if absent:
            level = "error"
            text = "; ".join(f"{a}: {self.book.reason(a)}" for a in absent)
        elif self.fault_log:
            level, text = "warn", self.fault_log[-1]
        if self.finished and self.exit_status and self.k < self.n_steps:
            level, text = "error", "run ended early: " + (self.fault_log or [""])[-1]
        elif self.finished and not absent:
            text = "run complete" + (f" ({len(self.fault_log)} faults)" if self.fault_log else "")
            if self.exit_status:
                level, text = "error", f"{text}; {self.lockstep_record().verdict()}"
        per = [(f"{self.get_name()}: {name}", "ok" if present else "error",
                reason or "answering", {"faults": faults})
               for name, present, reason, faults in self.book.statuses()]
        lockstep = [self._lockstep_status()] if self.started else []
        self.pub_diag.publish(m.diagnostics(m.sample_ns(self.k, self.T), [
            (f"{self.get_name()}: loop", level, text, stats), *per, *lockstep,
            m.published_status(self)]))


def main(args=None) -> int:
    return run_node(PlantSimulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
