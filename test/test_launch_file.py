"""The launch file, tested without ``launch``/``launch_ros`` (not installable from the registries
here): it parses, it is installed, and run against small stand-ins of the ``launch`` and
``launch_ros`` modules that record its actions, it starts for every shipped scenario exactly the
nodes of the launch-free graph (rotor_avc.nodes.graph), each a console script of the package,
with parameters that node declares (and accepts), the scenario parameter an existing config
file, in the namespace given; when the plant exits the launch shuts down."""
import ast
import importlib
import importlib.util
import runpy
import sys
import types
from pathlib import Path
from unittest import mock

import pytest

from rotor_avc.config import find_config
from rotor_avc.nodes.graph_nodes import RECORDER
from rotor_avc.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
LAUNCH = ROOT / "launch" / "rotor_avc.launch.py"
SCENARIOS = sorted(p.stem for p in (ROOT / "config").glob("scenario_*.yaml"))


def setup_kwargs(monkeypatch) -> dict:
    """The keyword arguments setup.py gives setuptools.setup (run with setup() captured)."""
    captured = {}
    monkeypatch.chdir(ROOT)
    with mock.patch("setuptools.setup", lambda **kw: captured.update(kw)):
        runpy.run_path(str(ROOT / "setup.py"))
    return captured


def console_scripts(monkeypatch) -> dict[str, str]:
    scripts = setup_kwargs(monkeypatch)["entry_points"]["console_scripts"]
    return dict(s.replace(" ", "").split("=") for s in scripts)


# -- stand-ins of launch / launch_ros: keyword-only signatures as in ROS 2 Jazzy ----------------
class Action:
    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


class LaunchDescription(Action):
    def __init__(self, initial_entities=None):
        super().__init__(entities=list(initial_entities or []))


class DeclareLaunchArgument(Action):
    def __init__(self, name, *, default_value=None, description=None, choices=None):
        super().__init__(name, default_value=default_value, description=description,
                         choices=choices)


class OpaqueFunction(Action):
    def __init__(self, *, function, args=None, kwargs=None):
        super().__init__(function=function, args=args or [], kwargs=kwargs or {})


class RegisterEventHandler(Action):
    def __init__(self, event_handler):
        super().__init__(event_handler=event_handler)


class OnProcessExit(Action):
    def __init__(self, *, target_action=None, on_exit):
        super().__init__(target_action=target_action, on_exit=on_exit)


class EmitEvent(Action):
    def __init__(self, *, event):
        super().__init__(event=event)


class Shutdown(Action):
    def __init__(self, *, reason="reason not given"):
        super().__init__(reason=reason)


class LaunchConfiguration:
    def __init__(self, variable_name, *, default=None):
        self.name, self.default = variable_name, default

    def perform(self, context) -> str:
        return context.launch_configurations[self.name]


class Node(Action):
    def __init__(self, *, executable, package=None, name=None, namespace=None, exec_name=None,
                 parameters=None, remappings=None, ros_arguments=None, arguments=None,
                 output="log", **more):
        super().__init__(executable=executable, package=package, name=name, namespace=namespace,
                         parameters=parameters, remappings=remappings,
                         ros_arguments=ros_arguments, arguments=arguments, output=output, **more)


def _modules() -> dict[str, types.ModuleType]:
    def module(name, **members):
        mod = types.ModuleType(name)
        mod.__dict__.update(members)
        return mod
    return {
        "launch": module("launch", LaunchDescription=LaunchDescription),
        "launch.actions": module("launch.actions", DeclareLaunchArgument=DeclareLaunchArgument,
                                 OpaqueFunction=OpaqueFunction, EmitEvent=EmitEvent,
                                 RegisterEventHandler=RegisterEventHandler),
        "launch.event_handlers": module("launch.event_handlers", OnProcessExit=OnProcessExit),
        "launch.events": module("launch.events", Shutdown=Shutdown),
        "launch.substitutions": module("launch.substitutions",
                                       LaunchConfiguration=LaunchConfiguration),
        "launch_ros": module("launch_ros"),
        "launch_ros.actions": module("launch_ros.actions", Node=Node),
    }


def launch(monkeypatch, **arguments) -> tuple[dict, list]:
    """Run the launch file with ``arguments`` (the rest their defaults) against the stand-ins:
    (declared arguments name -> DeclareLaunchArgument, the actions the launch starts)."""
    for name, mod in _modules().items():
        monkeypatch.setitem(sys.modules, name, mod)
    spec = importlib.util.spec_from_file_location("rotor_avc_launch", LAUNCH)
    launch_file = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(launch_file)
    entities = launch_file.generate_launch_description().kwargs["entities"]
    declared = {a.args[0]: a for a in entities if isinstance(a, DeclareLaunchArgument)}
    unknown = set(arguments) - set(declared)
    assert not unknown, f"not launch arguments: {unknown}"
    context = types.SimpleNamespace(launch_configurations={
        **{n: a.kwargs["default_value"] for n, a in declared.items()}, **arguments})
    started = []
    for action in entities:
        if isinstance(action, OpaqueFunction):
            started += action.kwargs["function"](context, *action.kwargs["args"],
                                                 **action.kwargs["kwargs"])
    return declared, started


