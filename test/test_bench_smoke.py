"""The benchmarks run: each in its shortest mode, as ``make bench`` runs it (its own process, from
bench/), exits 0 and prints at least one well-formed ``RESULT`` line with CPU and wall figures
above zero; and the README's performance table is rewritten between its markers only. No timing
is asserted (the machine is shared): the figures are checked for form, not size."""
import os
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parent.parent / "bench"
sys.path.insert(0, str(BENCH))
import ros_profile  # noqa: E402
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
    "bench_ros_loop": ["--steps", "2500", "--repeats", "1", "--realtime-s", "0.3"],
    "bench_sim": ["--seconds", "0.2", "--repeats", "1"],
    "bench_simulate_memory": ["--durations", "0.2"],
    "bench_study": ["--points", "4", "--base", "2", "--efficiency-points", "4", "--speeds",
                    "200", "--repeats", "1"],
    "compare_memory": ["--lengths", "2"],
}
#: the modules the benchmarks share (no benchmark of their own)
HELPERS = {"run_all", "timing", "ros_floors", "ros_profile"}
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
    names = {p.stem for p in BENCH.glob("*.py")} - HELPERS
    assert names == set(QUICK)


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


def test_the_timeline_reads_each_segment():
    """Synthetic source times (ns) of a known per-sample timeline, rows shuffled and one message
    lost: each segment's median comes back (topics: three measurements, the plant's last
    message, three answers)."""
    rng = np.random.default_rng(0)
    k = np.arange(200)
    start = k * 1_000_000                                    # a sample every 1000 us
    times = [start + i * 10_000 for i in range(3)] + [start + 50_000]
    times += [times[i] + 200_000 + 1_000 * i for i in range(3)]    # answers 200-202 us later
    rows = []
    for t in times:
        r = np.column_stack([k + 1, t])[rng.permutation(len(k))]
        rows.append(r)
    rows[5] = rows[5][rows[5][:, 0] != 51]                 # sample 50's second answer lost
    got = ros_profile.timeline(rows, [0, 1, 2, 3], [(0, 4), (1, 5), (2, 6)])
    assert got["plant publishes its messages (first to last)"][0] == pytest.approx(50)
    assert got["measurement -> answer published (each controller)"][0] == pytest.approx(201)
    assert got["last answer -> plant's next sample published"][0] == pytest.approx(778)
    assert got["whole sample (period)"] == pytest.approx((1000, 1000))
    with pytest.raises(RuntimeError, match="too few"):
        ros_profile.timeline([r[:5] for r in rows], [0, 1, 2, 3], [(0, 4), (1, 5), (2, 6)])


def test_the_cpu_span_counts_this_process_and_its_children():
    """0.3 s of CPU burnt here and in a child between begin and end: about 3 ms per sample over
    100 samples for each (clock-tick resolution)."""
    burn = ("import sys, time\nprint('ready', flush=True)\nsys.stdin.readline()\n"
            "t = time.process_time()\nwhile time.process_time() - t < 0.3: pass\n"
            "sys.stdin.read()")
    child = subprocess.Popen([sys.executable, "-c", burn, "burner"], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline() == "ready\n"
        span = ros_profile.CpuSpan()
        span.begin(0)
        child.stdin.write("go\n")
        child.stdin.flush()
        t = time.process_time()
        while time.process_time() - t < 0.3:
            pass
        deadline = time.monotonic() + 60
        while (ros_profile.process_cpu(child.pid)[0] - span.start[child.pid][1][0] < 0.3 - 0.02
               and time.monotonic() < deadline):
            time.sleep(0.05)
        span.end(100)
    finally:
        child.stdin.close()
        child.wait()
    assert span.per_sample["this"][0] == pytest.approx(3e-3, abs=3e-4)
    assert span.per_sample["burner"][0] == pytest.approx(3e-3, abs=3e-4)
    assert span.total() >= 6e-3 - 6e-4
