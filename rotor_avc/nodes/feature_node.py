"""The base of the nodes that run one block of a scenario beside the plant (the balancer, the
harmonic controller, the synchronous feed-forward): what they share, owned once.

* **Parameters** -- the subclass's ``PARAMS`` (:data:`rotor_avc.nodes.runtime.COMMON_PARAMS`
  plus ``scenario`` and ``namespace``), declared and read into ``self.p``; the executor kind
  the runtime starts the node with.
* **The block** -- the scenario (``scenario`` parameter, loaded and validated) and the block the
  subclass's ``build(scenario)`` makes of it; a scenario without the block's section is refused
  naming it (``NEEDS``), before any topic exists.
* **Diagnostics** -- one status per second on ``/diagnostics``: the loop timing, the fault count,
  what ``status()`` adds (level, text, statistics) and what the node has published.
* **Faults** -- ``fault(text)`` counts a fault, keeps it as ``last_fault`` and logs it when it
  differs from the previous one (a stream of the same fault is one log line, every one counted).
* **Shutdown** -- by :func:`rotor_avc.nodes.runtime.run_node` (signals, final diagnostics).

Incoming joint states are read by :meth:`joint` (a malformed one is a counted fault).
"""
from __future__ import annotations

from rclpy.node import Node

from ..errors import RotorAvcError
from . import messages as m
from . import taps
from .runtime import declare_parameters, node_scenario
from .timing import LoopTiming


class FeatureNode(Node):
    """See the module docstring; subclasses set ``PARAMS``, ``NEEDS`` (what the scenario must
    have, e.g. "`simulation.feedforward`"), ``TITLE`` (of the diagnostics) and implement
    ``build(scenario)`` and ``status()``."""

    PARAMS: tuple = ()
    NEEDS = ""
    TITLE = ""

    def __init__(self, name: str, **kwargs):
        super().__init__(name, **kwargs)
        self.p = declare_parameters(self, self.PARAMS)
        self.executor_kind = self.p["executor"]
        self.scenario = node_scenario(self, self.p["scenario"], f"a scenario with {self.NEEDS}")
        self.block = self.build(self.scenario)
        if self.block is None:
            raise RotorAvcError(f"{self.get_name()}: {self.scenario.machine.config.source} has "
                                f"no {self.NEEDS} -- fix: use a scenario with it")
        self.namespace = self.p["namespace"]
        self.pub_diag = taps.publisher(self, m.DiagnosticArray, "/diagnostics", m.DIAGNOSTICS_QOS)
        self.create_timer(1.0, self._publish_diagnostics)
        self.timing = LoopTiming(None)
        self.last_stamp = -1
        self.faults = 0
        self.last_fault = ""

    def build(self, scenario):
        """The block this node runs, or None if the scenario has none."""
        raise NotImplementedError

    def status(self) -> tuple[str, str, dict]:
        """``(level, text, statistics)`` of the diagnostics (level ``ok`` or ``warn``)."""
        raise NotImplementedError

    def fault(self, text: str) -> None:
        self.faults += 1
        if text != self.last_fault:
            self.get_logger().warning(text)
        self.last_fault = text

    def joint(self, data: bytes) -> tuple[int, list, list] | None:
        """``(stamp ns, positions, velocities)`` of a ``rotor/joint_state``, or None for a
        malformed message (a fault)."""
        try:
            return m.joint_state(data)
        except m.MessageError as exc:
            self.fault(f"rotor/joint_state ignored: {exc}")
            return None

    def _publish_diagnostics(self) -> None:
        level, text, extra = self.status()
        stats = self.timing.summary()
        stats.update({"faults": self.faults, **extra})
        self.pub_diag.publish(m.diagnostics(max(self.last_stamp, 0), [
            (f"{self.get_name()}: {self.TITLE}", level, text, stats), m.published_status(self)]))
