"""What decides a replayed block's answers (rotor_avc.compare.answer_config), without ROS: the
shipped scenarios differ exactly where their YAML files do, numbers are equal within the float
tolerance and not beyond it, a different rate, G_c, limit or start is named with both values,
an older node without the parameter is one clear difference, and the bag's recorded
configuration gives what its source file gives (with the command that starts a node so)."""
import json
from pathlib import Path

import pytest

from rotor_avc.bag import BagReader
from rotor_avc.block_kinds import BALANCER, FEEDBACK
from rotor_avc.compare.answer_config import (MISSING, PARAMETER, AnswerConfig, BagAnswers,
                                             answer_config, answering_block, differences,
                                             start_command)
from rotor_avc.config import find_config
from rotor_avc.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
REFERENCE_BAG = ROOT / "bags" / "reference" / "case3_stepped.mcap"
DL_FORCE = "/avc/foot/DL/actuator_force"


def dl(scenario) -> AnswerConfig:
    return answer_config(load_scenario(scenario), FEEDBACK.name, "DL")


def lines(bag: AnswerConfig, node: AnswerConfig) -> list[str]:
    return [d.line() for d in differences(bag, node)]


def variant(tmp_path, name: str, text: str) -> str:
    """A scenario file that includes scenario_case3_steady and changes ``text``."""
    path = tmp_path / f"{name}.yaml"
    path.write_text(f"include: {find_config('scenario_case3_steady')}\n{text}")
    return str(path)


def other_dl(tmp_path, name: str, entry: str) -> str:
    """scenario_case3_steady with DL's controller replaced by ``entry`` (case 2 is case 3
    without its controllers; the steady scenario's simulation section)."""
    path = tmp_path / f"{name}.yaml"
    path.write_text(f"include: {find_config('foot_mount_case2')}\ncontrollers:\n  DL: {entry}\n"
                    "  DR: {type: I, feedback: acceleration, ki: 1.4e+5}\n"
                    "  NL: {type: I, feedback: acceleration, ki: 1.4e+5}\nsimulation:"
                    + find_config("scenario_case3_steady").read_text().split("\nsimulation:")[1])
    return str(path)


def test_shipped_scenarios_differ_exactly_where_their_files_do():
    """config/scenario_case3_stepped.yaml starts at 10 Hz, scenario_case3_steady.yaml at 20 Hz,
    both at 5 kHz with the same controllers; scenario_reference.yaml runs at 1 kHz from 103 Hz."""
    steady = dl("scenario_case3_steady")
    assert lines(dl("scenario_case3_stepped"), steady) == [
        "initial_state.speed_hz: bag 10, node 20"]
    assert lines(dl("scenario_reference"), steady) == [
        "sample_rate_hz: bag 1000, node 5000", "initial_state.speed_hz: bag 103, node 20"]
    assert steady.fields["controllers.DL.ki"] == 1.4e5          # foot_mount_case3.yaml
    assert steady.fields["controllers.DL.feedback"] == "acceleration"
    assert not differences(steady, dl("scenario_case3_steady"))


def test_numbers_are_equal_within_the_float_tolerance_and_not_beyond():
    steady = dl("scenario_case3_steady")

    def scaled(factor: float) -> AnswerConfig:
        def scale(fields):
            return {k: v * factor if isinstance(v, float) else v for k, v in fields.items()}
        return AnswerConfig(steady.kind, steady.block_id, scale(steady.fields),
                            scale(steady.steady_start))

    assert not differences(steady, scaled(1 + 1e-12))         # e.g. a rate as 1 / (1 / f)
    changed = differences(steady, scaled(1 + 1e-6))
    assert "sample_rate_hz" in [d.field for d in changed]
    assert "controllers.DL.ki: bag 140000, node 140000.14" in [d.line() for d in changed]


def test_a_different_rate_g_c_or_limit_is_named_with_both_values(tmp_path):
    steady = dl("scenario_case3_steady")
    rate = dl(variant(tmp_path, "rate", "simulation:\n  sample_rate_hz: 4000.0\n"))
    assert lines(steady, rate) == ["sample_rate_hz: bag 5000, node 4000"]
    gain = dl(variant(tmp_path, "gain", "controllers:\n"
                      "  DL: {type: I, feedback: acceleration, ki: 1.5e+5}\n"))
    assert lines(steady, gain) == ["controllers.DL.ki: bag 140000, node 150000"]
    # the same G_c = 1.4e5 / s written as num/den is another configuration of the same law
    tf = dl(other_dl(tmp_path, "tf", "{type: tf, feedback: acceleration, num: [1.4e+5], "
                     "den: [1.0, 0.0]}"))
    assert lines(steady, tf) == ["controllers.DL.type: bag I, node tf",
                                 "controllers.DL.ki: bag 140000, node (not given)",
                                 "controllers.DL.num: bag (not given), node [140000]",
                                 "controllers.DL.den: bag (not given), node [1, 0]"]
    velocity = dl(other_dl(tmp_path, "velocity", "{type: P, feedback: velocity, kp: 1.4e+5}"))
    assert lines(steady, velocity) == ["controllers.DL.type: bag I, node P",
                                       "controllers.DL.feedback: bag acceleration, node velocity",
                                       "controllers.DL.ki: bag 140000, node (not given)",
                                       "controllers.DL.measurement_limit: bag 100000, node 100",
                                       "controllers.DL.kp: bag (not given), node 140000"]
    # a force limit brings back-calculation anti-windup with it (rotor_avc/control/block.py)
    limited = dl(variant(tmp_path, "limit", "controllers:\n  DL: {type: I, feedback: "
                         "acceleration, ki: 1.4e+5, force_limit_n: 2000.0}\n"))
    assert lines(steady, limited) == [
        "controllers.DL.anti_windup: bag none, node back_calculation",
        "controllers.DL.force_limit_n: bag (not given), node 2000"]


