"""Progress with the time left on the commands that can run long: each one run in-process on a
small case with stderr captured (not a terminal), its bar lines ``k/N UNIT`` rising to ``N/N``
exactly once per pass, ``N`` what the command did (speeds asked, PNGs in its folder, seconds of
the recording, MB of the file, runs, test steps), and nothing of them on stdout. The figures are
not drawn (``Figure.savefig`` writes a stand-in, ``tight_layout`` does nothing): what is counted
is that each was made and written. The bar itself: the time left against a hand computation
with a stopped clock."""
import io
import json
import math
import re
from pathlib import Path

import pytest
from matplotlib.figure import Figure

from rotor_avc.cli import main
from rotor_avc.studies import progress as progress_module
from rotor_avc.studies.progress import Bars, Progress, clock_text, run_each

from test_runup import runup_bag  # noqa: F401  (the simulated run-up bag, a fixture)

ROOT = Path(__file__).resolve().parents[1]
REFERENCE_BAG = ROOT / "bags" / "reference" / "case3_stepped.mcap"
CONFIG = ROOT / "config"
BAR = re.compile(r"\] (\d+)/(\d+) (.+?) \d+(?::\d+)+ elapsed, ETA ")


@pytest.fixture
def undrawn(monkeypatch):
    """Figures made but not rendered: a PNG stand-in per ``savefig``."""
    monkeypatch.setattr(Figure, "savefig", lambda self, fname, **kw: Path(fname).write_bytes(
        b"\x89PNG stand-in"))
    monkeypatch.setattr(Figure, "tight_layout", lambda self, **kw: None)


def _run(capsys, argv, status=0) -> tuple[str, str]:
    assert main(argv) == status, argv
    captured = capsys.readouterr()
    return captured.out, captured.err


def passes(err: str, unit: str) -> list[list[tuple[int, int]]]:
    """The ``(done, total)`` of the bar lines of ``unit``, one list per pass (a pass starts
    where ``done`` goes back or ``total`` changes)."""
    out: list[list[tuple[int, int]]] = []
    for line in err.splitlines():
        m = BAR.search(line)
        if m and m.group(3) == unit:
            k, n = int(m.group(1)), int(m.group(2))
            if not out or k < out[-1][-1][0] or n != out[-1][-1][1]:
                out.append([])
            out[-1].append((k, n))
    return out


def check_bar(err: str, out: str, unit: str, total: int, n_passes: int = 1) -> None:
    """Every pass of ``unit`` rises to ``total``/``total``, reached once; none on stdout."""
    found = passes(err, unit)
    assert len(found) == n_passes, (unit, found, err)
    for lines in found:
        done = [k for k, _ in lines]
        assert done == sorted(done) and {n for _, n in lines} == {total}, lines
        assert done.count(total) == 1 and done[-1] == total, lines
    assert not BAR.search(out) and "ETA" not in out


def test_campbell_counts_speeds_and_prints_what_it_prints_without(capsys, monkeypatch):
    argv = ["campbell", "foot_mount_case2", "--speed-hz", "0:100:11", "--json"]
    out, err = _run(capsys, argv)
    check_bar(err, out, "speeds", 11)
    monkeypatch.setattr(Progress, "update", lambda self, done: None)
    quiet_out, quiet_err = _run(capsys, argv)
    assert quiet_out == out and not passes(quiet_err, "speeds")


def test_frf_counts_its_figures(capsys, tmp_path, undrawn):
    out, err = _run(capsys, ["frf", "active_bearing", "--speed-hz", "2:100:20",
                             "--out", str(tmp_path)])
    check_bar(err, out, "figures", len(list(tmp_path.glob("frf_*.png"))))


def test_compare_counts_each_pass_over_the_bag_and_the_figures(capsys, tmp_path, undrawn):
    """The reference bag spans 1 s of log time: the 1x pass and the ISO 20816-3 pass."""
    from rotor_avc.bag import BagReader
    with BagReader(REFERENCE_BAG) as bag:
        first, last = bag.time_range_ns
    out, err = _run(capsys, ["compare", str(REFERENCE_BAG), "--out", str(tmp_path)])
    check_bar(err, out, "s of recording", math.ceil((last - first) * 1e-9), n_passes=2)
    check_bar(err, out, "figures", len(list(tmp_path.glob("*.png"))))


def test_bag_integrity_counts_megabytes_of_the_file(capsys, monkeypatch):
    argv = ["bag", "info", "--integrity", str(REFERENCE_BAG)]
    out, err = _run(capsys, argv)
    check_bar(err, out, "MB", math.ceil(REFERENCE_BAG.stat().st_size / 1e6))
    monkeypatch.setattr(Progress, "update", lambda self, done: None)
    assert _run(capsys, argv)[0] == out


