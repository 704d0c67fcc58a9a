"""A misspelt input is answered with the closest valid one, in one line, exit status 2: file paths
(bags, configs, included files, --map, UFF data; rotor_avc.errors.path_suggestion), bag topics
(replay's --topics/--remap/--wait-for, a --map channel's topic) and node names (run --list-params
NODE). Every case runs the `rotor-avc` entry point in-process; the expected suggestions are the
files, topics and nodes each test lays out (or the reference bag holds), written out by hand."""
import sys
from pathlib import Path

import pytest

from rotor_avc.bag.check import bag_files
from rotor_avc.bag.errors import BagError
from rotor_avc.bag.integrity import scan_bag
from rotor_avc.bag.reader import BagReader
from rotor_avc.bag.recover import recover_bag
from rotor_avc.bag.summary import read_summary
from rotor_avc.cli import main
from rotor_avc.errors import path_suggestion

ROOT = Path(__file__).resolve().parent.parent
BAG = str(ROOT / "bags" / "reference" / "case3_stepped.mcap")
DL_ACC = "/avc/foot/DL/acceleration"
#: the topics of the reference bag (bags/reference/case3_stepped.mcap), sorted
BAG_TOPICS = ("/avc/foot/DL/acceleration, /avc/foot/DL/actuator_force, /avc/foot/DR/acceleration, "
              "/avc/foot/DR/actuator_force, /avc/foot/NL/acceleration, "
              "/avc/foot/NL/actuator_force, /avc/plant/observables, /avc/rotor/joint_state, /clock")


def refused(argv, capsys) -> str:
    """The one error line of a command that exits 2."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"rotor-avc {argv[0]}: error: "), err
    return err


@pytest.fixture
def tree(tmp_path, monkeypatch):
    """out/demo/bags/run.mcap (and a file out/demos), the working folder."""
    (tmp_path / "out" / "demo" / "bags").mkdir(parents=True)
    (tmp_path / "out" / "demo" / "bags" / "run.mcap").touch()
    (tmp_path / "out" / "demos").touch()
    monkeypatch.chdir(tmp_path)
    return tmp_path


BAG_COMMANDS = [["bag", "info"], ["bag", "check"], ["bag", "recover"], ["replay"], ["compare"]]


@pytest.mark.parametrize("command", BAG_COMMANDS, ids=" ".join)
def test_a_misspelt_bag_file_gets_the_closest_file_of_its_folder(command, tree, capsys):
    err = refused([*command, "out/demo/bags/rnu.mcap"], capsys)
    assert "out/demo/bags/rnu.mcap: no such bag file" in err
    assert "(did you mean 'out/demo/bags/run.mcap'?) -- fix: check the path" in err


@pytest.mark.parametrize("command", BAG_COMMANDS, ids=" ".join)
def test_a_bag_below_a_missing_folder_gets_the_closest_existing_folder(command, tree, capsys):
    err = refused([*command, "out/dmeo/bags/run.mcap"], capsys)
    assert "out/dmeo/bags/run.mcap: no such bag file" in err
    assert "(did you mean 'out/demo'?)" in err          # a folder, not the file out/demos


@pytest.mark.parametrize("command", BAG_COMMANDS, ids=" ".join)
def test_nothing_close_still_names_the_file(command, tree, capsys):
    err = refused([*command, "zzz/qqq.mcap"], capsys)
    assert "zzz/qqq.mcap: no such bag file" in err and "did you mean" not in err


@pytest.mark.parametrize("read", [bag_files, scan_bag, BagReader, recover_bag, read_summary],
                         ids=lambda f: f.__name__)
def test_every_bag_reader_says_it_alike(read, tree):
    with pytest.raises(BagError) as exc:
        read("out/demo/bags/rnu.mcap")
    assert str(exc.value).startswith("out/demo/bags/rnu.mcap: no such bag file")
    assert str(exc.value).endswith("(did you mean 'out/demo/bags/run.mcap'?) -- fix: check the "
                                   "path")


def test_the_suggestion_is_one_listing_of_the_right_folder(tree):
    assert path_suggestion("out/demo/bags/run.mcap") == ""               # it exists
    assert path_suggestion("out/demo/bag/run.mcap") == " (did you mean 'out/demo/bags'?)"
    assert path_suggestion("out/demoss") == " (did you mean 'out/demos'?)"          # any entry
    assert path_suggestion("out/demoss/x") == " (did you mean 'out/demo'?)"      # folders only
    assert path_suggestion("out/demo/bags/run.mcap/x") == ""             # below a file
    assert path_suggestion(tree / "out" / "dmeo") == f" (did you mean '{tree / 'out' / 'demo'}'?)"
    assert path_suggestion("dmeo", root=tree / "out") == " (did you mean 'demo'?)"
    (tree / "out" / ".demox").touch()
    assert path_suggestion("out/demox") == " (did you mean 'out/demo'?)"      # not .demox
    assert path_suggestion("out/.demx") == " (did you mean 'out/.demox'?)"
    assert path_suggestion("a\0b") == ""


def test_config_paths_included_files_and_maps(tree, capsys):
    (tree / "cfg").mkdir()
    (tree / "cfg" / "machine.yaml").write_text("model: foot_mount\n")
    err = refused(["poles", "cfg/machin.yaml"], capsys)
    assert "cfg/machin.yaml: no such file" in err and "(did you mean 'cfg/machine.yaml'?)" in err
    err = refused(["poles", "cgf/machine.yaml"], capsys)
    assert "(did you mean 'cfg'?)" in err
    err = refused(["poles", "foot_mount_cas3"], capsys)                  # a name: shipped ones
    assert "(did you mean 'foot_mount_case3'?)" in err
    (tree / "cfg" / "top.yaml").write_text("include: machne.yaml\n")
    err = refused(["poles", "cfg/top.yaml"], capsys)
    assert "included file 'machne.yaml' not found (did you mean 'machine.yaml'?)" in err
    (tree / "map.yaml").write_text("channels: {}\n")
    err = refused(["compare", BAG, "--config", "foot_mount_case3", "--map", "mpa.yaml"], capsys)
    assert f"{tree / 'mpa.yaml'}: cannot read file" in err
    assert f"(did you mean '{tree / 'map.yaml'}'?)" in err


def test_a_misspelt_uff_file(tree, capsys):
    (tree / "modal.uff").touch()
    (tree / "map.yaml").write_text("uff: {input: DL, speed_hz: 0.0, responses: [{node: 11, "
                                   "direction: 3, signal: foot_DL_az}]}\n")
    err = refused(["calibrate", "modl.uff", "--config", "foot_mount_case3", "--uff-map",
                   "map.yaml", "--fit", "foundation.tan_delta", "--out", "cal", "--workers", "1"],
                  capsys)
    assert "modl.uff: no such UFF file (did you mean 'modal.uff'?)" in err


@pytest.fixture
def no_ros(monkeypatch):
    """rclpy and the replay node cannot be imported: replay's checks must come first."""
    monkeypatch.setitem(sys.modules, "rclpy", None)
    monkeypatch.setitem(sys.modules, "rotor_avc.nodes.replay", None)


