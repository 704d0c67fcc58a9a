"""The lockstep plant's recorder window: which topics the recorder has confirmed, how far
it lags behind the run, and when the plant must hold back or end the run for it."""
from __future__ import annotations

import time

from . import messages as m
from . import taps
from .plant_params import EXIT_RECORDER_LOST


class RecorderWindowMixin:
    """The recorder handshake of :class:`rotor_avc.nodes.plant_simulator.PlantSimulator`."""

    # -- the recorder handshake (lockstep) -------------------------------------------------------
    def _unrecorded(self) -> list[str]:
        """Topics of the run the ``wait_for_recorder`` node does not receive yet: it has no
        subscription on them, or (the plant's own topics) a listed subscription is not matched
        to the plant's publisher yet. Empty when no recorder is awaited."""
        name = self.p["wait_for_recorder"]
        if not name:
            return []
        ns = self.p["namespace"]
        own = [pub for pub, _, _ in self.meas] + [self.pub_joint, self.pub_clock, self.pub_obs]
        others = [m.actuator_topic(actuator, "actuator_force", ns) for actuator in self.driven]
        others += [m.topic(t, ns) for kind in self.waited_kinds for t in kind.recorded_topics()]
        missing = []
        if self.count_publishers(self.progress_topic) < 1:
            return ["(no recorder progress yet)"]
        for topic, pub in [(p.topic_name, p) for p in own] + [(t, None) for t in others]:
            if taps.tapped(topic) and self.count_publishers(topic) == taps.local_publishers(topic):
                continue                       # a recorder composed into this process has it
            infos = self.get_subscriptions_info_by_topic(topic)
            names = {i.node_name for i in infos} | {
                i.node_namespace.rstrip("/") + "/" + i.node_name for i in infos}
            if name not in names or (pub is not None and pub.get_subscription_count() < len(infos)):
                missing.append(topic)
        return missing

    def _sent(self) -> dict[str, int]:
        """Messages of the run per topic the recorder must take: what the plant published on
        its lockstep topics and the answers it received."""
        sent = {pub.topic_resolved: pub.count for pub, _, _ in self.meas}
        for pub in (self.pub_joint, self.pub_clock, self.pub_obs):
            sent[pub.topic_resolved] = pub.count
        sent.update(self.received)
        return sent

    def _recorder_lag(self) -> int:
        """Messages of the most lagging topic not yet taken by the recorder."""
        taken = self.recorder_taken
        return max(n - taken.get(topic, 0) for topic, n in self._sent().items())

    def _on_progress(self, data: bytes) -> None:
        try:
            label, values = m.labelled_array(data)
            names = label.split(",")
            if len(names) != len(values) or names[:1] != ["time_s"]:
                raise m.MessageError(f"labelled {label!r} with {len(values)} values")
        except m.MessageError as exc:
            self._fault(f"recorder progress ignored: {exc}")
            return
        self.recorder_taken = {n: int(v) for n, v in zip(names[1:], values[1:])}
        lag = self._recorder_lag()
        self.allowance = self.p["recorder_window"] - lag
        if self.draining and lag <= 0:
            self.draining = False
            self._finish()
        elif self.recorder_lagging and self.allowance > 0:
            self.recorder_lagging = False
            self.stalled_since = None
            self._publish_sample()

    def _recorder_holds_back(self) -> bool:
        """Lockstep with a recorder: True (and the plant waits for its progress) when the next
        sample would put the plant more than ``recorder_window`` samples ahead of it."""
        if not self.p["wait_for_recorder"] or self.p["mode"] != "lockstep":
            return False
        if self.allowance > 0:
            return False
        self.recorder_lagging = True
        self.stalled_since = time.monotonic()
        return True

    def _check_recorder(self, now: float) -> None:
        """While waiting for the recorder: end the run when it is gone or takes nothing."""
        gone = self.count_publishers(self.progress_topic) < 1
        if gone or now - self.stalled_since > self.p["recorder_timeout_s"]:
            sent, taken = self._sent(), self.recorder_taken
            short = {t: n - taken.get(t, 0) for t, n in sent.items() if n > taken.get(t, 0)}
            why = ("disappeared" if gone else
                   f"took nothing for {self.p['recorder_timeout_s']:g} s")
            self._fault(f"recorder {self.p['wait_for_recorder']!r} {why} at sample {self.k} of "
                        f"{self.n_steps}: its bag lacks " + ", ".join(
                            f"{n} message(s) of {t}" for t, n in sorted(short.items()))
                        + "; ending the run (exit status 1)")
            self.exit_status = EXIT_RECORDER_LOST
            self.recorder_lagging = self.draining = False
            self._finish(complete=False)
