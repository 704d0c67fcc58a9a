"""User-facing errors: every one names the offending field and how to fix it."""
from __future__ import annotations

import difflib
from typing import Iterable


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``choices`` to a misspelt ``word`` (difflib's
    ratio >= 0.6), else an empty string."""
    close = difflib.get_close_matches(str(word), sorted(map(str, choices)), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


class RotorAvcError(Exception):
    """Base class of the errors the command line reports without a traceback."""


class ConfigError(RotorAvcError, ValueError):
    """A configuration value is missing or wrong.

    ``field`` is the dotted path of the value (``machine.stator_mass_kg``), ``source`` the
    file it came from, ``fix`` a sentence telling the user what to do.
    """

    def __init__(self, field: str, problem: str, fix: str = "", source: str = ""):
        self.field = field
        self.problem = problem
        self.fix = fix
        self.source = source
        where = f"{source}: " if source else ""
        text = f"{where}{field}: {problem}"
        if fix:
            text += f" -- fix: {fix}"
        super().__init__(text)


class ModelError(RotorAvcError, ValueError):
    """A model or analysis was asked for something it cannot do (with the reason)."""
