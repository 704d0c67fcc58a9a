"""The lockstep plant's watch over its responders: a sample that waits is said, a responder
that left the graph ends the run, another plant on the namespace is refused, and the run's
lockstep account (rotor_avc.bag.lockstep) is kept for /diagnostics, the bag and the exit status.
"""
from __future__ import annotations

import time

from ..bag.lockstep import LOCKSTEP_SUFFIX, LockstepRecord
from . import messages as m
from .namespace_guard import (DISCOVERY_SETTLE_S, EXIT_NAMESPACE_TAKEN, NamespaceGuard,
                              other_publishers)
from .plant_params import EXIT_NODE_LEFT, EXIT_NOT_LOCKSTEP, WAIT_REPORT_S


class PlantWatchMixin:
    """The responder watch of :class:`rotor_avc.nodes.plant_simulator.PlantSimulator`."""

    def _init_watch(self) -> None:
        self.plant_name = self.get_name()              # also once the node is destroyed
        self.answer_nodes: dict[str, list[str]] = {}   # responder -> nodes answering (at start)
        self.gone: dict[str, str] = {}                 # responder -> why it is missing
        self.wait_reported_s = None                    # wall time of the last wait report
        self.guard = NamespaceGuard(self, "publishes the plant's topics", self.p["namespace"])

    def _answer_topic(self, name: str) -> str:
        ns = self.p["namespace"]
        if name == "balancer":
            return self.command_topic
        if name == "harmonic":
            return self.harmonic_topic
        return m.actuator_topic(name, "actuator_force", ns)

    def _who(self, name: str) -> str:
        """``foot_controller_DL (DL)``: the nodes that answered for responder ``name``."""
        nodes = self.answer_nodes.get(name) or ["(no node seen)"]
        return f"{', '.join(nodes)} ({name})"

    def _note_answer_nodes(self) -> None:
        """At sample 0: which node answers for which responder (to name one that leaves)."""
        for name in self.book.names:
            self.answer_nodes[name] = sorted(
                f"{i.node_namespace.rstrip('/')}/{i.node_name}".lstrip("/")
                for i in self.get_publishers_info_by_topic(self._answer_topic(name)))

    # -- one plant per namespace ----------------------------------------------------------------
    def _sampled_topics(self) -> list[str]:
        return [pub.topic_name for pub, _, _ in self.meas] + [self.pub_joint.topic_name,
                                                               self.pub_obs.topic_name]

    def _namespace_taken(self, now: float) -> bool:
        """Another node publishes this plant's sampled topics, or another plant's answers
        arrive: do not start (True); refused once it is named (rotor_avc.nodes.namespace_guard)
        or the answers have flowed for ``discovery_timeout_s``."""
        if not (self.guard.taken(self._sampled_topics()) or self._driven_by_another(now)):
            return False
        if self.guard.refusal and not self.finished:
            self.fault_log.append(self.guard.refusal)
            self.finished = True
        return True

    def _driven_by_another(self, now: float) -> bool:
        """Answers keep arriving before sample 0: another plant (or a replay) drives the
        responders, discovered or not. Refused (exit status 6) once they have flowed for
        ``discovery_timeout_s`` without that plant being named; a burst that stops (the
        history of a finished run's answers) is no reason."""
        answers = sum(self.received.values())
        if answers != self.stray_answers:
            self.stray_answers, self.stray_last_s = answers, now
            self.stray_since_s = self.stray_since_s or now
        if self.stray_since_s is None:
            return False
        if now - self.stray_last_s > DISCOVERY_SETTLE_S:
            self.stray_since_s = None            # the flow stopped
            return False
        if now - self.stray_since_s >= self.p["discovery_timeout_s"]:
            nodes = sorted({f"{i.node_namespace.rstrip('/')}/{i.node_name}"
                            for t in self.received for i in self.get_publishers_info_by_topic(t)})
            self.guard.refuse(f"a plant not discovered yet (answers to samples this plant never "
                              f"sent keep arriving from {', '.join(nodes)})")
        return True

    # -- while a sample waits (fault_policy wait) -----------------------------------------------
    def _watch_waiting(self, now: float) -> None:
        """Say who the sample waits for (once per WAIT_REPORT_S after controller_timeout_s);
        end the run when one of them has left the graph."""
        names, waited = self.book.waiting(now)
        if not names or waited < self.p["resend_after_s"]:
            return
        left = [n for n in names if self.count_publishers(self._answer_topic(n)) < 1]
        if left:
            for n in left:
                self.gone[n] = f"left the graph at sample {self.k}"
            self._fault(f"{', '.join(self._who(n) for n in left)} left the graph: sample "
                        f"{self.k} of {self.n_steps} cannot be answered; ending the run (exit "
                        f"status {EXIT_NODE_LEFT})")
            self.exit_status = EXIT_NODE_LEFT
            self._finish(complete=False)
            return
        if waited < self.p["controller_timeout_s"]:
            return
        others = other_publishers(self, self._sampled_topics())
        if others:                         # discovered late: the answers are to its samples
            self._fault(f"{', '.join(others)} also publishes the plant's topics on namespace "
                        f"{self.p['namespace']!r}: its samples are answered, not this run's; "
                        f"ending the run (exit status {EXIT_NAMESPACE_TAKEN}) -- fix: one plant "
                        "per namespace")
            self.exit_status = EXIT_NAMESPACE_TAKEN
            self._finish(complete=False)
            return
        if self.wait_reported_s is None or now - self.wait_reported_s >= WAIT_REPORT_S:
            self.wait_reported_s = now
            self.waiting_text = (f"waiting {waited:.1f} s at sample {self.k} (t = "
                                 f"{self.k * self.T:.6g} s) for "
                                 + ", ".join(self._who(n) for n in names)
                                 + ": still in the graph, no answer yet (fault_policy wait)")
            self.get_logger().warning(self.waiting_text)
            self._publish_diagnostics()

    def _waited(self) -> None:
        """The sample that was reported waiting is answered: say so, once."""
        if self.wait_reported_s is not None:
            waited = time.monotonic() - self.book.started_s
            self.get_logger().info(f"sample {self.k} answered after {waited:.1f} s; "
                                   "the run goes on in lockstep")
            self.wait_reported_s = None
            self.waiting_text = ""

    # -- the account ----------------------------------------------------------------------------
    def lockstep_record(self) -> LockstepRecord:
        """What this run did to lockstep so far (rotor_avc.bag.lockstep)."""
        book = self.book
        absent = {self._who(r.name): f"was absent {r.faults} time(s), its answers stood in for "
                                     f"at {r.substituted} sample(s) (last: {r.fault_reason})"
                  for r in book.responders.values() if r.faults or r.substituted}
        absent.update({self._who(n): why for n, why in self.gone.items()})
        ended = ("" if not self.finished or self.k >= self.n_steps
                 else f"at sample {self.k} of {self.n_steps}: {self.fault_log[-1]}"
                 if self.fault_log else f"at sample {self.k} of {self.n_steps}")
        return LockstepRecord(self.plant_name, self.p["mode"], self.p["fault_policy"], self.k,
                              book.substituted.count, book.substituted.text, book.changed.count,
                              book.changed.text, absent, "", ended)

    def _lockstep_status(self) -> tuple:
        """The ``<plant>: lockstep`` diagnostic status (the recorder writes it into the bag)."""
        record = self.lockstep_record()
        return (f"{self.plant_name}{LOCKSTEP_SUFFIX}", "ok" if record.ok else "error",
                record.verdict(), record.encode())

    def _judge_lockstep(self) -> None:
        """At the end of a complete run: not lockstep -> said, exit status 4."""
        record = self.lockstep_record()
        if not record.ok and not self.exit_status:
            self.exit_status = EXIT_NOT_LOCKSTEP
            self.get_logger().error(f"{record.verdict()} (exit status {EXIT_NOT_LOCKSTEP})")
