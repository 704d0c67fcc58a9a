"""User-facing errors: every one names the offending field and how to fix it."""
from __future__ import annotations

import difflib
import itertools
import os
from pathlib import Path
from typing import Iterable

#: a folder is searched for a path's suggestion among its first this many entries (one listing)
MAX_LISTED = 10_000


def _closest(word: str, choices: Iterable[str]) -> str | None:
    """The closest of ``choices`` to ``word`` (difflib's ratio >= 0.6), or None."""
    close = difflib.get_close_matches(str(word), sorted(map(str, choices)), n=1)
    return close[0] if close else None


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``choices`` to a misspelt ``word`` (difflib's
    ratio >= 0.6), else an empty string."""
    close = _closest(word, choices)
    return f" (did you mean {close!r}?)" if close else ""


def path_suggestion(path, root=".") -> str:
    """:func:`did_you_mean` for a file or folder ``path`` (relative to ``root``) that does not
    exist: its first missing part against the entries of the folder above that part -- the
    file's own folder when that exists (``out/demo/bags/x.mcap`` -> ``out/demo/bags/y.mcap``),
    else the deepest existing one (``out/dmeo/bags/x.mcap`` -> ``out/demo``; a missing part
    that is not the last is matched with folders only), said as ``path`` is written. One
    listing of one folder (at most :data:`MAX_LISTED` entries, hidden ones only for a hidden
    part); an empty string when ``path`` exists, nothing is close or the folder cannot be read."""
    parts = Path(path).parts
    known = Path()
    try:
        for i, part in enumerate(parts):
            if not (Path(root) / known / part).exists():
                break
            known = known / part
        else:
            return ""
        last = i == len(parts) - 1
        with os.scandir(Path(root) / known) as entries:
            names = [e.name for e in itertools.islice(entries, MAX_LISTED)
                     if e.name != part and (part.startswith(".") or not e.name.startswith("."))
                     and (last or e.is_dir())]
    except (OSError, ValueError):                 # unreadable, too long, a NUL byte
        return ""
    close = _closest(part, names)
    return f" (did you mean {str(known / close)!r}?)" if close else ""


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
