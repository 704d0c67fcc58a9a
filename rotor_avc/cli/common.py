"""Argument types shared by the commands."""
from __future__ import annotations

import argparse
import sys

import numpy as np


def speed_range_hz(text: str, allow_zero: bool = False) -> np.ndarray:
    """``START:STOP:N`` -> N speeds in Hz from START to STOP inclusive (START > 0, or >= 0 with
    ``allow_zero``)."""
    parts = text.split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not START:STOP:N (e.g. 1:250:2000, speeds in Hz)") from None
    if (not (np.isfinite(start) and np.isfinite(stop)) or start < 0 or (start == 0 and not allow_zero)
            or stop <= start or n < 2):
        raise argparse.ArgumentTypeError(
            f"{text!r}: need 0 {'<=' if allow_zero else '<'} START < STOP and N >= 2 "
            "(e.g. 1:250:2000)")
    return np.linspace(start, stop, n)


def nonnegative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number >= 0")
    return value


def speed_range_from_zero_hz(text: str) -> np.ndarray:
    """:func:`speed_range_hz` with START = 0 allowed."""
    return speed_range_hz(text, allow_zero=True)


def config_frf_speeds_hz(machine) -> np.ndarray:
    """The speed grid of a machine config's ``analysis.frf_speed_hz: {start, stop, n}``."""
    rng = machine.analysis.frf_speed_hz
    if rng is None:
        raise machine.config.section("analysis", {}).error(
            "frf_speed_hz", "missing", fix="add `frf_speed_hz: {start, stop, n}` or give --speed-hz")
    return np.linspace(rng.start, rng.stop, rng.n)


def warn(command: str, text: str) -> None:
    """A warning on stderr, as ``rotor-avc COMMAND: warning: text``."""
    print(f"rotor-avc {command}: warning: {text}", file=sys.stderr)
