"""Run the benchmarks of this folder (``make bench``), each in its own process with its output
echoed; every ``RESULT | ...`` line one prints (``timing.result``) becomes a row of the
performance table, which ``--readme`` writes into README.md between the performance markers,
under a line naming the date, the machine and the load average at start and end.

Run: ``python bench/run_all.py [--only NAME ...] [--readme]``: the table holds the rows of the
benchmarks run (exit status nonzero when one missed a goal or failed; the table is written all
the same, with the rows it got).
"""
import argparse
import datetime
import os
import platform
import subprocess
import sys
from pathlib import Path

from timing import load_line, parse_result

HERE = Path(__file__).resolve().parent
README = HERE.parent / "README.md"
BEGIN, END = "<!-- performance -->", "<!-- /performance -->"
NAMES = sorted(p.stem for p in HERE.glob("bench_*.py")) + ["compare_memory"]


def run(name: str) -> tuple[int, list[list[str]]]:
    """Run one benchmark, echoing its output: its exit status and its RESULT rows."""
    rows = []
    with subprocess.Popen([sys.executable, str(HERE / f"{name}.py")], stdout=subprocess.PIPE,
                          text=True) as proc:
        for line in proc.stdout:
            sys.stdout.write(line)
            sys.stdout.flush()
            fields = parse_result(line)
            if fields:
                rows.append([name, *fields])
    return proc.returncode, rows


def machine() -> str:
    """CPU model, CPU count and Python version."""
    try:
        cpuinfo = Path("/proc/cpuinfo").read_text()
        model = next(line.split(":", 1)[1].strip() for line in cpuinfo.splitlines()
                     if line.startswith("model name"))
    except (OSError, StopIteration):
        model = platform.processor() or platform.machine()
    return f"{model}, {os.cpu_count()} CPUs, Python {platform.python_version()}"


def table(header: str, rows: list[list[str]]) -> str:
    """The section's text: the header line, then the table of the RESULT rows."""
    lines = [header, "", "| bench | what | CPU | wall | baseline | ratio (ours / baseline) |",
             "|---|---|---|---|---|---|"]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def rewrite_readme(text: str, body: str) -> str:
    """``text`` with everything between the performance markers replaced by ``body``."""
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise ValueError(f"README.md needs one '{BEGIN}' line followed by one '{END}' line "
                         "around the performance table")
    head, rest = text.split(BEGIN)
    return f"{head}{BEGIN}\n{body}\n{END}{rest.split(END)[1]}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="+", choices=NAMES, metavar="NAME",
                    help=f"run these only (of {', '.join(NAMES)})")
    ap.add_argument("--readme", action="store_true",
                    help="write the table into README.md between the performance markers")
    args = ap.parse_args()
    start = load_line()
    date = datetime.date.today().isoformat()
    status, rows = 0, []
    for name in args.only or NAMES:
        print(f"== {name}", flush=True)
        code, got = run(name)
        status |= code
        rows += got
        if code:
            print(f"== {name}: exit status {code}", flush=True)
    body = table(f"{date}, {machine()}; {start} at start, {load_line()} at the end:", rows)
    print(body)
    if args.readme:
        README.write_text(rewrite_readme(README.read_text(), body))
        print(f"wrote the table into {README}")
    return 1 if status else 0


if __name__ == "__main__":
    sys.exit(main())