def test_runup_counts_its_figures(capsys, tmp_path, undrawn, runup_bag):  # noqa: F811
    capsys.readouterr()
    argv = ["runup", str(runup_bag), "--out", str(tmp_path), "--channels", "bearing_D_vz",
            "bearing_D_vy", "--operating-hz", "27:28", "--orbit-hz", "12"]
    assert main(argv) == 1                        # an API 684 row fails (test_runup.py)
    captured = capsys.readouterr()
    check_bar(captured.err, captured.out, "figures", len(list(tmp_path.glob("*.png"))))


def test_controller_counts_its_figures(capsys, tmp_path, undrawn):
    out, err = _run(capsys, ["controller", "foot_mount_case3", "--foot", "DL",
                             "--out", str(tmp_path)])
    pngs = list(tmp_path.glob("*.png"))
    assert len(pngs) == 1 + 2 * 3                 # the foot's Bode, each loop's Bode and Nyquist
    check_bar(err, out, "figures", len(pngs))


def test_balance_counts_the_runs_with_and_without_balancing(capsys, tmp_path, undrawn):
    out, err = _run(capsys, ["balance", "balancer_rigid_rotor", "--duration-s", "0.2",
                             "--out", str(tmp_path)])
    check_bar(err, out, "runs", 2)


def test_commissioning_counts_the_baseline_and_each_test(capsys, tmp_path):
    scenario = tmp_path / "short.yaml"
    scenario.write_text(f"include: {CONFIG / 'scenario_harmonic_case3_steady.yaml'}\n"
                        "harmonic:\n  commission:\n"
                        "    {settle_revolutions: 4, measure_revolutions: 4}\n")
    out, err = _run(capsys, ["harmonic", "commission", str(scenario), "--out",
                             str(tmp_path / "c")])
    doc = json.loads((tmp_path / "c" / "commission.json").read_text())
    check_bar(err, out, "steps", 1 + len(doc["actuators"]) * len(doc["harmonics"]))


# -- the bar ----------------------------------------------------------------------------------
class Clock:
    """A stopped clock for ``time.perf_counter``, moved by hand."""

    def __init__(self, now: float = 1000.0):
        self.now = now

    def __call__(self) -> float:
        return self.now


def test_time_left_is_the_rate_of_this_run_times_what_remains(monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress_module.time, "perf_counter", clock)
    bar = Progress(100, resumed=20, stream=io.StringIO(), unit="speeds")
    clock.now += 30.0                             # 30 new ones in 30 s: 50 left -> 50 s
    assert bar.line(50).endswith("50/100 speeds 00:30 elapsed, ETA 00:50")
    clock.now += 90.0                             # 60 new ones in 120 s: 20 left -> 40 s
    assert bar.line(80).endswith("80/100 speeds 02:00 elapsed, ETA 00:40")
    assert bar.line(20).endswith("ETA --:--")     # nothing new yet: no rate
    assert clock_text(3725) == "1:02:05" and clock_text(59.6) == "01:00"


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_on_a_terminal_the_bar_is_redrawn_and_its_line_ended_once(monkeypatch):
    clock, stream = Clock(), Terminal()
    monkeypatch.setattr(progress_module.time, "perf_counter", clock)
    bar = Progress(4, stream=stream, unit="figures")
    for done in (1, 2, 2, 3, 4, 4):
        clock.now += 1.0
        bar.update(done)
    bar.close()
    text = stream.getvalue()
    assert text.count("\r") == 5 and text.count("\n") == 1 and text.endswith("\n")
    assert text.count("4/4 figures") == 1


def test_bars_start_a_new_bar_for_each_pass(monkeypatch):
    stream = io.StringIO()
    monkeypatch.setattr(progress_module.sys, "stderr", stream)
    with Bars("chunks") as bar:
        for done in (1, 2, 3, 1, 2, 3, 3):
            bar(done, 3)
        bar(1, 5)
    assert passes(stream.getvalue(), "chunks") == [[(1, 3), (2, 3), (3, 3)]] * 2 + [[(1, 5)]]


def test_run_each_returns_the_results_in_order_and_counts_them(monkeypatch):
    stream = io.StringIO()
    monkeypatch.setattr(progress_module.sys, "stderr", stream)
    assert run_each([lambda k=k: k * k for k in range(4)], "runs") == [0, 1, 4, 9]
    assert passes(stream.getvalue(), "runs") == [[(1, 4), (2, 4), (3, 4), (4, 4)]]
