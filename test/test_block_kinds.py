"""The answering block kinds (rotor_avc.block_kinds) are what the graph, the plant, a bag's sampled
topics, replay and the in-process recording iterate over: each declaration is checked against the
code it names (protocol, node, topics, channels), and the users against the declarations."""
from __future__ import annotations

import dataclasses
import re

import pytest

from rotor_avc.bag import topics as T
from rotor_avc.block_kinds import BALANCER, FEEDBACK, FEEDFORWARD, HARMONIC, KINDS
from rotor_avc.nodes.graph_nodes import graph_nodes
from rotor_avc.nodes.plant_params import PARAMS as PLANT_PARAMS
from rotor_avc.scenario import load_scenario

#: shipped scenarios that together hold every kind
SCENARIOS = {"scenario_case3_steady": {FEEDBACK},
             "scenario_active_bearing": {FEEDFORWARD},
             "scenario_harmonic_case3_steady": {FEEDBACK, HARMONIC},
             "scenario_balance_runup": {BALANCER}}


def _blocks_of(scenario, kind):
    """The blocks the scenario builds for ``kind``, by the scenario's own builders."""
    built = {FEEDBACK: lambda: list(scenario.controllers().values()),
             FEEDFORWARD: lambda: [scenario.feedforward()],
             HARMONIC: lambda: [scenario.harmonic()],
             BALANCER: lambda: [scenario.balancer()]}
    return built[kind]()


@pytest.mark.parametrize("name", SCENARIOS)
def test_a_scenario_builds_a_block_of_each_declared_protocol(name):
    scenario = load_scenario(name)
    kinds = scenario.block_kinds()
    assert SCENARIOS[name] <= set(kinds)
    for kind in KINDS:
        blocks = _blocks_of(scenario, kind) if kind in kinds else []
        assert all(isinstance(b, kind.protocol) for b in blocks), kind.name
        if kind not in kinds and kind is not FEEDBACK:
            assert _blocks_of(scenario, kind) == [None], f"{name}: {kind.name} built but absent"


@pytest.mark.parametrize("name", SCENARIOS)
def test_the_graph_starts_one_node_per_declared_instance(name, tmp_path):
    scenario = load_scenario(name)
    specs = graph_nodes(scenario, tmp_path / "run.mcap")
    assert specs[0].executable == "recorder" and specs[-1].executable == "plant_simulator"
    expected = [kind.node for kind, ids in scenario.block_kinds().items() for _ in ids]
    assert [s.executable for s in specs[1:-1]] == expected
    plant = specs[-1].parameters
    for kind in KINDS:
        if kind.plant_flag:
            assert plant.get(kind.plant_flag, False) == (kind in scenario.block_kinds())
    feet = [s.parameters[FEEDBACK.id_param] for s in specs if s.executable == FEEDBACK.node]
    assert feet == list(scenario.machine.controllers)


def test_every_kind_names_a_node_and_a_plant_parameter_that_exist(monkeypatch):
    from test_launch_file import console_scripts
    scripts = console_scripts(monkeypatch)
    plant_params = {p.name for p in PLANT_PARAMS}
    for kind in KINDS:
        assert scripts[kind.node] == f"rotor_avc.nodes.{kind.node}:main"
        assert kind.plant_flag is None or kind.plant_flag in plant_params
        assert kind.node_per_actuator == bool(kind.id_param)


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.name)
def test_answers_are_sampled_topics_and_recorded_topics_have_types(kind):
    answer = T.topic(kind.answer_topic.format(id="DL"), "machine_a")
    assert T.SAMPLED.match(answer)
    for topic in kind.recorded_topics():
        assert T.message_type(T.topic(topic.format(id="DL"))) is not None
    for topic in kind.also_publishes:
        assert not T.SAMPLED.match(T.topic(topic)), f"{topic} is published per update, not sample"


def test_replay_answers_follow_the_replayable_kinds():
    from rotor_avc.nodes.replay import DEFAULT_RULES

    def answer(topic):
        return next((a for a in (r.match(topic) for r in DEFAULT_RULES) if a), None)

    for signal in ("acceleration", "velocity", "displacement"):
        assert answer(f"/m/foot/NR/{signal}") == "/m/foot/NR/actuator_force"
    assert answer("/avc/plant/observables") == "/avc/balancer/command"
    assert answer("/avc/rotor/joint_state") is None           # two kinds would answer it
    assert not any(re.fullmatch(r.pattern, "/avc/foot/DL/actuator_force") for r in DEFAULT_RULES)


def test_an_in_process_recording_writes_each_kinds_answer_topic():
    """A balanced run's bag has the balancer's answers; the feedback controllers' forces per
    controlled actuator; harmonic forces only where the time series carries them."""
    from rotor_avc.recording import run_streams
    scenario = dataclasses.replace(load_scenario("scenario_balance_runup"), duration_s=0.02)
    names = {s.topic for s in run_streams(scenario, scenario.run(progress=False))}
    assert T.topic(BALANCER.answer_topic) in names
    assert T.topic(HARMONIC.answer_topic) not in names
    scenario = dataclasses.replace(load_scenario("scenario_case3_steady"), duration_s=0.01)
    ts = scenario.run(progress=False)
    names = {s.topic for s in run_streams(scenario, ts)}
    assert {T.topic(FEEDBACK.answer_topic.format(id=f)) for f in scenario.machine.controllers} <= names
    assert T.topic(BALANCER.answer_topic) not in names
