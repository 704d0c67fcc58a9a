"""A scenario's viewer layouts as files (``rotor-avc layouts``): ``<name>.foxglove.json`` for
Foxglove and ``<name>.plotjuggler.xml`` for PlotJuggler, from the panels of
rotor_avc.reports.layout_panels, each series spelled as the tool names it:

* Foxglove: message paths ``/topic.field.sub[i]``; a plot's ``paths`` carry the series' label
  (the array element's name); whole-topic panels (Raw Messages, Diagnostic Summary); the panels
  tiled in a mosaic;
* PlotJuggler (ROS 2 parser): series ``/topic/field/sub[i]``, a JointState's as
  ``/topic/<joint>/<position|velocity>``; a labelled array's element becomes a custom series
  named ``<last part of the topic>/<label>`` (``observables/bearing_D_vz``: a Lua ``return
  value`` linked to ``/avc/plant/observables/data[10]``), so the curve carries the element's
  name; one tab of the machine's panels, one of the blocks'.

Stamps start at t = 0 (the graph runs on simulated time), so both tools show the time since
the start: Foxglove's plots on their ``timestamp`` axis, PlotJuggler with its relative time
offset (``use_relative_time_offset``) on.
"""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

from ..bag import topics as T
from ..block_kinds import JOINT_STATE, OBSERVABLES
from ..output_files import make_folder, write_text
from .layout_panels import Panel, Series

#: PlotJuggler's and Foxglove's curve colours, in turn
COLOURS = ("#1f77b4", "#d62728", "#1ac938", "#ff7f0e", "#f14cc1", "#9467bd", "#17becf",
           "#bcbd22")
JOINT_STATE_TYPE = T.TOPIC_TYPES[JOINT_STATE]
ARRAY_TYPE = T.TOPIC_TYPES[OBSERVABLES]          # every labelled array's
#: the joint names of the package's rotor/joint_state (rotor_avc.bag.topics.joint_state)
JOINTS = T.joint_state([0.0], [0.0], [0.0]).template["name"]
#: the PlotJuggler tab of each group of panels
TABS = {"machine": "machine", "blocks": "balancer, harmonic control"}
FOXGLOVE_KIND = {"plot": "Plot", "raw": "RawMessages", "diagnostics": "DiagnosticSummary"}


def foxglove_path(s: Series) -> str:
    """``/topic.field.sub[i]``."""
    return f"{s.topic}.{s.field}" + ("" if s.index is None else f"[{s.index}]")


def plotjuggler_series(s: Series, namespace: str) -> tuple[str, str | None]:
    """``(curve name, linked source)``: the ROS 2 parser's series name, or for a labelled
    array's element a custom series ``<last part of the topic>/<label>`` linked to it
    (``estimate/static_re``)."""
    msg_type = T.message_type(s.topic, namespace)
    if msg_type == JOINT_STATE_TYPE:
        return f"{s.topic}/{JOINTS[s.index]}/{s.field}", None
    raw = f"{s.topic}/{s.field.replace('.', '/')}" + ("" if s.index is None else f"[{s.index}]")
    if msg_type == ARRAY_TYPE:
        return f"{s.topic.rsplit('/', 1)[1]}/{s.label}", raw
    return raw, None


def _mosaic(keys: list[str], direction: str = "row"):
    """The panels tiled: halves side by side, then stacked, in turn."""
    if len(keys) == 1:
        return keys[0]
    half = (len(keys) + 1) // 2
    other = "column" if direction == "row" else "row"
    return {"direction": direction, "first": _mosaic(keys[:half], other),
            "second": _mosaic(keys[half:], other),
            "splitPercentage": round(100 * half / len(keys))}


def _foxglove_panel(panel: Panel) -> dict:
    if panel.kind == "raw":
        return {"topicPath": panel.topic, "diffEnabled": False, "diffMethod": "custom",
                "diffTopicPath": "", "showFullMessageForDiff": False, "expansion": "all"}
    if panel.kind == "diagnostics":
        return {"topicToRender": panel.topic, "pinnedIds": [], "hardwareIdFilter": "",
                "sortByLevel": True}
    return {"foxglovePanelTitle": panel.title,
            "paths": [{"value": foxglove_path(s), "enabled": True,
                       "timestampMethod": "receiveTime", "label": s.label,
                       "color": COLOURS[i % len(COLOURS)]}
                      for i, s in enumerate(panel.series)],
            "showXAxisLabels": True, "showYAxisLabels": True, "showLegend": True,
            "legendDisplay": "floating", "showPlotValuesInLegend": False, "isSynced": True,
            "xAxisVal": "timestamp", "sidebarDimension": 240}


