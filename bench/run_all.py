"""Run every benchmark in this folder (each prints ratios against its own same-run baseline)."""
import subprocess
import sys
from pathlib import Path

status = 0
for path in sorted(Path(__file__).parent.glob("bench_*.py")):
    print(f"== {path.name}", flush=True)
    status |= subprocess.run([sys.executable, str(path)]).returncode
sys.exit(status)
