"""Bounded resources: a size estimate before every large allocation, refused above a limit.

The memory limit is ``ROTOR_AVC_MAX_MEMORY_GB`` (GiB; the command line's ``--max-memory-gb``
sets it) or, by default, :data:`DEFAULT_RAM_FRACTION` of the machine's physical memory; the
time limit of estimated work (studies) is ``ROTOR_AVC_MAX_HOURS`` (``--max-hours``) or
:data:`DEFAULT_MAX_HOURS`. A refused
estimate raises :class:`ResourceError` (a user error, exit status 2) that says how much was
asked for, what for, the limit, and what to do instead -- never a numpy MemoryError from deep
inside or a machine driven into swap.
"""
from __future__ import annotations

import math
import os
import shutil

from .errors import RotorAvcError

#: share of the physical memory one command may plan to allocate by default
DEFAULT_RAM_FRACTION = 0.5
ENV_VAR = "ROTOR_AVC_MAX_MEMORY_GB"
#: refuse work estimated to take longer than this (hours; ``ROTOR_AVC_MAX_HOURS`` overrides it)
DEFAULT_MAX_HOURS = 24.0
TIME_ENV_VAR = "ROTOR_AVC_MAX_HOURS"
GIB = 2**30
#: working memory of one chunk of a grid evaluated in chunks (:func:`chunks`)
CHUNK_BYTES = 64 * 2**20
#: bytes of one float64 / complex128 value
FLOAT_BYTES, COMPLEX_BYTES = 8, 16


class ResourceError(RotorAvcError):
    """A planned allocation or run is larger than the configured limit."""


def physical_memory_bytes() -> int:
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def memory_limit_bytes() -> int:
    """The allocation limit: ``ROTOR_AVC_MAX_MEMORY_GB`` or a fraction of the physical memory."""
    value = _env_limit(ENV_VAR, "--max-memory-gb", "GiB")
    return int(DEFAULT_RAM_FRACTION * physical_memory_bytes() if value is None else value * GIB)


def time_limit_s() -> float:
    """The run-time limit of estimated work: ``ROTOR_AVC_MAX_HOURS`` or :data:`DEFAULT_MAX_HOURS`."""
    value = _env_limit(TIME_ENV_VAR, "--max-hours", "hours")
    return 3600.0 * (DEFAULT_MAX_HOURS if value is None else value)


def _env_limit(name: str, option: str, unit: str) -> float | None:
    text = os.environ.get(name)
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ResourceError(f"{name} ({option}) must be a number of {unit} > 0 (got {text!r}) "
                            "-- fix: give e.g. 4, or unset it")
    return value


def check_memory(nbytes: float, what: str, fix: str) -> None:
    """Refuse a planned allocation of ``nbytes`` for ``what`` above :func:`memory_limit_bytes`."""
    _refuse_above(nbytes / GIB, memory_limit_bytes() / GIB, f"{what} needs about {{:.3g}} GiB of "
                  "memory", "GiB", fix, "--max-memory-gb")


def check_time(seconds: float, what: str, fix: str) -> None:
    """Refuse work estimated to take ``seconds`` for ``what`` above :func:`time_limit_s`."""
    _refuse_above(seconds / 3600, time_limit_s() / 3600, f"{what} would take about {{:.3g}} h",
                  "h", fix, "--max-hours")


def check_disk(nbytes: float, folder, what: str, fix: str) -> None:
    """Refuse writing about ``nbytes`` more for ``what`` into ``folder`` beyond its free space."""
    free = shutil.disk_usage(folder).free
    if nbytes > free:
        raise ResourceError(f"{what} needs about {nbytes / GIB:.3g} GiB more on disk, "
                            f"{folder} has {free / GIB:.3g} GiB free -- fix: {fix}, or write "
                            "to a disk with more room")


def _refuse_above(amount: float, limit: float, claim: str, unit: str, fix: str,
                  option: str) -> None:
    if amount > limit:
        raise ResourceError(f"{claim.format(amount)}, above the limit of {limit:.3g} {unit} -- "
                            f"fix: {fix}, or raise the limit with {option}")


def chunks(n: int, bytes_per_item: float):
    """``(start, stop)`` ranges over ``n`` items, each chunk holding about :data:`CHUNK_BYTES`."""
    step = max(1, int(CHUNK_BYTES // max(bytes_per_item, 1)))
    for start in range(0, n, step):
        yield start, min(n, start + step)
