"""The one template of every interactive HTML report: a table of contents, then sections of
text and tables with plots between them; every plot zoomable (drag a box; wheel), pannable (the
toolbar's pan tool) and readable (hover shows the values; double-click resets).

A page is a list of blocks: :class:`Figure` (plotly traces whose rotor speeds are given in Hz
and whose magnitudes in SI units) and HTML strings (their ``<h2>`` headings are the sections of
the contents). The same defaults hold on every page: speed axes in Hz, magnitudes in SI units;
a speed selector (rpm or Hz) is shown where a plot has a rotor speed and redraws every such
plot, a magnitude selector (dB re 1 SI unit, or SI units) where a plot has a magnitude. The URL
query chooses them too (``index.html?speed=rpm&magnitude=db``). Figure titles are written above
the plots, clear of plotly's toolbar; legends stand at the right of the plot, never under an
axis title.

:func:`write_page` writes the page and, once per folder, ``plotly.min.js`` from the ``plotly``
package beside it; the page loads it by a relative link, so it opens from the file system with
no network (copy the folder whole). The data of the plots are thinned and rounded for drawing
(:mod:`rotor_avc.interactive.plot_data`); the files beside a page hold them in full.
"""
from __future__ import annotations

import html
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..output_files import write_text
from .jsonable import jsonable
from .page_script import CAPTURE, CSS, SCRIPT
from .plot_data import coloured, rounded, thinned

#: a window error or a failed plot is written into this element (and counted by the page check)
ERRORS_ID = "report-errors"
#: the plotly.js bundle every page loads from its own folder
PLOTLY_FILE = "plotly.min.js"
#: the speed unit every page opens with ("hz" or "rpm")
DEFAULT_SPEED_UNIT = "hz"
#: in a hover template, replaced by the speed unit shown ("Hz" or "rpm")
SPEED_UNIT = "{speed_unit}"
#: a section with more plots than this lists them folded in the contents
FOLD_AFTER = 6


@dataclass
class Figure:
    """One plot: ``traces`` in plotly's form; ``speed_axis`` names the trace key holding the
    rotor speed in Hz (``"x"``, ``"y"``, ``"z"`` or ``None``), ``magnitude_key`` the key holding
    magnitudes in SI units of ``unit`` (``"y"``, ``"z"`` or ``None``); the axis titles get the
    unit shown appended. ``z_title`` is the colour bar's title of a heatmap."""

    id: str
    title: str
    traces: list[dict]
    x_title: str = "rotor speed"
    y_title: str = ""
    unit: str = ""
    speed_axis: str | None = "x"
    magnitude_key: str | None = None
    layout: dict = field(default_factory=dict)
    height_px: int = 420
    z_title: str = ""


def _figure_spec(fig: Figure) -> dict:
    traces = coloured([thinned(t, fig.magnitude_key == "y") for t in fig.traces])
    return rounded(jsonable({"id": fig.id, "traces": traces, "xTitle": fig.x_title,
                             "yTitle": fig.y_title, "zTitle": fig.z_title, "unit": fig.unit,
                             "speedKey": fig.speed_axis, "magKey": fig.magnitude_key,
                             "layout": fig.layout, "height": fig.height_px}))


def plotly_js() -> str:
    """The plotly.js bundle shipped with the ``plotly`` package."""
    from plotly.offline import get_plotlyjs
    return get_plotlyjs()


def write_plotly_js(folder: Path) -> Path:
    """``folder/plotly.min.js``, written only when absent or different from the package's."""
    path = Path(folder) / PLOTLY_FILE
    bundle = plotly_js()
    try:
        same = path.read_text(encoding="utf-8") == bundle
    except (OSError, UnicodeDecodeError):
        same = False
    return path if same else write_text(path, bundle)