def foxglove_layout(panels: list[Panel]) -> dict:
    """A Foxglove layout (``configById``, ``layout`` mosaic, ``playbackConfig`` ...)."""
    configs = {f"{FOXGLOVE_KIND[p.kind]}!{p.key}": _foxglove_panel(p) for p in panels}
    return {"configById": configs, "globalVariables": {}, "userNodes": {},
            "playbackConfig": {"speed": 1.0}, "layout": _mosaic(list(configs))}


def _plotjuggler_tab(parent, title: str, panels: list[Panel], namespace: str, snippets) -> None:
    tab = ET.SubElement(parent, "Tab", tab_name=title, containers="1")
    split = ET.SubElement(ET.SubElement(tab, "Container"), "DockSplitter", orientation="-",
                          count=str(len(panels)),
                          sizes=";".join([f"{1 / len(panels):.6f}"] * len(panels)))
    for panel in panels:
        plot = ET.SubElement(ET.SubElement(split, "DockArea", name=panel.title), "plot",
                             mode="TimeSeries", style="Lines", flip_x="false", flip_y="false")
        ET.SubElement(plot, "range", left="0", right="1", top="1", bottom="-1")
        ET.SubElement(plot, "limitY")
        for i, s in enumerate(panel.series):
            name, source = plotjuggler_series(s, namespace)
            ET.SubElement(plot, "curve", name=name, color=COLOURS[i % len(COLOURS)])
            if source is not None:
                snippets[name] = source


def plotjuggler_layout(panels: list[Panel], scenario: str, namespace: str = T.NAMESPACE) -> str:
    """A PlotJuggler layout (XML text): the plots on two tabs, the labelled arrays' elements as
    custom series, the MCAP loader and the ROS 2 topic subscriber."""
    root = ET.Element("root")
    tabs = ET.SubElement(root, "tabbed_widget", name="Main Window", parent="main_window")
    snippets: dict[str, str] = {}
    for group, tab_title in TABS.items():
        members = [p for p in panels if p.kind == "plot" and p.group == group]
        if members:
            _plotjuggler_tab(tabs, tab_title, members, namespace, snippets)
    ET.SubElement(tabs, "currentTabIndex", index="0")
    ET.SubElement(root, "use_relative_time_offset", enabled="1")
    plugins = ET.SubElement(root, "Plugins")
    for plugin in ("DataLoad MCAP", "ROS2 Topic Subscriber"):
        ET.SubElement(plugins, "plugin", ID=plugin)
    ET.SubElement(root, "previouslyLoaded_Datafiles")
    equations = ET.SubElement(root, "customMathEquations")
    for name, source in snippets.items():
        snippet = ET.SubElement(equations, "snippet", name=name, language="LUA")
        ET.SubElement(snippet, "global").text = ""
        ET.SubElement(snippet, "function").text = "return value"
        ET.SubElement(snippet, "linked_source").text = source
    ET.SubElement(root, "snippets")
    ET.indent(root, space=" ")
    return ("<?xml version='1.0' encoding='UTF-8'?>\n"
            f"<!-- rotor_avc: PlotJuggler layout of {scenario} (rotor-avc layouts) -->\n"
            + ET.tostring(root, encoding="unicode") + "\n")


def write_layouts(panels: list[Panel], folder, name: str, scenario: str,
                  namespace: str = T.NAMESPACE) -> list[Path]:
    """``<folder>/<name>.foxglove.json`` and ``<name>.plotjuggler.xml`` of ``panels``
    (rotor_avc.reports.layout_panels.layout_panels) of ``scenario`` (its name)."""
    folder = make_folder(folder)
    return [write_text(folder / f"{name}.foxglove.json",
                       json.dumps(foxglove_layout(panels), indent=2) + "\n"),
            write_text(folder / f"{name}.plotjuggler.xml",
                       plotjuggler_layout(panels, scenario, namespace))]
