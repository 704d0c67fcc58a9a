"""The kinds of block that answer the plant at every sample, each declared once (DESIGN.md
section 3).

A kind says which protocol its blocks implement (:mod:`rotor_avc.blocks`), which ROS node runs
one, which of the plant's topics it answers and on which topic it answers (one message per sample,
stamped with the sample it answers), what else it publishes that a run records, the channel prefix
of its answers in an in-process run's time series, and the ``plant_simulator`` parameter that makes
the plant wait for it. The graph (which nodes a run starts), the lockstep plant (whose answers it
waits for, what the recorder must take), a bag's sampled topics, replay (which answer a replayed
sample gets) and the in-process recording (which channels become which topic) iterate over
:data:`KINDS` instead of naming the kinds.

Topic names are relative to the machine's namespace; ``{id}`` stands for an actuator id (the
``foot/`` prefix is the foot-mount machines' name for an actuator's topics).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from .blocks import Balancer, Controller, Harmonic, Synchronous

#: the plant's sampled topics that blocks answer, by what they carry, and an actuator's force
ACTUATOR_SIGNALS = ("foot/{id}/acceleration", "foot/{id}/velocity", "foot/{id}/displacement")
ACTUATOR_FORCE = "foot/{id}/actuator_force"
JOINT_STATE = "rotor/joint_state"
OBSERVABLES = "plant/observables"


@dataclass(frozen=True)
class BlockKind:
    """One kind of answering block (see the module docstring)."""

    name: str
    protocol: type
    node: str                               # the console script / node executable
    answer_topic: str                       # one message per sample answered
    triggers: tuple[str, ...]               # the plant topics whose samples it answers
    channel_prefix: str                     # its answers' channels in an in-process time series
    also_publishes: tuple[str, ...] = ()    # other recorded topics of its node
    plant_flag: str | None = None           # plant_simulator parameter: wait for this kind
    node_per_actuator: bool = False         # one node per actuator (parameter ``id_param``)
    id_param: str = ""
    #: every answer follows one message of one trigger topic, so a replay can tell which
    #: published message an answer belongs to (a kind answering two topics cannot say)
    replayable: bool = False

    def recorded_topics(self) -> tuple[str, ...]:
        """What a run with this kind records of it: its answers and its other topics."""
        return (self.answer_topic,) + self.also_publishes

    def replay_rules(self) -> tuple[tuple[str, str], ...]:
        """Per trigger ``(pattern, answer)``: a regular expression over a full published topic
        name (named groups ``ns`` and, per actuator, ``id``) and the answer topic as a format
        string over those groups."""
        return tuple(("(?P<ns>.*)/" + re.escape(t).replace(r"\{id\}", "(?P<id>[^/]+)"),
                      "{ns}/" + self.answer_topic) for t in self.triggers)

FEEDBACK = BlockKind(
    "feedback", Controller, "foot_controller", ACTUATOR_FORCE, ACTUATOR_SIGNALS,
    "actuator_", node_per_actuator=True, id_param="foot_id", replayable=True)
FEEDFORWARD = BlockKind(
    "feedforward", Synchronous, "synchronous_controller", ACTUATOR_FORCE, (JOINT_STATE,),
    "actuator_")
HARMONIC = BlockKind(
    "harmonic", Harmonic, "harmonic_controller", "harmonic/forces", (OBSERVABLES, JOINT_STATE),
    "harmonic_", also_publishes=("harmonic/status",), plant_flag="harmonic")
BALANCER = BlockKind(
    "balancer", Balancer, "balancer", "balancer/command", (OBSERVABLES,), "balancer_",
    also_publishes=("balancer/estimate",), plant_flag="balancer", replayable=True)

#: every answering kind, in the order a graph starts their nodes (before the plant)
KINDS = (FEEDBACK, FEEDFORWARD, HARMONIC, BALANCER)


def answer_topics() -> tuple[str, ...]:
    """The distinct answer topics of all kinds (``{id}`` unexpanded)."""
    return tuple(dict.fromkeys(k.answer_topic for k in KINDS))


def answer_prefixes() -> tuple[str, ...]:
    """The distinct time-series channel prefixes of the kinds' answers."""
    return tuple(dict.fromkeys(k.channel_prefix for k in KINDS))
