"""The lockstep plant's start-up (a mixin of rotor_avc.nodes.plant_simulator.PlantSimulator):
sample 0 is published once every responder is connected (and the recorder records, with
``wait_for_recorder``) and the namespace's graph has held still for
:data:`~rotor_avc.nodes.namespace_guard.DISCOVERY_SETTLE_S`, so that another plant on the
namespace is seen first (rotor_avc.nodes.namespace_guard); responders or a recorder missing
after ``discovery_timeout_s`` are said, and end the run or start it with the fault policy."""
from __future__ import annotations

from ..block_kinds import FEEDFORWARD, JOINT_STATE, OBSERVABLES
from . import messages as m
from .plant_params import EXIT_NODE_LEFT, EXIT_RECORDER_LOST


class PlantStartupMixin:
    """Start-up of :class:`~rotor_avc.nodes.plant_simulator.PlantSimulator` (module docstring)."""

    def _graph_seen(self) -> tuple:
        """What discovery has shown of the sampled and answer topics so far (endpoint counts),
        and the answers received (before sample 0 only another plant's samples are answered)."""
        topics = [t for t, _ in self.get_topic_names_and_types()
                  if t.startswith(m.topic("", self.p["namespace"]))]
        return (tuple((t, self.count_publishers(t), self.count_subscribers(t))
                      for t in sorted(topics)), sum(self.received.values()))

    def _connected(self) -> bool:
        ns = self.p["namespace"]
        for pub, msg, idx in self.meas:       # each controller's own signal must be heard
            if self.feedback.get(msg.foot_id) == msg.kind and pub.get_subscription_count() < 1:
                return False
        for actuator in self.driven:
            if self.count_publishers(m.actuator_topic(actuator, "actuator_force", ns)) < 1:
                return False
        if any(self.count_publishers(m.topic(k.answer_topic, ns)) < 1 for k in self.waited_kinds):
            return False
        # the machine-wide kinds (and the feed-forward node) must hear the topics they answer
        feedforward = len(self.driven) > len(self.feedback)
        kinds = self.waited_kinds + ((FEEDFORWARD,) if feedforward else ())
        trigger = {JOINT_STATE: self.pub_joint, OBSERVABLES: self.pub_obs}
        if any(trigger[t].get_subscription_count() < 1 for k in kinds for t in k.triggers):
            return False
        return not self._unrecorded()

    def _tick_start(self, now: float) -> None:
        """One tick before sample 0 (the plant's waiting timer)."""
        if self._namespace_taken(now):
            return
        if self._connected():
            # discovery is asynchronous (and slow on a loaded host): the graph must hold
            # still for a moment -- no publisher or subscription of the namespace's sampled
            # topics appearing -- before sample 0, so that another plant on the namespace
            # is seen before this one steps (its answers keep it from holding still)
            if self.stillness.held(self._graph_seen(), now):
                self._start()
            return
        self.stillness.reset()
        if now - self.t_created > self.p["discovery_timeout_s"]:
            missing = [f for f in self.driven if self.count_publishers(
                m.actuator_topic(f, "actuator_force", self.p["namespace"])) < 1]
            unrecorded = self._unrecorded()
            if missing and self.p["fault_policy"] == "wait" and self.p["mode"] == "lockstep":
                for f in missing:
                    self.gone[f] = f"never connected (no publisher of {self._answer_topic(f)})"
                self._fault(f"controllers did not connect within "
                            f"{self.p['discovery_timeout_s']:g} s: {missing}; not starting the "
                            f"run (exit status {EXIT_NODE_LEFT}) -- fix: start them with the "
                            "same namespace and domain (fault_policy hold or zero runs "
                            "without them, as a fault study)")
                self.exit_status = EXIT_NODE_LEFT
                self._finish(complete=False)
                return
            if missing or not unrecorded:
                self._fault(f"controllers did not connect within "
                            f"{self.p['discovery_timeout_s']:g} s: {missing}; starting with "
                            "the fault policy for them")
            if unrecorded:
                self._fault(f"recorder {self.p['wait_for_recorder']!r} does not record "
                            f"{', '.join(unrecorded)} after {self.p['discovery_timeout_s']:g}"
                            " s; not starting the run (exit status 1) -- fix: start the "
                            "recorder first, with the same namespace and domain")
                self.exit_status = EXIT_RECORDER_LOST
                self._finish(complete=False)
                return
            self._start()
