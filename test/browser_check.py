"""Open a report in headless Chromium (Debian package ``chromium``) and check that it loads
without errors and that every plot rendered. Tests that use it are skipped without Chromium."""
import re
import shutil
import subprocess

import pytest

from rotor_avc.interactive.page import ERRORS_ID


def chromium() -> str:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium)")
    return exe


def rendered_dom(path) -> tuple[str, str]:
    """The page's DOM after its scripts ran, and Chromium's log."""
    proc = subprocess.run(
        [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--enable-logging=stderr", "--v=0", "--virtual-time-budget=20000",
         "--dump-dom", path.resolve().as_uri()],
        capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout, proc.stderr


def check_report(path) -> int:
    """Assert that the report at ``path`` loaded without a page error and that each of its
    plots holds a rendered plotly SVG; returns the number of plots."""
    dom, log = rendered_dom(path)
    console = [line for line in log.splitlines() if "CONSOLE" in line and "Uncaught" in line]
    assert not console, console
    errors = re.search(rf'<div id="{ERRORS_ID}"[^>]*>(.*?)</div>', dom, re.S)
    assert errors is not None and errors.group(1).strip() == "", errors and errors.group(1)
    plots = re.findall(r'<div class="plot[^"]*" id="([^"]+)"', dom)
    assert plots, "no plot in the page"
    rendered = re.search(r'<body[^>]*data-rendered="(\d+)"', dom)
    assert rendered is not None and int(rendered.group(1)) == len(plots)
    for pid in plots:
        start = dom.index(f'id="{pid}"')
        nxt = [dom.find(f'id="{q}"', start + 1) for q in plots if q != pid]
        end = min([i for i in nxt if i > start] + [len(dom)])
        assert "main-svg" in dom[start:end], f"plot {pid} did not render"
    return len(plots)
