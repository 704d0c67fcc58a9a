"""Bounded resources: a size estimate before every large allocation, refused above a limit.

The limit is ``ROTOR_AVC_MAX_MEMORY_GB`` (GiB; the command line's ``--max-memory-gb`` sets it)
or, by default, :data:`DEFAULT_RAM_FRACTION` of the machine's physical memory. A refused
estimate raises :class:`ResourceError` (a user error, exit status 2) that says how much was
asked for, what for, the limit, and what to do instead -- never a numpy MemoryError from deep
inside or a machine driven into swap.
"""
from __future__ import annotations

import math
import os

from .errors import RotorAvcError

#: share of the physical memory one command may plan to allocate by default
DEFAULT_RAM_FRACTION = 0.5
ENV_VAR = "ROTOR_AVC_MAX_MEMORY_GB"
GIB = 2**30
#: bytes of one float64 / complex128 value
FLOAT_BYTES, COMPLEX_BYTES = 8, 16


class ResourceError(RotorAvcError):
    """A planned allocation or run is larger than the configured limit."""


def physical_memory_bytes() -> int:
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def memory_limit_bytes() -> int:
    """The allocation limit: ``ROTOR_AVC_MAX_MEMORY_GB`` or a fraction of the physical memory."""
    text = os.environ.get(ENV_VAR)
    if text is None:
        return int(DEFAULT_RAM_FRACTION * physical_memory_bytes())
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ResourceError(f"{ENV_VAR} (--max-memory-gb) must be a number of GiB > 0 "
                            f"(got {text!r}) -- fix: give e.g. 4, or unset it")
    return int(value * GIB)


def check_memory(nbytes: float, what: str, fix: str) -> None:
    """Refuse a planned allocation of ``nbytes`` for ``what`` above :func:`memory_limit_bytes`."""
    limit = memory_limit_bytes()
    if nbytes > limit:
        raise ResourceError(f"{what} needs about {nbytes / GIB:.3g} GiB of memory, above the "
                            f"limit of {limit / GIB:.3g} GiB -- fix: {fix}, or raise the limit "
                            "with --max-memory-gb")


def chunks(n: int, bytes_per_item: float, target_bytes: float = 64 * 2**20):
    """``(start, stop)`` ranges over ``n`` items, each holding about ``target_bytes``."""
    step = max(1, int(target_bytes // max(bytes_per_item, 1)))
    for start in range(0, n, step):
        yield start, min(n, start + step)
