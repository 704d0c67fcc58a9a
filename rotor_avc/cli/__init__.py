"""The ``rotor-avc`` command: one sub-command per module in this package.

Each command module defines ``NAME``, ``HELP`` (one line), ``EXAMPLE`` and ``add_arguments(p)``
and ``run(args) -> int``. Errors the user can fix (:class:`rotor_avc.errors.RotorAvcError`) are
printed as one line and exit with status 2 (or the error's own ``exit_status``, e.g. 3 for a
recording with missing samples, 74 for an output the operating system refuses to write:
:mod:`rotor_avc.output_files`); Ctrl-C ends a command with one line and exit status 130;
nothing else is caught. Every command takes ``--max-memory-gb`` and ``--max-hours``, the limits
of rotor_avc.resources.
"""
from __future__ import annotations

import argparse
import importlib
import importlib.metadata
import os
import sys

from ..errors import RotorAvcError
from ..resources import DEFAULT_MAX_HOURS, DEFAULT_RAM_FRACTION, ENV_VAR, TIME_ENV_VAR
from .common import EXIT_INTERRUPTED, positive_float

COMMANDS = [
    "poles", "campbell", "frf", "controller", "simulate", "compare",     # any machine
    "stability", "study", "active-bearing", "balance",       # paper-specific studies
    "api684",                                                # standard checks of a model
    "demo",                                                  # the main job
    "run",                                                   # a scenario as a ROS graph
    "replay",                                                # bags into the ROS graph
    "bag",                                                   # bag info, check, recover
    "runup",                                                 # views of a recorded run-up
    "calibrate",                                             # a model fitted to recordings
    "config",                                                # the configuration language
    "harmonic",                                              # harmonic control commissioned
    "layouts",                                               # Foxglove / PlotJuggler layouts
]
#: command -> its module, where they differ (``config.py`` would read as the config loader)
MODULES = {"config": "config_cmd"}


def version() -> str:
    """The installed package's version (its metadata: pip and colcon installs alike)."""
    try:
        return importlib.metadata.version("rotor_avc")
    except importlib.metadata.PackageNotFoundError:
        return "(not installed: run from a source tree without `pip install`)"


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or of the command ``only`` (each command module imports
    what it runs, so one command's parser starts without the others' imports)."""
    parser = argparse.ArgumentParser(
        prog="rotor-avc",
        description="Active vibration control of rotating machines: models, analyses, "
                    "simulation, bags and reports.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Run `rotor-avc COMMAND --help` for a command's options and an example.")
    parser.add_argument("--version", action="version", version=f"rotor-avc {version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS if only is None else [only]:
        mod = importlib.import_module(f"{__name__}.{MODULES.get(name, name.replace('-', '_'))}")
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP,
                           epilog="example:\n  " + mod.EXAMPLE,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        mod.add_arguments(p)
        p.add_argument("--max-memory-gb", type=positive_float, default=None,
                       help="refuse runs and grids planned to need more memory (GiB; default: "
                            f"{DEFAULT_RAM_FRACTION:g} of the machine's RAM, or ${ENV_VAR})")
        p.add_argument("--max-hours", type=positive_float, default=None,
                       help="refuse studies estimated to run longer (hours; default: "
                            f"{DEFAULT_MAX_HOURS:g}, or ${TIME_ENV_VAR})")
        p.set_defaults(_run=mod.run)
    return parser


#: stdout's reader went away (128 + SIGPIPE, the status of a shell tool killed by it)
EXIT_BROKEN_PIPE = 141


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = build_parser(argv[0] if argv and argv[0] in COMMANDS else None).parse_args(argv)
    for name, value in ((ENV_VAR, args.max_memory_gb), (TIME_ENV_VAR, args.max_hours)):
        if value is not None:
            os.environ[name] = repr(value)
    try:
        return int(args._run(args) or 0)
    except RotorAvcError as exc:
        print(f"rotor-avc {args.command}: error: {exc}", file=sys.stderr)
        return getattr(exc, "exit_status", 2)
    except KeyboardInterrupt:
        print(f"rotor-avc {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # the reader of stdout stopped (`| head`): end quietly, as the shell's own tools do
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE


if __name__ == "__main__":
    sys.exit(main())