def declared_params(executable: str) -> dict:
    """The node's parameter table (rotor_avc.nodes.runtime.Param by name)."""
    pytest.importorskip("rclpy")
    module = importlib.import_module(f"rotor_avc.nodes.{executable}")
    return {p.name: p for p in module.PARAMS}


def test_launch_file_parses_and_is_installed(monkeypatch):
    tree = ast.parse(LAUNCH.read_text())
    functions = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert "generate_launch_description" in functions
    data_files = dict(setup_kwargs(monkeypatch)["data_files"])
    assert "launch/rotor_avc.launch.py" in data_files["share/rotor_avc/launch"]


def test_launch_arguments_and_defaults(monkeypatch):
    declared, started = launch(monkeypatch, bag="/tmp/x.mcap")
    assert set(declared) == {"scenario", "namespace", "bag", "mode"}
    assert all(a.kwargs["description"] for a in declared.values())
    assert find_config(declared["scenario"].kwargs["default_value"]).is_file()
    nodes = [a for a in started if isinstance(a, Node)]
    assert {n.kwargs["namespace"] for n in nodes} == {"avc"}


@pytest.mark.parametrize("name", SCENARIOS)
def test_launch_starts_the_graph_of_every_scenario(monkeypatch, tmp_path, name):
    """The nodes of the launch-free graph, with its parameters, plus namespace and mode."""
    from rotor_avc.nodes.graph import node_commands
    bag = tmp_path / "run.mcap"
    _, started = launch(monkeypatch, scenario=name, namespace="machine_a", bag=str(bag),
                        mode="lockstep")
    scripts = console_scripts(monkeypatch)
    nodes = [a for a in started if isinstance(a, Node)]
    scenario = load_scenario(name)
    launch_free = node_commands(scenario, bag)
    assert [n.kwargs["name"] for n in nodes] == list(launch_free)
    for node in nodes:
        kw = node.kwargs
        assert kw["package"] == "rotor_avc" and kw["namespace"] == "machine_a"
        assert scripts[kw["executable"]] == f"rotor_avc.nodes.{kw['executable']}:main"
        assert not kw["remappings"] and not kw["ros_arguments"] and not kw["arguments"]
        (params,) = kw["parameters"]
        table = declared_params(kw["executable"])
        for key, value in params.items():
            assert key in table, f"{kw['name']}: parameter {key!r} is not declared"
            table[key].check(value, kw["name"])        # type, bounds and choices accepted
        assert Path(params["scenario"]).is_file()
        assert Path(params["scenario"]).resolve() == find_config(name).resolve()
        assert params["namespace"] == "machine_a"
        # the launch-free graph's command line says the same (besides namespace and mode)
        cmd = launch_free[kw["name"]]
        assert cmd[:2] == ["-m", f"rotor_avc.nodes.{kw['executable']}"]
        given = dict(a.split(":=", 1) for a in cmd[cmd.index("--ros-args") + 1:][3::2])
        expect = {k: str(v).lower() if isinstance(v, bool) else str(v)
                  for k, v in params.items() if k not in ("namespace", "mode")}
        assert given == expect
    by_name = {n.kwargs["name"]: n.kwargs for n in nodes}
    assert by_name[RECORDER]["parameters"][0]["path"] == str(bag)
    plant = by_name["plant_simulator"]["parameters"][0]
    assert plant["wait_for_recorder"] == RECORDER and plant["mode"] == "lockstep"
    assert {f"foot_controller_{f}" for f in scenario.machine.controllers} == {
        n for n in by_name if n.startswith("foot_controller_")}
    assert ("harmonic_controller" in by_name) == scenario.use_harmonic
    assert ("balancer" in by_name) == scenario.use_balancer
    (handler,) = [a for a in started if isinstance(a, RegisterEventHandler)]
    on_exit = handler.kwargs["event_handler"]
    assert isinstance(on_exit, OnProcessExit)
    assert on_exit.kwargs["target_action"].kwargs["name"] == "plant_simulator"
    assert isinstance(on_exit.kwargs["on_exit"][0].kwargs["event"], Shutdown)


def test_default_bag_name_is_new_per_launch(monkeypatch):
    _, started = launch(monkeypatch, scenario="scenario_reference")
    (recorder,) = [a for a in started if isinstance(a, Node) and a.kwargs["name"] == RECORDER]
    path = recorder.kwargs["parameters"][0]["path"]
    assert path.startswith("scenario_reference_") and path.endswith(".mcap")

