"""The integrity pass and recovery: their cost against reading the bag, and their memory.

A 40 s bag of the Werner 2021 graph's topics at 5 kHz (bench_bag's messages: clock, joint state,
acceleration and force of four feet, the labelled observables; 2.2 M messages) is

* baseline: read as every topic's numpy series (``BagReader.series``, the index path compare
  uses);
* checked by the integrity pass (``rotor_avc.bag.integrity.scan_bag``, every record of the data);
* recovered into a new file (``recover_bag``).

Prints times and ratios to the baseline, and the peak traced memory of the integrity pass and
recovery for a 10 s and the 40 s bag (streaming: the same peak, not 4x). Run:
``python bench/bench_bag_integrity.py``.
"""
from __future__ import annotations

import tempfile
import time
import tracemalloc
from pathlib import Path

import bench_bag
from rotor_avc.bag import BagReader, recover_bag, write_bag
from rotor_avc.bag.integrity import scan_bag

LONG_S, SHORT_S = 40.0, 10.0


def make_bag(path: Path, duration_s: float) -> Path:
    bench_bag.DURATION_S = duration_s
    return write_bag(path, bench_bag.make_streams(), bench_bag.CONFIG)


def timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def read_series(path: Path) -> None:
    with BagReader(path) as bag:
        for topic in bag.topics:
            bag.series(topic)


def peak_mb(fn) -> float:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        long_bag = make_bag(tmp / "long.mcap", LONG_S)
        short_bag = make_bag(tmp / "short.mcap", SHORT_S)
        report = scan_bag(long_bag)
        assert report.ok, report.verdict()
        print(f"{LONG_S:g} s bag: {report.message_count} messages, "
              f"{long_bag.stat().st_size / 2**20:.1f} MiB, {report.chunks} chunks")
        base = timed(lambda: read_series(long_bag))
        check = timed(lambda: scan_bag(long_bag))
        recover = timed(lambda: recover_bag(long_bag, tmp / "r.mcap"))
        print(f"  baseline (every topic's series): {base:6.2f} s")
        print(f"  integrity pass:                  {check:6.2f} s  ({check / base:.2f}x)")
        print(f"  recover:                         {recover:6.2f} s  ({recover / base:.2f}x)")
        for name, job in (("integrity pass", scan_bag),
                          ("recover", lambda p: recover_bag(p, p.with_suffix(".r2.mcap")))):
            short, long_ = peak_mb(lambda: job(short_bag)), peak_mb(lambda: job(long_bag))
            print(f"  peak traced memory, {name}: {short:.1f} MiB ({SHORT_S:g} s), "
                  f"{long_:.1f} MiB ({LONG_S:g} s): {long_ / short:.2f}x for "
                  f"{LONG_S / SHORT_S:g}x the file")


if __name__ == "__main__":
    main()
