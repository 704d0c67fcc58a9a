"""The plant's side of the lockstep protocol, free of ROS (DESIGN.md section 4).

The plant publishes sample ``k`` stamped ``t_k`` and steps only when every configured responder
(each foot controller, the balancer when present) has answered ``t_k``. :class:`AnswerBook`
keeps that bookkeeping and the fault policy:

* an answer stamped ``t_k`` counts for sample ``k``; answers for other stamps are ignored
  (a late answer only tells that its sender is alive again);
* no answer within ``resend_after_s`` (wall clock) -> the plant publishes sample ``k`` again
  (a message lost while the graph was still connecting); responders answer a repeated stamp from
  their cache without stepping twice;
* policy ``wait`` (the default): the plant waits for every answer however long it takes
  (:meth:`AnswerBook.waiting` says for whom and how long; the plant reports it and ends the run
  only when a responder has left the graph);
* policies ``hold`` and ``zero`` (fault studies): no answer within ``timeout_s`` -> the
  responder is marked absent: its force follows the policy (``hold`` the last force it sent, or
  ``zero``), the plant no longer waits for it, and the fault is reported; the first answer it
  sends again (for any stamp) marks it present, and from the next sample on the plant waits for
  it again.

Either way the book counts what makes a run depart from lockstep
(rotor_avc.bag.lockstep): the samples at which the policy stood in for an answer
(:meth:`AnswerBook.settle`, ``substituted``) and the samples a responder answered again with a
different value (``changed``: the current sample, or the previous one after it was stepped).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..bag.lockstep import SampleRanges

#: ``wait``: lockstep whatever it takes; ``hold``, ``zero``: step on without an answer (faults)
POLICIES = ("wait", "hold", "zero")


@dataclass
class Responder:
    """Bookkeeping of one responder (a foot controller or the balancer)."""

    name: str
    present: bool = True
    last_value: object = None
    answer: object = None               # value answered for the current stamp
    faults: int = 0                     # times it was declared absent
    fault_reason: str = ""
    substituted: int = 0                # samples stepped without its answer
    changed: int = 0                    # answers that differed from its first to that sample


@dataclass
class AnswerBook:
    """Which responders answered the current sample; what to use for those that did not."""

    names: tuple[str, ...]
    policy: str = "wait"
    timeout_s: float = 1.0
    resend_after_s: float = 0.25
    responders: dict[str, Responder] = field(default_factory=dict)
    stamp_ns: int = -1
    started_s: float = 0.0
    last_send_s: float = 0.0
    resends: int = 0
    sample: int = -1                    # index of the current sample
    substituted: SampleRanges = field(default_factory=SampleRanges)
    changed: SampleRanges = field(default_factory=SampleRanges)
    previous: dict = field(default_factory=dict)     # answers the previous sample stepped with
    previous_stamp_ns: int = -1

    def __post_init__(self):
        if self.policy not in POLICIES:
            raise ValueError(f"unknown fault policy {self.policy!r}; use one of {POLICIES}")
        self.responders = {n: Responder(n) for n in self.names}

    def begin(self, stamp_ns: int, now_s: float, sample: int | None = None) -> None:
        """A new sample (index ``sample``, default: the next) was published."""
        self.previous = {r.name: r.answer for r in self.responders.values()}
        self.previous_stamp_ns = self.stamp_ns
        self.stamp_ns = stamp_ns
        self.sample = self.sample + 1 if sample is None else sample
        self.started_s = self.last_send_s = now_s
        for r in self.responders.values():
            r.answer = None

    def receive(self, name: str, stamp_ns: int, value) -> bool:
        """Record an answer; True when it completes the current sample."""
        r = self.responders.get(name)
        if r is None:
            return False
        if not r.present:
            r.present = True            # alive again: wait for it from the next sample on
            r.fault_reason = f"returned after fault (answer stamped {stamp_ns} ns)"
            if stamp_ns != self.stamp_ns:
                return False
        if stamp_ns == self.previous_stamp_ns and self.previous.get(name) is not None:
            if value != self.previous[name]:          # a sample already stepped, answered anew
                r.changed += 1
                self.changed.add(self.sample - 1)
            return False
        if stamp_ns != self.stamp_ns:
            return False
        if r.answer is not None and value != r.answer:
            r.changed += 1
            self.changed.add(self.sample)
            return False                                  # the first answer stands
        r.answer = value
        r.last_value = value
        return self.ready()

    def ready(self) -> bool:
        return all(r.answer is not None for r in self.responders.values() if r.present)

    def poll(self, now_s: float) -> tuple[bool, list[str]]:
        """``(resend, newly_absent)`` at wall time ``now_s`` while waiting for the sample
        (policy ``wait``: nobody becomes absent)."""
        newly_absent = []
        for r in self.responders.values():
            if (self.policy != "wait" and r.present and r.answer is None
                    and now_s - self.started_s >= self.timeout_s):
                r.present = False
                r.faults += 1
                r.fault_reason = (f"no answer within {self.timeout_s:g} s (sample stamped "
                                  f"{self.stamp_ns} ns); policy: {self.policy}")
                newly_absent.append(r.name)
        resend = (not newly_absent and not self.ready()
                  and now_s - self.last_send_s >= self.resend_after_s)
        if resend:
            self.last_send_s = now_s
            self.resends += 1
        return resend, newly_absent

    def waiting(self, now_s: float) -> tuple[list[str], float]:
        """The present responders that have not answered the current sample, and the wall time
        waited for it so far."""
        return ([r.name for r in self.responders.values() if r.present and r.answer is None],
                now_s - self.started_s)

    def settle(self) -> list[str]:
        """The sample is stepped now: the responders whose answer the policy stands in for
        (counted, with the sample, in ``substituted``)."""
        missing = [r.name for r in self.responders.values() if r.answer is None]
        for name in missing:
            self.responders[name].substituted += 1
        if missing:
            self.substituted.add(self.sample)
        return missing

    def value(self, name: str, zero):
        """The answer of ``name`` for this sample, or the policy's substitute."""
        r = self.responders[name]
        if r.answer is not None:
            return r.answer
        if self.policy == "hold" and r.last_value is not None:
            return r.last_value
        return zero

    def absent(self) -> list[str]:
        return [r.name for r in self.responders.values() if not r.present]

    def reason(self, name: str) -> str:
        """Why ``name`` was last declared absent or returned ("" when it never was)."""
        return self.responders[name].fault_reason

    def statuses(self) -> list[tuple[str, bool, str, int]]:
        """Per responder ``(name, present, reason, faults)``, for diagnostics."""
        return [(r.name, r.present, r.fault_reason, r.faults) for r in self.responders.values()]

    # -- real time: no samples to answer, the latest answer holds ------------------------------
    def latest(self, name: str, value) -> None:
        """Real time: ``name`` sent ``value`` (it is present from now on)."""
        r = self.responders[name]
        r.present = True
        r.last_value = value

    def expire(self, name: str, silent_s: float) -> bool:
        """Real time: ``name`` has been silent for ``silent_s``; True when that makes it absent
        (longer than ``timeout_s``, while it was present)."""
        r = self.responders[name]
        if not r.present or silent_s <= self.timeout_s:
            return False
        r.present = False
        r.faults += 1
        r.fault_reason = f"silent for more than {self.timeout_s:g} s; policy: {self.policy}"
        return True

    def held(self, name: str, zero):
        """Real time: the latest answer of a present responder, the policy's for an absent one."""
        r = self.responders[name]
        if r.last_value is None or (not r.present and self.policy == "zero"):
            return zero
        return r.last_value