def test_a_start_at_rest_is_one_field_and_the_steady_start_counts_every_input(tmp_path):
    steady = dl("scenario_case3_steady")
    rest = dl(variant(tmp_path, "rest", "simulation:\n  initial_state: rest\n"))
    assert rest.steady_start == {}
    assert lines(steady, rest) == ["simulation.initial_state: bag steady_state, node rest"]
    # the periodic solution depends on the whole loop: another foundation or another foot's
    # controller changes the DL filter's start, so they are compared too
    soft = dl(variant(tmp_path, "soft", "foundation:\n  stiffness_n_per_m: {z: 1.0e+9}\n"))
    assert lines(steady, soft) == [
        "foundation.stiffness_n_per_m.z: bag 1440000000, node 1000000000"]
    other = dl(variant(tmp_path, "dr", "controllers:\n"
                       "  DR: {type: I, feedback: acceleration, ki: 1.0e+5}\n"))
    assert lines(steady, other) == ["controllers.DR.ki: bag 140000, node 100000"]
    unbalance = dl(variant(tmp_path, "unb", "simulation:\n  unbalance:\n"
                           "    static: {magnitude: 2.0e-2, phase_deg: 0.0}\n"))
    assert lines(steady, unbalance) == [
        "simulation.unbalance.static.magnitude: bag 0.01, node 0.02"]


def test_an_older_node_or_an_unreadable_value_is_one_clear_difference():
    with BagReader(REFERENCE_BAG) as reader:
        bag = BagAnswers(reader.config, REFERENCE_BAG)
    older = bag.check("/foot_controller", DL_FORCE, None)
    (d,) = older.differences
    assert d.field == PARAMETER and d.node is MISSING
    assert "node (not declared: a node of an older version" in d.line()
    assert older.command == ("foot_controller --ros-args -p scenario:=scenario_reference "
                             "-p foot_id:=DL")
    for text, said in (("{not json", "unreadable: not JSON"),
                       (json.dumps({"kind": "feedback"}), "unreadable: not a mapping")):
        (d,) = bag.check("/foot_controller", DL_FORCE, text).differences
        assert said in d.line()
    (d,) = bag.check("/fc", DL_FORCE, None, unread="no answer within 5 s").differences
    assert "node (not read: no answer within 5 s)" in d.line()
    wrong_kind = AnswerConfig("harmonic", "", {})
    (d,) = bag.check("/h", "/avc/some/forces", wrong_kind.to_json()).differences
    assert d.field == "block kind" and d.node == "harmonic"


def test_the_bag_gives_what_its_source_file_gives_and_the_command_to_start_it():
    """The reference bag's configuration (through the bag's YAML records) against
    config/scenario_reference.yaml, from which it was recorded (bags/README.md)."""
    source = dl("scenario_reference")
    with BagReader(REFERENCE_BAG) as reader:
        bag = BagAnswers(reader.config, REFERENCE_BAG)
    assert not differences(bag.answers(FEEDBACK.name, "DL"), source)
    assert bag.check("/foot_controller", DL_FORCE, source.to_json()).differences == []
    steady = bag.check("/foot_controller_DL", DL_FORCE, dl("scenario_case3_steady").to_json())
    assert [d.line() for d in steady.differences] == [
        "sample_rate_hz: bag 1000, node 5000", "initial_state.speed_hz: bag 103, node 20"]
    assert steady.command == ("foot_controller --ros-args -r __node:=foot_controller_DL -p "
                              "scenario:=scenario_reference -p foot_id:=DL")


@pytest.mark.parametrize("topic, expected", [
    ("/avc/foot/DL/actuator_force", (FEEDBACK, "DL", "avc")),
    ("/rig/a/foot/NR/actuator_force", (FEEDBACK, "NR", "rig/a")),
    ("/avc/balancer/command", (BALANCER, "", "avc")),
    ("/avc/harmonic/forces", None),              # answers two topics: not re-driven by replay
    ("/foot/DL/actuator_force", (FEEDBACK, "DL", "")),      # the empty namespace
    ("/avc/foot/actuator_force", None),
])
def test_the_answer_topic_names_the_block(topic, expected):
    assert answering_block(topic) == expected


def test_answer_config_round_trips_and_the_start_command_keeps_name_and_namespace():
    steady = dl("scenario_case3_steady")
    assert AnswerConfig.from_json(steady.to_json()) == steady
    assert start_command(FEEDBACK, "NL", "/rig/fc_nl", "my.yaml", "rig") == (
        "foot_controller --ros-args -r __node:=fc_nl -p scenario:=my.yaml -p foot_id:=NL "
        "-p namespace:=rig")
    assert start_command(FEEDBACK, "DL", "/foot_controller", "s.yaml", "") == (
        "foot_controller --ros-args -p scenario:=s.yaml -p foot_id:=DL -p namespace:=''")
    assert start_command(BALANCER, "", "/balancer", None) == (
        "balancer --ros-args -p scenario:=<a scenario file with the bag's configuration>")
