"""The benchmarks run: each in its shortest mode, as ``make bench`` runs it (its own process, from
bench/), exits 0 and prints at least one well-formed ``RESULT`` line with CPU and wall figures
above zero; and the README's performance table is rewritten between its markers only. No timing
is asserted (the machine is shared): the figures are checked for form, not size."""
import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parent.parent / "bench"
sys.path.insert(0, str(BENCH))
import run_all  # noqa: E402
import timing  # noqa: E402
sys.path.remove(str(BENCH))

#: each benchmark's shortest mode
QUICK = {
    "bench_bag": ["--seconds", "0.1", "--repeats", "1"],
    "bench_bag_info": ["--durations", "1", "2", "--repeats", "1"],
    "bench_bag_integrity": ["--seconds", "0.4", "--repeats", "1"],
    "bench_calibrate": ["--machines", "foot_mount_case3", "--speeds", "4", "--params", "1",
                        "--repeats", "1", "--dwell-s", "0.5"],
    "bench_campbell": ["--speeds", "10", "--repeats", "1"],
    "bench_filter": ["--samples", "2000", "--repeats", "1"],
    "bench_frf": ["--speeds", "250", "--repeats", "1"],
    "bench_harmonic": ["--seconds", "0.2", "--repeats", "1"],
    "bench_sim": ["--seconds", "0.2", "--repeats", "1"],
    "bench_simulate_memory": ["--durations", "0.2"],
    "bench_study": ["--points", "4", "--base", "2", "--efficiency-points", "4", "--speeds",
                    "200", "--repeats", "1"],
    "compare_memory": ["--lengths", "2"],
}
#: benchmarks that print no RESULT line yet (the README's other sections quote them)
WITHOUT_RESULTS = {"bench_ros_loop"}
#: ``RESULT | what | 1.23 us/unit | 4.56 ms/unit | baseline | 0.5x (CPU)``, read independently
#: of timing.parse_result
LINE = re.compile(r"^RESULT \| ([^|]+) \| ([0-9.e+-]+) (ns|us|ms|s)/([^|]+) \| "
                  r"([0-9.e+-]+) (ns|us|ms|s)/([^|]+) \| ([^|]+) \| ([0-9.e+-]+)x \(([^|]+)\)$")


@pytest.fixture(scope="module")
def runs():
    """Every quick run, two at a time (most of a run is its imports, waiting on the disk)."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MPLBACKEND="Agg")

    def run(name):
        return subprocess.run([sys.executable, f"{name}.py", *QUICK[name]], cwd=BENCH, env=env,
                              capture_output=True, text=True, timeout=600)
    pool = ThreadPoolExecutor(2)
    yield {name: pool.submit(run, name) for name in QUICK}
    pool.shutdown(cancel_futures=True)


def test_every_benchmark_has_a_quick_mode():
    names = {p.stem for p in BENCH.glob("*.py")} - {"run_all", "timing"}
    assert names - WITHOUT_RESULTS == set(QUICK)


@pytest.mark.parametrize("name", sorted(QUICK))
def test_the_quick_mode_prints_results(runs, name):
    proc = runs[name].result()
    assert proc.returncode == 0, f"{name}: exit status {proc.returncode}\n{proc.stderr[-3000:]}"
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT")]
    assert lines, f"{name} printed no RESULT line:\n{proc.stdout[-2000:]}"
    for line in lines:
        m = LINE.match(line)
        assert m, f"malformed: {line}"
        assert float(m[2]) > 0 and float(m[5]) > 0, line          # CPU and wall per unit
        assert m[4] == m[7], line                                  # the same unit
        assert float(m[9]) > 0, line
        assert timing.parse_result(line) == [m[1], f"{m[2]} {m[3]}/{m[4]}",
                                             f"{m[5]} {m[6]}/{m[7]}", m[8], f"{m[9]}x ({m[10]})"]
    assert "load average" in proc.stdout


def test_a_result_line_reads_back(capsys):
    timing.result("IirFilter.step", 4.8e-7, 1.2e-3, "sample", "hand-written", 2.5)
    timing.result("compare, streamed", 2.0, 30.0, "s of run", "--in-memory", 0.4, "peak memory")
    first, second = capsys.readouterr().out.splitlines()
    assert first == ("RESULT | IirFilter.step | 480 ns/sample | 1.2 ms/sample | hand-written | "
                     "2.5x (CPU)")
    assert timing.parse_result(second) == ["compare, streamed", "2 s/s of run",
                                           "30 s/s of run", "--in-memory", "0.4x (peak memory)"]
    assert timing.parse_result("RESULTS | a | b") is None
    with pytest.raises(ValueError, match=r"\|"):
        timing.result("a | b", 1.0, 1.0, "run", "x", 1.0)


README = """# title

intro

<!-- performance -->
old line
| a | b |
<!-- /performance -->

## Tests
after
"""


def test_the_readme_table_is_replaced_between_the_markers():
    new = run_all.rewrite_readme(README, "2026-01-01, a machine\n\n| x | y |")
    assert new == README.replace("old line\n| a | b |", "2026-01-01, a machine\n\n| x | y |")
    assert run_all.rewrite_readme(new, "again") == README.replace("old line\n| a | b |", "again")


@pytest.mark.parametrize("text", [README.replace("<!-- performance -->\n", ""),
                                  README.replace("<!-- /performance -->\n", ""),
                                  README.replace("## Tests", "<!-- performance -->"),
                                  "<!-- /performance -->\n<!-- performance -->\n"],
                         ids=["no start", "no end", "two starts", "reversed"])
def test_the_readme_is_refused_without_its_markers(text):
    with pytest.raises(ValueError, match="performance"):
        run_all.rewrite_readme(text, "table")


def test_the_table_has_a_row_per_result():
    body = run_all.table("header", [["bench_filter", "IirFilter.step", "480 ns/sample",
                                     "1.2 us/sample", "hand-written", "2.5x (CPU)"]])
    assert body.splitlines()[0] == "header"
    assert body.splitlines()[-1] == ("| bench_filter | IirFilter.step | 480 ns/sample | "
                                     "1.2 us/sample | hand-written | 2.5x (CPU) |")
