"""Timing that load cannot fool: CPU time (``time.process_time``, plus the children's through
``resource.getrusage``) beside wall time, each the best of several repeats, with the arms of one
comparison run interleaved (A B C A B C ...) so a change of load hits every arm alike."""
import resource
import time


def cpu_now() -> float:
    """CPU seconds of this process and its finished children (user + system)."""
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + child.ru_utime + child.ru_stime


def timed(fn) -> tuple[float, float]:
    """``(cpu_s, wall_s)`` of one call."""
    c0, w0 = cpu_now(), time.perf_counter()
    fn()
    return cpu_now() - c0, time.perf_counter() - w0


def interleaved(arms: dict, repeats: int = 5, measure=timed) -> dict[str, tuple[float, float]]:
    """``{name: (best cpu_s, best wall_s)}`` over ``repeats`` rounds of every arm in turn, each
    call's ``(cpu_s, wall_s)`` from ``measure(arm)`` (an arm in another process: its own report)."""
    best = {name: (float("inf"), float("inf")) for name in arms}
    for _ in range(repeats):
        for name, fn in arms.items():
            cpu, wall = measure(fn)
            best[name] = (min(best[name][0], cpu), min(best[name][1], wall))
    return best


def load_line() -> str:
    """The machine's load while the benchmark ran (1, 5, 15 min averages)."""
    import os
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f} {five:.2f} {fifteen:.2f} on {os.cpu_count()} CPUs"


#: the prefix of a headline figure's line (``result``), which ``run_all.py`` collects
RESULT = "RESULT"


def duration(seconds: float) -> str:
    """``seconds`` with three significant digits in the unit that reads best (ns, us, ms, s)."""
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6)):
        if abs(seconds) >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds * 1e9:.3g} ns"


def result(what: str, cpu_s: float, wall_s: float, unit: str, baseline: str, ratio: float,
           ratio_of: str = "CPU") -> None:
    """Print one headline figure, ``RESULT | what | CPU per unit | wall per unit | baseline |
    ratio``: ``cpu_s`` and ``wall_s`` seconds per ``unit``, ``ratio`` ours over the baseline
    measured in the same run (below 1: ours is cheaper) of CPU time unless ``ratio_of`` names
    another measure (wall, peak memory)."""
    fields = (what, f"{duration(cpu_s)}/{unit}", f"{duration(wall_s)}/{unit}", baseline,
              f"{ratio:.3g}x ({ratio_of})")
    if any("|" in f for f in fields):
        raise ValueError(f"a RESULT field holds '|': {fields}")
    print(" | ".join((RESULT, *fields)), flush=True)


def parse_result(line: str) -> list[str] | None:
    """The five fields of a ``result`` line (what, CPU, wall, baseline, ratio), else ``None``."""
    fields = [f.strip() for f in line.split(" | ")]
    return fields[1:] if len(fields) == 6 and fields[0] == RESULT else None
