"""Open a report in headless Chromium (Debian package ``chromium``), with no network, and check
the template every report shares (rotor_avc.interactive.page): it loads ``plotly.min.js`` from
its own folder, shows no page error, every plot rendered, the links of its contents resolve, the
page is small, and the speed selector redraws every plot with a rotor speed (opened with
``?speed=rpm``: each such axis then says rpm). Tests that use it are skipped without Chromium."""
import re
import shutil
import subprocess

import numpy as np
import pytest

from rotor_avc.interactive.page import ERRORS_ID, PLOTLY_FILE, plotly_js

#: the largest page of a test's report [bytes] (plotly.js, 4.8 MB, is not in it)
MAX_PAGE_BYTES = 400_000
#: where plotly writes the title of the axis (colour bar) of each trace key
TITLE = {"x": r'<text class="xtitle"[^>]*data-unformatted="([^"]*)"',
         "y": r'<text class="ytitle"[^>]*data-unformatted="([^"]*)"',
         "z": r'class="cbtitle"[^>]*><text[^>]*data-unformatted="([^"]*)"'}


def chromium() -> str:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium)")
    return exe


def rendered_dom(path, query: str = "") -> tuple[str, str]:
    """The page's DOM after its scripts ran, and Chromium's log; every host name fails to
    resolve (no network)."""
    proc = subprocess.run(
        [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--host-resolver-rules=MAP * ~NOTFOUND", "--enable-logging=stderr", "--v=0",
         "--virtual-time-budget=20000", "--dump-dom", path.resolve().as_uri() + query],
        capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout, proc.stderr


def _plot_regions(dom: str, plots: list[str]) -> dict[str, str]:
    """Each plot's part of the DOM (from its id to the next plot's)."""
    out = {}
    for pid in plots:
        start = dom.index(f'id="{pid}"')
        nxt = [dom.find(f'id="{q}"', start + 1) for q in plots if q != pid]
        out[pid] = dom[start:min([i for i in nxt if i > start] + [len(dom)])]
    return out


def check_report(path, max_bytes: int = MAX_PAGE_BYTES, opens_in: str = "hz",
                 symlog: dict | None = None) -> int:
    """Assert the template's promises (module docstring) of the report at ``path``: it opens in
    the speed unit ``opens_in`` and the other one, asked for in the URL, titles every speed
    axis; ``symlog``: plot id -> x0 of the plots whose x axis must be symmetric-log (their tick
    positions follow sign(v) log10(1 + |v|/x0) of the labels, not v). Returns the number of
    plots."""
    text = path.read_text()
    assert len(text.encode()) <= max_bytes, f"{path.name}: {len(text.encode())} bytes"
    scripts = re.findall(r'<script src="([^"]+)"', text)
    assert scripts == [PLOTLY_FILE] and (path.parent / PLOTLY_FILE).read_text() == plotly_js()
    speeds = dict(re.findall(r'<div class="plot" id="([^"]+)" data-speed-axis="([xyz])"', text))
    other = {"hz": "rpm", "rpm": "hz"}[opens_in]
    if speeds:
        assert f'<option value="{opens_in}" selected>' in text
    dom, log = rendered_dom(path, f"?speed={other}" if speeds else "")
    console = [line for line in log.splitlines() if "CONSOLE" in line and "Uncaught" in line]
    assert not console, console
    errors = re.search(rf'<div id="{ERRORS_ID}"[^>]*>(.*?)</div>', dom, re.S)
    assert errors is not None and errors.group(1).strip() == "", errors and errors.group(1)
    plots = re.findall(r'<div class="plot[^"]*" id="([^"]+)"', dom)
    assert plots, "no plot in the page"
    rendered = re.search(r'<body[^>]*data-rendered="(\d+)"', dom)
    assert rendered is not None and int(rendered.group(1)) == len(plots)
    regions = _plot_regions(dom, plots)
    for pid, region in regions.items():
        assert "main-svg" in region, f"plot {pid} did not render"
    ids = set(re.findall(r'\sid="([^"]+)"', dom))
    toc = re.search(r'<nav class="toc">(.*?)</nav>', dom, re.S)
    links = re.findall(r'href="#([^"]+)"', toc.group(1))
    assert links and set(links) <= ids, set(links) - ids
    unit = {"hz": "[Hz]", "rpm": "[rpm]"}[other]
    for pid, key in speeds.items():
        titles = re.findall(TITLE[key], regions[pid])
        assert titles and titles[0].endswith(unit), (pid, titles)
    for pid, x0 in (symlog or {}).items():
        ticks = tick_positions(regions[pid])
        assert len(ticks) >= 3, ticks
        on_symlog, on_linear = symlog_residuals(ticks, x0)
        assert on_symlog < 1e-3 < 0.05 < on_linear, (pid, ticks)
    return len(plots)


def tick_positions(region: str) -> dict[float, float]:
    """Label value -> x position of each x tick of a rendered plot."""
    out = {}
    for tick in re.findall(r'<g class="xtick">(.*?)</g>', region, re.S):
        label = re.search(r'data-unformatted="([^"]+)"', tick).group(1)
        x = re.search(r"translate\(([-\d.e]+)", tick).group(1)
        out[float(label.replace("\u2212", "-"))] = float(x)
    return out


def symlog_residuals(ticks: dict[float, float], x0: float) -> tuple[float, float]:
    """RMS residual of a straight-line fit of the tick positions against sign(v) log10(1 +
    |v|/x0), and against the values v themselves (relative to the axis' pixel span)."""
    v = np.array(sorted(ticks))
    px = np.array([ticks[k] for k in v])
    span = px.max() - px.min()

    def residual(u):
        A = np.column_stack([u, np.ones_like(u)])
        fit = np.linalg.lstsq(A, px, rcond=None)[0]
        return float(np.sqrt(np.mean((A @ fit - px) ** 2)) / span)
    return residual(np.sign(v) * np.log10(1 + np.abs(v) / x0)), residual(v)
