"""``rotor-avc layouts``: Foxglove and PlotJuggler layouts of what a scenario's graph publishes
(rotor_avc.reports.layout_panels, rotor_avc.reports.layout_files)."""
from __future__ import annotations

import argparse
import re
from pathlib import Path

from ..bag import topics as T
from ..reports.layout_files import write_layouts
from ..reports.layout_panels import layout_panels
from ..scenario import load_scenario
from .common import output_folder

NAME = "layouts"
HELP = ("Foxglove and PlotJuggler layouts generated from a scenario: only the topics its ROS "
        "graph publishes; bearing-housing vibration, actuator forces, shaft speed and, where "
        "the scenario runs them, the balancer's and the harmonic controller's arrays, each "
        "array element named by its label: <out>/<name>.foxglove.json and "
        "<out>/<name>.plotjuggler.xml.")
EXAMPLE = "rotor-avc layouts scenario_demo_case3 --out out/layouts"


def _word(pattern: str, allowed: str):
    """An argument that must match ``pattern`` (``allowed`` says what in the error)."""
    def parse(text: str) -> str:
        if not re.fullmatch(pattern, text):
            raise argparse.ArgumentTypeError(f"{text!r}: use {allowed}")
        return text
    return parse


def add_arguments(p) -> None:
    p.add_argument("scenario", help="scenario config: a YAML path or a shipped name "
                                    "(scenario_demo_case3, scenario_harmonic_case2_steady, ...)")
    p.add_argument("--out", type=output_folder, default=Path("."),
                   help="output folder (default: the current folder)")
    p.add_argument("--name", type=_word(r"\w[\w.-]*", "letters, digits, _ . - (no folders)"),
                   default=None,
                   help="file name stem (default: the scenario's file name)")
    p.add_argument("--namespace",
                   type=_word(r"[A-Za-z]\w*", "a ROS name: letters, digits and _, first a letter"),
                   default=T.NAMESPACE,
                   help=f"the graph's topic namespace (default: {T.NAMESPACE})")


def run(args) -> int:
    scenario = load_scenario(args.scenario)
    stem = Path(args.scenario).stem
    panels = layout_panels(scenario, args.namespace)
    for path in write_layouts(panels, args.out, args.name or stem, stem, args.namespace):
        print(path)
    for panel in panels:
        shown = ", ".join(s.label for s in panel.series) or panel.topic
        print(f"  {panel.title}: {shown}")
    return 0
