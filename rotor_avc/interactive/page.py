"""Self-contained interactive HTML pages: plotly.js embedded (no network at view time), every
plot zoomable (drag a box; wheel), pannable (the toolbar's pan tool) and readable (hover shows
the values; double-click resets).

A page is a list of :class:`Figure` -- plotly traces whose speed axes are given in Hz and whose
magnitudes in SI units -- and two selectors that redraw every plot: speed axis in rpm or Hz,
magnitude in dB (re 1 SI unit) or SI units. Sections of HTML text and tables go between plots.
"""
from __future__ import annotations

import html
import json
from dataclasses import dataclass, field

from .jsonable import jsonable

#: a window error or a failed plot is written into this element (and counted by the page check)
ERRORS_ID = "report-errors"


@dataclass
class Figure:
    """One plot: ``traces`` in plotly's form; ``speed_axis`` names the trace key holding the
    rotor speed in Hz (``"x"``, or ``None``), ``magnitude_key`` the key holding magnitudes in SI
    units (``"y"``, ``"z"`` or ``None``)."""

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


def _figure_spec(fig: Figure) -> dict:
    return jsonable({"id": fig.id, "title": fig.title, "traces": fig.traces,
                      "xTitle": fig.x_title, "yTitle": fig.y_title, "unit": fig.unit,
                      "speedKey": fig.speed_axis, "magKey": fig.magnitude_key,
                      "layout": fig.layout, "height": fig.height_px})


#: runs before plotly.js: every uncaught error and console.error of the page is kept and shown
_CAPTURE = r"""
window.reportErrors = [];
function paintErrors() {
  const box = document.getElementById('%(errors)s');
  if (box && window.reportErrors.length) {
    box.style.display = 'block';
    box.textContent = window.reportErrors.join('\n');
  }
}
function showError(text) { window.reportErrors.push(text); paintErrors(); }
window.addEventListener('error', e => showError('error: ' + e.message));
const consoleError = console.error.bind(console);
console.error = (...args) => { showError('console: ' + args.join(' ')); consoleError(...args); };
"""

_SCRIPT = r"""
const FIGS = %(figs)s;
paintErrors();
function db(v) { return v === null ? null : 20 * Math.log10(Math.max(Math.abs(v), 1e-300)); }
function mapDeep(a, f) { return Array.isArray(a) ? a.map(v => mapDeep(v, f)) : f(a); }
function render() {
  const rpm = document.getElementById('speed-unit').value === 'rpm';
  const inDb = document.getElementById('magnitude-unit').value === 'db';
  let done = 0;
  for (const f of FIGS) {
    const traces = f.traces.map(t => {
      const u = Object.assign({}, t);
      if (f.speedKey && t[f.speedKey]) u[f.speedKey] = mapDeep(t[f.speedKey], v => rpm ? v * 60 : v);
      if (f.magKey && t[f.magKey] && inDb) u[f.magKey] = mapDeep(t[f.magKey], db);
      return u;
    });
    const layout = Object.assign({title: {text: f.title, font: {size: 14}}, height: f.height,
                                  hovermode: 'closest', margin: {t: 40, l: 70, r: 20, b: 50},
                                  legend: {orientation: 'h', y: -0.18}},
                                 JSON.parse(JSON.stringify(f.layout)));
    const xt = f.speedKey === 'x' ? f.xTitle + (rpm ? ' [rpm]' : ' [Hz]') : f.xTitle;
    const yt = f.magKey === 'y' ? f.yTitle + (inDb ? ' [dB re 1 ' + f.unit + ']' : ' [' + f.unit + ']') : f.yTitle;
    layout.xaxis = Object.assign({title: {text: xt}}, layout.xaxis || {});
    layout.yaxis = Object.assign({title: {text: yt}}, layout.yaxis || {});
    if (f.magKey === 'z') traces.forEach(t => { if (t.colorbar) t.colorbar = Object.assign({}, t.colorbar,
        {title: {text: inDb ? 'dB re 1 ' + f.unit : f.unit}}); });
    try {
      Plotly.react(f.id, traces, layout, {responsive: true, scrollZoom: true, displaylogo: false});
      done += 1;
    } catch (err) { showError(f.id + ': ' + err); }
  }
  document.body.dataset.rendered = String(done);
}
document.getElementById('speed-unit').addEventListener('change', render);
document.getElementById('magnitude-unit').addEventListener('change', render);
render();
"""

_CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1100px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 3px 8px; text-align: left; }
th { background: #f2f2f2; } td.num { text-align: right; }
.pass { color: #17702f; font-weight: bold; } .fail { color: #b00020; font-weight: bold; }
.controls { position: sticky; top: 0; background: #fff; padding: 0.4em 0; border-bottom: 1px solid #ddd; z-index: 10; }
.plot { width: 100%; } .note { color: #555; font-size: 0.9em; }
#report-errors { display: none; color: #b00020; white-space: pre; }
"""


def plotly_js() -> str:
    """The plotly.js bundle shipped with the ``plotly`` package (embedded, so the page needs
    no network)."""
    from plotly.offline import get_plotlyjs
    return get_plotlyjs()


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


def page(title: str, blocks: list, default_speed_unit: str = "hz",
         default_magnitude_unit: str = "si") -> str:
    """A complete HTML page: ``blocks`` are :class:`Figure` or HTML strings, in order."""
    figs, parts = [], []
    for block in blocks:
        if isinstance(block, Figure):
            figs.append(_figure_spec(block))
            parts.append(f'<div class="plot" id="{html.escape(block.id)}"></div>')
        else:
            parts.append(block)

    def option(value, label, default):
        return f'<option value="{value}"{" selected" if value == default else ""}>{label}</option>'

    controls = (
        '<div class="controls">speed axis <select id="speed-unit">'
        + option("hz", "Hz", default_speed_unit) + option("rpm", "rpm", default_speed_unit)
        + '</select> &nbsp; magnitudes <select id="magnitude-unit">'
        + option("si", "SI units", default_magnitude_unit) + option("db", "dB", default_magnitude_unit)
        + '</select> <span class="note">drag a box or turn the wheel to zoom, pan with the '
          'toolbar\'s pan tool, hover to read values, double-click to reset</span></div>')
    data = json.dumps(figs, allow_nan=False).replace("</", "<\\/")     # no "</script>" inside
    script = _SCRIPT % {"figs": data, "errors": ERRORS_ID}
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(title)}</title><style>{_CSS}</style>"
            f"<script>{_CAPTURE % {'errors': ERRORS_ID}}</script>"
            f"<script>{plotly_js()}</script></head><body>"
            f"<h1>{html.escape(title)}</h1>{controls}<div id=\"{ERRORS_ID}\"></div>"
            + "\n".join(parts) + f"<script>{script}</script></body></html>")