def table_html(rows: list[dict], columns: list[tuple[str, str]], classes=None) -> str:
    """An HTML table of ``rows`` with ``columns`` = (key, heading); floats to 5 significant digits;
    ``classes``: key -> function(value) -> CSS class of that cell."""
    head = "".join(f"<th>{html.escape(h)}</th>" for _, h in columns)
    body = []
    for r in rows:
        cells = []
        for key, _ in columns:
            v = r.get(key)
            text = "-" if v is None else (f"{v:.5g}" if isinstance(v, float) else str(v))
            cls = (classes or {}).get(key, lambda _: "num" if isinstance(v, (int, float)) else "")(v)
            cells.append(f'<td class="{cls}">{html.escape(text)}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def _value_text(v) -> str:
    if isinstance(v, dict):
        return "; ".join(f"{k} = {_value_text(x)}" for k, x in v.items())
    if isinstance(v, (list, tuple)):
        return ", ".join(_value_text(x) for x in v)
    return "-" if v is None else (f"{v:.6g}" if isinstance(v, float) else str(v))


def key_value_table(items) -> str:
    """A two-column table (item, value) of a mapping or of (key, value) pairs; nested values
    as ``k = v; ...`` and lists joined by commas."""
    pairs = items.items() if isinstance(items, dict) else items
    return table_html([{"k": str(k), "v": _value_text(v)} for k, v in pairs],
                      [("k", "item"), ("v", "value")])


def _anchor(prefix: str, text: str, taken: set) -> str:
    base = prefix + (re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-").lower() or "x")
    anchor, k = base, 2
    while anchor in taken:
        anchor, k = f"{base}-{k}", k + 1
    taken.add(anchor)
    return anchor


def _layout(blocks: list) -> tuple[list[str], list[dict], list[dict]]:
    """(body parts, figure specs, contents): each ``<h2>`` of the HTML blocks gets an id and
    starts a section of the contents; each figure its caption and a place in the section."""
    parts, specs, contents, taken = [], [], [{"id": None, "title": None, "figs": []}], set()

    def heading(match):
        title = html.unescape(re.sub(r"<[^>]+>", "", match.group(2)))
        anchor = _anchor("sec-", title, taken)
        contents.append({"id": anchor, "title": title, "figs": []})
        return f'<h2 id="{anchor}"{match.group(1)}>{match.group(2)}</h2>'

    for block in blocks:
        if isinstance(block, Figure):
            specs.append(_figure_spec(block))
            anchor = _anchor("fig-", block.id, taken)
            contents[-1]["figs"].append((anchor, block.title))
            axis = f' data-speed-axis="{block.speed_axis}"' if block.speed_axis else ""
            parts.append(f'<div class="figure" id="{anchor}"><p class="fig-title">'
                         f'{html.escape(block.title)}</p><div class="plot" '
                         f'id="{html.escape(block.id)}"{axis}></div></div>')
        else:
            parts.append(re.sub(r"<h2((?:\s[^>]*)?)>(.*?)</h2>", heading, block, flags=re.S))
    return parts, specs, [c for c in contents if c["id"] or c["figs"]]


def _contents_html(contents: list[dict]) -> str:
    def figs(items):
        links = "".join(f'<li><a href="#{a}">{html.escape(t)}</a></li>' for a, t in items)
        if len(items) > FOLD_AFTER:
            return (f"<details><summary>{len(items)} plots</summary>"
                    f'<ul class="toc-figs">{links}</ul></details>')
        return f'<ul class="toc-figs">{links}</ul>' if items else ""

    rows = []
    for c in contents:
        head = (f'<a href="#{c["id"]}">{html.escape(c["title"])}</a>' if c["id"]
                else "plots")
        rows.append(f"<li>{head}{figs(c['figs'])}</li>")
    return f'<nav class="toc"><b>Contents</b><ol>{"".join(rows)}</ol></nav>'


def _select(name: str, label: str, options, chosen: str) -> str:
    opts = "".join(f'<option value="{v}"{" selected" if v == chosen else ""}>{t}</option>'
                   for v, t in options)
    return f'{label} <select id="{name}">{opts}</select> &nbsp; '


def page(title: str, blocks: list, speed_unit: str = DEFAULT_SPEED_UNIT) -> str:
    """A complete HTML page (module docstring): ``blocks`` are :class:`Figure` or HTML strings,
    in order; ``speed_unit`` the speed unit it opens with (a user's choice; the default is the
    same on every page)."""
    parts, specs, contents = _layout(blocks)
    controls = ""
    if any(s["speedKey"] for s in specs):
        controls += _select("speed-unit", "speed axis", (("hz", "Hz"), ("rpm", "rpm")), speed_unit)
    if any(s["magKey"] for s in specs):
        controls += _select("magnitude-unit", "magnitudes", (("si", "SI units"), ("db", "dB")), "si")
    if specs:
        controls = (f'<div class="controls">{controls}<span class="note">drag a box or turn the '
                    "wheel to zoom, pan with the toolbar's pan tool, hover to read values, "
                    "double-click to reset</span></div>")
    data = json.dumps(specs, allow_nan=False).replace("</", "<\\/")     # no "</script>" inside
    footer = (f'<p class="note">This page loads {PLOTLY_FILE} (plotly.js) from its own folder: '
              "copy the folder whole. The plots are drawn from data thinned and rounded for "
              "drawing; the files beside the page hold them in full.</p>")
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(title)}</title><style>{CSS}</style>"
            f"<script>{CAPTURE % {'errors': ERRORS_ID}}</script>"
            f'<script src="{PLOTLY_FILE}"></script></head><body>'
            f"<h1>{html.escape(title)}</h1>{_contents_html(contents)}{controls}"
            f'<div id="{ERRORS_ID}"></div>' + "\n".join(parts) + footer
            + f"<script>{SCRIPT % {'figs': data, 'speed': json.dumps(SPEED_UNIT)}}</script>"
            "</body></html>")


def write_page(path, title: str, blocks: list, speed_unit: str = DEFAULT_SPEED_UNIT) -> Path:
    """Write :func:`page` to ``path`` and ``plotly.min.js`` beside it (:func:`write_plotly_js`);
    returns ``path``."""
    path = Path(path)
    write_plotly_js(path.parent)
    return write_text(path, page(title, blocks, speed_unit))


def page_files(path) -> list[Path]:
    """The files a page written by :func:`write_page` needs: itself and its plotly.min.js."""
    return [Path(path), Path(path).parent / PLOTLY_FILE]
