"""The style and scripts of the report template (:mod:`rotor_avc.interactive.page`)."""

#: runs before plotly.js: every uncaught error and console.error of the page is kept and shown
CAPTURE = r"""
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

#: draws every figure of FIGS in the units chosen; the URL query (?speed=rpm&magnitude=db)
#: chooses them after the first drawing, through the selectors' own change events
SCRIPT = r"""
const FIGS = %(figs)s;
const SPEED_UNIT = %(speed)s;
paintErrors();
function db(v) { return v === null ? null : 20 * Math.log10(Math.max(Math.abs(v), 1e-300)); }
function mapDeep(a, f) { return Array.isArray(a) ? a.map(v => mapDeep(v, f)) : f(a); }
function chosen(id) { const e = document.getElementById(id); return e ? e.value : null; }
function withUnit(title, unit) { return title ? title + ' [' + unit + ']' : unit; }
function render() {
  if (typeof Plotly === 'undefined') {
    showError('plotly.min.js did not load: keep it in the folder of this page');
    return;
  }
  const rpm = chosen('speed-unit') === 'rpm';
  const inDb = chosen('magnitude-unit') === 'db';
  const speedUnit = rpm ? 'rpm' : 'Hz';
  let done = 0;
  for (const f of FIGS) {
    const traces = f.traces.map(t => {
      const u = Object.assign({}, t);
      if (f.speedKey && t[f.speedKey]) u[f.speedKey] = mapDeep(t[f.speedKey], v => v === null ? null : (rpm ? v * 60 : v));
      if (f.magKey && t[f.magKey] && inDb) u[f.magKey] = mapDeep(t[f.magKey], db);
      if (typeof t.hovertemplate === 'string') u.hovertemplate = t.hovertemplate.split(SPEED_UNIT).join(speedUnit);
      return u;
    });
    const titles = {x: f.xTitle, y: f.yTitle, z: f.zTitle};
    if (f.speedKey) titles[f.speedKey] = withUnit(titles[f.speedKey], speedUnit);
    if (f.magKey) titles[f.magKey] = withUnit(titles[f.magKey], inDb ? 'dB re 1 ' + f.unit : f.unit);
    const layout = Object.assign({height: f.height, hovermode: 'closest',
                                  margin: {t: 32, l: 70, r: 20, b: 50},
                                  legend: {x: 1.02, xanchor: 'left', y: 1, yanchor: 'top'}},
                                 JSON.parse(JSON.stringify(f.layout)));
    layout.xaxis = Object.assign({title: {text: titles.x}, automargin: true}, layout.xaxis || {});
    layout.yaxis = Object.assign({title: {text: titles.y}, automargin: true}, layout.yaxis || {});
    if (f.speedKey === 'z' || f.magKey === 'z' || f.zTitle) traces.forEach(t => { if (t.type === 'heatmap') t.colorbar = Object.assign({}, t.colorbar, {title: {text: titles.z}}); });
    try {
      Plotly.react(f.id, traces, layout, {responsive: true, scrollZoom: true, displaylogo: false,
                                          toImageButtonOptions: {filename: f.id}});
      done += 1;
    } catch (err) { showError(f.id + ': ' + err); }
  }
  document.body.dataset.rendered = String(done);
}
for (const id of ['speed-unit', 'magnitude-unit']) {
  const e = document.getElementById(id);
  if (e) e.addEventListener('change', render);
}
render();
const query = new URLSearchParams(window.location.search);
for (const [key, id] of [['speed', 'speed-unit'], ['magnitude', 'magnitude-unit']]) {
  const e = document.getElementById(id);
  if (e && query.has(key) && e.value !== query.get(key)) {
    e.value = query.get(key);
    e.dispatchEvent(new Event('change'));
  }
}
"""

CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1100px; color: #222; padding: 0 1em; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; } h3 { font-size: 1.05em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #f2f2f2; } td.num { text-align: right; }
.pass { color: #17702f; font-weight: bold; } .fail { color: #b00020; font-weight: bold; }
.controls { position: sticky; top: 0; background: #fff; padding: 0.4em 0; border-bottom: 1px solid #ddd; z-index: 10; }
.figure { margin-top: 1em; } .fig-title { font-weight: bold; margin: 0.8em 0 0.2em 0; text-align: left; }
.plot { width: 100%; } .note { color: #555; font-size: 0.9em; }
nav.toc { border: 1px solid #ddd; background: #fafafa; padding: 0.5em 1em; margin: 1em 0; font-size: 0.9em; }
nav.toc ol { margin: 0.3em 0; padding-left: 1.5em; } nav.toc summary { cursor: pointer; color: #555; }
ul.toc-figs { margin: 0.1em 0 0.3em 0; padding-left: 0; list-style: none; }
ul.toc-figs li { display: inline; } ul.toc-figs li + li:before { content: " \\00b7 "; color: #999; }
#report-errors { display: none; color: #b00020; white-space: pre; }
"""