@pytest.mark.parametrize("options, option, typed, meant, topics", [
    (["--topics", "/avc/foot/DL/acceleraton"], "--topics", "/avc/foot/DL/acceleraton", DL_ACC,
     BAG_TOPICS),
    (["--remap", "/avc/foot/DL/accelration:=/x/acc"], "--remap", "/avc/foot/DL/accelration",
     DL_ACC, BAG_TOPICS),
    (["--topics", DL_ACC, "--remap", f"{DL_ACC}:=/re/acc", "--wait-for", "/re/ac:=/re/force"],
     "--wait-for", "/re/ac", "/re/acc", "/re/acc"),
    (["--topics", DL_ACC, "--wait-for", "/avc/foot/DL/acceleratio:=/f"], "--wait-for",
     "/avc/foot/DL/acceleratio", DL_ACC, DL_ACC),
], ids=["topics", "remap", "wait-for-remapped", "wait-for"])
def test_replay_refuses_a_topic_it_cannot_use_before_ros(options, option, typed, meant, topics,
                                                         no_ros, capsys):
    err = refused(["replay", BAG, "--fast", *options], capsys)
    where = "in the bag" if option != "--wait-for" else "among the published topics"
    assert (f"{BAG}: {option}: no topic {typed} (did you mean '{meant}'?) {where} -- fix: use one "
            f"of {topics}\n") in err


def test_replay_names_an_unknown_topic_and_the_bags_topics(no_ros, capsys):
    err = refused(["replay", BAG, "--topics", DL_ACC, "/nothing/like/it"], capsys)
    assert f"no topic /nothing/like/it in the bag -- fix: use one of {BAG_TOPICS}" in err
    assert "did you mean" not in err


def test_a_mapped_channel_topic_gets_the_closest_bag_topic(tree, capsys):
    (tree / "map.yaml").write_text(
        "channels:\n  foot_DL_az: {topic: /avc/foot/DL/acceleraton, field: accel.linear.z}\n"
        "shaft: {source: joint_state, topic: /avc/rotor/joint_state}\n")
    err = refused(["compare", BAG, "--config", "foot_mount_case3", "--map", "map.yaml",
                   "--out", "o"], capsys)
    assert (f"channels.foot_DL_az.topic: no topic /avc/foot/DL/acceleraton in {BAG} (did you "
            f"mean '{DL_ACC}'?) -- fix: use one of {BAG_TOPICS}") in err


NODES = "recorder, foot_controller_DL, foot_controller_DR, foot_controller_NL, plant_simulator"


@pytest.mark.parametrize("typed, hint", [("foot_controler_DL", " (did you mean "
                                                                "'foot_controller_DL'?)"),
                                         ("zzzz", "")])
def test_run_list_params_of_an_unknown_node(typed, hint, tmp_path, capsys):
    err = refused(["run", "scenario_case3_steady", "--list-params", typed, "--bag",
                   str(tmp_path / "b.mcap")], capsys)
    assert (f"--list-params: no node {typed!r} in this scenario's graph{hint} -- fix: give one "
            f"of {NODES}\n") in err


def test_run_list_params_of_one_node(tmp_path, capsys):
    pytest.importorskip("rclpy")                  # the parameter tables live in the node modules
    assert main(["run", "scenario_case3_steady", "--list-params", "foot_controller_DL", "--bag",
                 str(tmp_path / "b.mcap")]) == 0
    out = capsys.readouterr().out
    heads = [line.split()[0] for line in out.splitlines() if not line.startswith(" ")]
    assert heads == ["foot_controller_DL"] and "foot_id" in out
