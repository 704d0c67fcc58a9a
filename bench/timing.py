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


def interleaved(arms: dict, repeats: int = 5) -> dict[str, tuple[float, float]]:
    """``{name: (best cpu_s, best wall_s)}`` over ``repeats`` rounds of every arm in turn."""
    best = {name: (float("inf"), float("inf")) for name in arms}
    for _ in range(repeats):
        for name, fn in arms.items():
            cpu, wall = timed(fn)
            best[name] = (min(best[name][0], cpu), min(best[name][1], wall))
    return best


def load_line() -> str:
    """The machine's load while the benchmark ran (1, 5, 15 min averages)."""
    import os
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f} {five:.2f} {fifteen:.2f} on {os.cpu_count()} CPUs"
