"""``bag info`` from the summary against the full integrity pass, and the sample-sequence
check's memory against the recorded length.

Synthetic recorded runs of 10, 60 and 600 s (bench_bag's topic set -- clock, joint state, the
acceleration and force of four feet, the labelled observables -- at 1 kHz: 11 000 messages per
second of run), written by ``BagWriter`` in 1 MiB zstd chunks, are

* baseline: checked by the full integrity pass (``scan_bag``: every record of the data, what
  ``bag info`` did before and ``bag info --integrity`` does now);
* described by ``rotor-avc bag info BAG`` (run in this process, output discarded): the header,
  footer and summary, and two message indexes per topic for its first and last log time;

and their sample sequence is checked by ``check_sequence`` (chunk by chunk, from the message
indexes) beside the same check holding every sampled topic's log times at once (the baseline:
how it worked before). The integrity pass and ``bag info`` run interleaved, each figure the best
of the repeats. Prints CPU and wall time with ratios (CPU), and the peak traced memory of both
sequence checks per recorded length.

Run: ``python bench/bench_bag_info.py [--durations 10 60 600] [--repeats 3]``.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import tempfile
import tracemalloc
from pathlib import Path

import numpy as np

from bench_bag import streams
from timing import interleaved, load_line, result
from rotor_avc.bag import BagReader, BagWriter, topics as T
from rotor_avc.bag.integrity import scan_bag
from rotor_avc.bag.sequence import check_sequence
from rotor_avc.cli import main as cli

FS = 1000.0
DURATIONS_S = (10.0, 60.0, 600.0)
SEGMENT_S = 60.0
CONFIG = {"machine": {"model": "foot_mount_3d"}, "discretisation": {"sample_rate_hz": FS}}


def make_bag(path: Path, duration_s: float) -> Path:
    """The run written in segments of SEGMENT_S (the writer's input stays small)."""
    rng = np.random.default_rng(0)
    n = int(FS * duration_s)
    with BagWriter(path, CONFIG) as w:
        for k0 in range(0, n, int(FS * SEGMENT_S)):
            w.write_streams(streams(np.arange(k0, min(n, k0 + int(FS * SEGMENT_S))) / FS, rng))
    return path


def info(path: Path) -> None:
    with contextlib.redirect_stdout(io.StringIO()):
        assert cli(["bag", "info", str(path)]) == 0


def in_memory_sequence(reader: BagReader) -> int:
    """The baseline: every sampled topic's sample indices at once, then the missing ones."""
    period_ns = 1e9 / FS
    k = {t: np.unique(np.rint(reader.log_times(t) / period_ns).astype(np.int64))
         for t in reader.topics if T.SAMPLED.match(t)}
    n = 1 + max(int(v[-1]) for v in k.values())
    return sum(len(np.setdiff1d(np.arange(n), v, assume_unique=True)) for v in k.values())


def peak_mib(fn) -> float:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--durations", type=float, nargs="+", default=list(DURATIONS_S),
                    help="recorded seconds of each run")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (best of)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for duration_s in args.durations:
            path = make_bag(Path(tmp) / f"run_{duration_s:g}.mcap", duration_s)
            info(path)                               # warm-up: the command's imports
            best = interleaved({"full": lambda: scan_bag(path), "info": lambda: info(path)},
                               args.repeats)
            full, summary = best["full"], best["info"]
            with BagReader(path) as reader:
                reader.config                        # parsed before the peaks
                assert check_sequence(reader).ok and in_memory_sequence(reader) == 0
                streamed = peak_mib(lambda: check_sequence(reader))
                baseline = peak_mib(lambda: in_memory_sequence(reader))
                messages = reader.message_count
            rows.append((duration_s, path.stat().st_size / 2**20, messages, full, summary,
                         baseline, streamed))
            path.unlink()
        print(f"bag info: full integrity pass (baseline) vs from the summary; {FS:g} Hz, "
              f"11 topics; best of {args.repeats} interleaved rounds; {load_line()}")
        print("  run s    MiB   messages | integrity CPU/wall s | info CPU/wall ms | ratio (CPU)")
        for d, mib, msgs, full, summary, _, _ in rows:
            print(f"  {d:5g} {mib:6.1f} {msgs:10d} | {full[0]:8.2f} {full[1]:8.2f}    | "
                  f"{summary[0] * 1e3:7.1f} {summary[1] * 1e3:7.1f} | "
                  f"{summary[0] / full[0]:10.2g}x")
        print("sample-sequence check, peak traced memory: all log times at once (baseline) vs "
              "chunk by chunk")
        for d, _, _, _, _, baseline, streamed in rows:
            print(f"  {d:5g} s run: baseline {baseline:8.2f} MiB, streamed {streamed:6.3f} MiB "
                  f"({baseline / streamed:.0f}x less)")
        first, last = rows[0], rows[-1]
        print(f"  {last[0] / first[0]:g}x the run: baseline {last[5] / first[5]:.1f}x the peak, "
              f"streamed {last[6] / first[6]:.2f}x; info {last[4][0] / first[4][0]:.2f}x the "
              f"CPU time, integrity pass {last[3][0] / first[3][0]:.1f}x")
        d, _, msgs, full, summary, _, _ = last
        result(f"bag info from the summary, {d:g} s run ({msgs} messages)", *summary, "call",
               "full integrity pass", summary[0] / full[0])


if __name__ == "__main__":
    main()
