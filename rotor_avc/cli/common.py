"""Argument types shared by the commands."""
from __future__ import annotations

import argparse
import sys
import contextlib
import signal
from pathlib import Path

import numpy as np

from ..resources import FLOAT_BYTES, ResourceError, check_memory

#: exit status of a command stopped by Ctrl-C (128 + SIGINT, the shell's convention)
EXIT_INTERRUPTED = 130


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
    try:
        check_memory(FLOAT_BYTES * n, f"a grid of {n} speeds", "use fewer speeds")
    except ResourceError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return np.linspace(start, stop, n)


def nonnegative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number >= 0")
    return value


def positive_float(text: str) -> float:
    value = nonnegative_float(text)
    if value == 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
    return value


def speed_range_from_zero_hz(text: str) -> np.ndarray:
    """:func:`speed_range_hz` with START = 0 allowed."""
    return speed_range_hz(text, allow_zero=True)


def positive_speed_list(text: str) -> list[float]:
    """``F[,F...]`` -> speeds > 0 (Hz)."""
    try:
        speeds = [float(v) for v in text.split(",")]
    except ValueError:
        speeds = []
    if not speeds or not all(np.isfinite(v) and v > 0 for v in speeds):
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of speeds > 0 (e.g. 17.24 or "
                                         "20,50, in Hz)")
    return speeds


def _in_rpm(parse):
    """``parse`` (text in Hz -> Hz) for text in rpm: the same checks, the result in Hz."""
    def parse_rpm(text: str):
        try:
            value = parse(text)
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentTypeError(str(exc).replace("Hz", "rpm")) from None
        return [v / 60.0 for v in value] if isinstance(value, list) else value / 60.0
    return parse_rpm


def add_speed_option(p, parse, help_hz: str, *, default=None, required: bool = False,
                     metavar: str | None = None) -> None:
    """``--speed-hz`` or ``--speed-rpm`` (one of them; the same form, rpm = 60 Hz), both into
    ``args.speed_hz`` in Hz: every command that takes a speed takes it in either unit."""
    group = p.add_mutually_exclusive_group(required=required)
    metavar = metavar or "F"
    group.add_argument("--speed-hz", dest="speed_hz", type=parse, default=default,
                       metavar=metavar, help=help_hz)
    group.add_argument("--speed-rpm", dest="speed_hz", type=_in_rpm(parse), default=default,
                       metavar=metavar, help="the same in rpm")


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


def _refuse_file_in_the_way(path: Path, text: str) -> None:
    """Refuse ``path`` when one of its parent folders exists as a file."""
    for part in path.parents:
        if part.exists():
            if not part.is_dir():
                raise argparse.ArgumentTypeError(
                    f"{part} is a file, so {text} cannot be created -- fix: give another path")
            return


def output_folder(text: str) -> Path:
    """``--out FOLDER``: a folder that exists or can be created (no file in the way)."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(
            f"{text} is an existing file, not a folder -- fix: give a folder name (it is created)")
    _refuse_file_in_the_way(path, text)
    return path


def output_file(text: str, suffixes: tuple[str, ...] = ()) -> Path:
    """``--out FILE``: a file name (ending in one of ``suffixes``) whose folder can be created;
    an existing file is replaced only by a complete new one
    (:func:`rotor_avc.output_files.writing`)."""
    path = Path(text)
    if suffixes and path.suffix not in suffixes:
        raise argparse.ArgumentTypeError(
            f"{text}: the name must end in {' or '.join(suffixes)} (it chooses the format)")
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder -- fix: give a file name")
    _refuse_file_in_the_way(path, text)
    return path


#: the signals a long run stops on at a clean point: Ctrl-C and `kill` / `timeout`
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def interrupt_flag():
    """While inside: Ctrl-C (SIGINT) or SIGTERM only sets a flag, read by calling the yielded
    function, so a long run can stop at a clean point; a second one interrupts at once
    (KeyboardInterrupt: the run's clean-up still runs)."""
    hit = []

    def handler(signum, frame):
        if hit:
            raise KeyboardInterrupt
        hit.append(signum)

    previous = {sig: signal.signal(sig, handler) for sig in STOP_SIGNALS}
    try:
        yield lambda: bool(hit)
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)

