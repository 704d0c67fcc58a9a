"""The integrity pass and recovery: their cost against reading the bag, and their memory.

A 40 s bag of the Werner 2021 graph's topics at 5 kHz (bench_bag's messages: clock, joint state,
acceleration and force of four feet, the labelled observables; 2.2 M messages) is, in arms
interleaved in one run,

* baseline: read as every topic's numpy series (``BagReader.series``, the index path compare
  uses);
* checked by the integrity pass (``rotor_avc.bag.integrity.scan_bag``, every record of the data);
* recovered into a new file (``recover_bag``).

Prints CPU and wall time, each the best of the repeats, and the ratios to the baseline (CPU), and
the peak traced memory of the integrity pass and recovery for a bag a quarter as long and the
long one (streaming: the same peak, not 4x).

Run: ``python bench/bench_bag_integrity.py [--seconds 40] [--repeats 3]``.
"""
from __future__ import annotations

import argparse
import tempfile
import tracemalloc
from pathlib import Path

from bench_bag import CONFIG, make_streams
from timing import interleaved, load_line, result
from rotor_avc.bag import BagReader, recover_bag, write_bag
from rotor_avc.bag.integrity import scan_bag


def read_series(path: Path) -> None:
    with BagReader(path) as bag:
        for topic in bag.topics:
            bag.series(topic)


def recover(path: Path, target: Path) -> None:
    target.unlink(missing_ok=True)
    recover_bag(path, target)


def peak_mb(fn) -> float:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=40.0, help="the long bag's length")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (best of)")
    args = ap.parse_args()
    long_s, short_s = args.seconds, args.seconds / 4
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        long_bag = write_bag(tmp / "long.mcap", make_streams(long_s), CONFIG)
        short_bag = write_bag(tmp / "short.mcap", make_streams(short_s), CONFIG)
        report = scan_bag(long_bag)
        assert report.ok, report.verdict()
        n = report.message_count
        best = interleaved({"series": lambda: read_series(long_bag),
                            "integrity": lambda: scan_bag(long_bag),
                            "recover": lambda: recover(long_bag, tmp / "r.mcap")}, args.repeats)
        print(f"{long_s:g} s bag: {n} messages, {long_bag.stat().st_size / 2**20:.1f} MiB, "
              f"{report.chunks} chunks; best of {args.repeats} interleaved rounds; {load_line()}")
        base = best["series"][0]
        for name, label in (("series", "baseline (every topic's series)"),
                            ("integrity", "integrity pass"), ("recover", "recover")):
            cpu, wall = best[name]
            print(f"  {label + ':':33} CPU {cpu:6.2f} s  wall {wall:6.2f} s  ({cpu / base:.2f}x, "
                  "CPU)")
        for name, what in (("integrity", "integrity pass (scan_bag)"),
                           ("recover", "recover_bag")):
            cpu, wall = best[name]
            result(f"{what}, {long_s:g} s bag at 5 kHz", cpu / n, wall / n, "message",
                   "reading every topic's series", cpu / base)
        for name, job in (("integrity pass", scan_bag),
                          ("recover", lambda p: recover(p, p.with_suffix(".r2.mcap")))):
            short, long_ = peak_mb(lambda: job(short_bag)), peak_mb(lambda: job(long_bag))
            print(f"  peak traced memory, {name}: {short:.1f} MiB ({short_s:g} s), "
                  f"{long_:.1f} MiB ({long_s:g} s): {long_ / short:.2f}x for "
                  f"{long_s / short_s:g}x the file")


if __name__ == "__main__":
    main()
