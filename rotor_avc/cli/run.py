"""``rotor-avc run``: a scenario as a ROS graph, launch-free, recorded to a bag.

The nodes ``ros2 launch rotor_avc rotor_avc.launch.py`` would start (rotor_avc.nodes.graph_nodes),
each in its own process (``--composed``: all in one process and one executor), the plant in
lockstep with the recorder (``--realtime``: sample by sample at the wall clock); progress with the
time left, then the messages published and recorded per topic (a run that lost any is an error).
``--list-params`` prints the parameters of every node of the scenario's graph instead (``NODE``
after it: of that node only; a name the graph does not have is refused with the closest one):
the value the run gives it (or its default), its type, bounds and meaning.
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from ..errors import ConfigError, RotorAvcError, did_you_mean
from ..scenario import load_scenario
from ..studies.progress import Progress

NAME = "run"
HELP = ("Run a scenario as a ROS graph (one process per node, or --composed), recorded to a bag, "
        "with progress and the per-topic counts; --list-params [NODE]: every node's (that node's) "
        "parameters.")
EXAMPLE = ("rotor-avc run scenario_case3_stepped --composed --bag out/run/case3.mcap\n"
           "  rotor-avc run scenario_case3_stepped --list-params foot_controller_DL")


def add_arguments(p) -> None:
    p.add_argument("scenario", help="scenario config: a YAML path or a shipped name")
    p.add_argument("--bag", type=Path, default=None,
                   help="the bag to record (default: bags/<scenario>_<date>_<time>.mcap)")
    p.add_argument("--logs", type=Path, default=None,
                   help="folder of the nodes' logs (default: beside the bag, <bag>_logs)")
    p.add_argument("--composed", action="store_true",
                   help="all nodes in one process and one executor (several times faster)")
    p.add_argument("--realtime", action="store_true",
                   help="the plant steps at the wall clock instead of in lockstep")
    p.add_argument("--list-params", nargs="?", const="", default=None, metavar="NODE",
                   help="print each node's parameters for this scenario (NODE: only that "
                        "node's, e.g. foot_controller_DL) and exit")


def run(args) -> int:
    scenario = load_scenario(args.scenario)
    stem = Path(str(scenario.machine.config.source)).stem
    bag = args.bag or Path("bags") / f"{stem}_{time.strftime('%Y%m%d_%H%M%S')}.mcap"
    if args.list_params is not None:
        print_parameters(scenario, bag, args.list_params)
        return 0
    logs = args.logs or bag.with_name(bag.stem + "_logs")
    record_graph(args.scenario, bag, logs, "composed" if args.composed else "processes",
                 {"mode": "realtime"} if args.realtime else None)
    return 0


def record_graph(scenario: str, bag: Path, logs: Path, layout: str = "processes",
                 plant_params: dict | None = None) -> Path:
    """Run ``scenario`` through the ROS graph, recording ``bag``; prints progress and the
    messages published and recorded per topic (RotorAvcError when any was lost)."""
    try:
        from ..nodes.graph import run_graph
    except ImportError as exc:
        raise RotorAvcError(f"the ROS graph needs rclpy ({exc}) -- fix: pip install "
                            "-r requirements-ros.txt, or source a ROS 2 Jazzy installation")
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    print(f"{scenario}: starting the graph ({layout}; logs in {logs})")
    bar = _SampleProgress()
    try:
        result = run_graph(scenario, bag, logs, progress=bar.update, layout=layout,
                           plant_params=plant_params)
    finally:
        bar.close()
    print(f"{scenario}: {result.steps} samples in {result.wall_s:.1f} s "
          f"({result.steps / max(result.wall_s, 1e-9):.0f} samples/s, start-up included) -> {bag}")
    print(f"  {'topic':<32} {'published':>10} {'recorded':>10}")
    for topic, c in sorted(result.counts.items()):
        published = "?" if c["published"] is None else c["published"]
        print(f"  {topic:<32} {published:>10} {c['recorded']:>10}")
    lost = result.lost()
    if lost:
        raise RotorAvcError(f"{bag}: messages were lost ({lost}); see the logs in {logs}")
    return bag


class _SampleProgress:
    """The plant's ``(sample, samples_total)`` as a progress bar with the time left."""

    def __init__(self):
        self.bar: Progress | None = None

    def update(self, k: int, n: int) -> None:
        if self.bar is None:
            self.bar = Progress(n, unit="samples")
        self.bar.update(min(k, n))

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def print_parameters(scenario, bag: Path, node: str = "") -> None:
    """Every node of the scenario's graph (``node``: that one only) with its declared parameters
    (rclpy needed: the tables live in the node modules; an unknown ``node`` is refused first)."""
    import importlib
    from ..nodes.graph_nodes import graph_nodes
    specs = graph_nodes(scenario, bag)
    names = [spec.name for spec in specs]
    if node and node not in names:
        raise ConfigError("--list-params", f"no node {node!r} in this scenario's graph"
                          + did_you_mean(node, names),
                          fix="give one of " + ", ".join(names))
    for spec in specs:
        if node and spec.name != node:
            continue
        try:
            params = importlib.import_module(f"rotor_avc.nodes.{spec.executable}").PARAMS
        except ImportError as exc:
            raise RotorAvcError(f"the node tables need rclpy ({exc}) -- fix: pip install "
                                "-r requirements-ros.txt") from None
        print(f"{spec.name} (ros2 run rotor_avc {spec.executable}):")
        for p in params:
            given = spec.parameters.get(p.name, p.default)
            limits = ([f"one of {'|'.join(p.choices)}"] if p.choices else []) + [
                f"{op} {v:g}" for op, v in ((">=", p.minimum), ("<=", p.maximum)) if v is not None]
            mark = "" if p.name not in spec.parameters else "  (set by the run)"
            print(f"  {p.name:<24} {type(p.default).__name__:<6} {given!r:<28}{mark}")
            print(f"      {p.description}" + (f" [{', '.join(limits)}]" if limits else ""))
    sys.stdout.flush()
