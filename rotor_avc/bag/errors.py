"""The error every bag problem is reported with (a one-line message, no traceback)."""
from __future__ import annotations

from ..errors import RotorAvcError, path_suggestion


class BagError(RotorAvcError, ValueError):
    """A bag cannot be written or read as asked: ``path: problem -- fix: ...``.

    ``problem`` says what is wrong (truncated file, unknown schema, missing configuration
    metadata, empty bag, ...), ``fix`` what the user can do about it.
    """

    def __init__(self, path, problem: str, fix: str = ""):
        self.path = str(path)
        self.problem = problem
        self.fix = fix
        text = f"{self.path}: {problem}"
        if fix:
            text += f" -- fix: {fix}"
        super().__init__(text)


def no_such_bag(path, what: str = "bag file") -> BagError:
    """``path: no such bag file (did you mean '...'?) -- fix: check the path``: the error of a
    bag path that does not exist, with the closest existing one
    (:func:`rotor_avc.errors.path_suggestion`)."""
    return BagError(path, f"no such {what}" + path_suggestion(path), fix="check the path")


#: exit status of a command refusing a corrupted or inconsistent bag
EXIT_CORRUPT = 4


class CorruptBagError(BagError):
    """The bag's data disagree with its CRCs, indexes, statistics, records or schemas
    (:mod:`rotor_avc.bag.integrity`): one verdict listing every problem and where it is."""

    exit_status = EXIT_CORRUPT

    def __init__(self, path, problems: int, verdict: str):
        self.verdict = verdict
        super().__init__(path, f"corrupted or inconsistent bag, {problems} problem(s):\n  "
                         + verdict.replace("\n", "\n  "),
                         fix="nothing read from this file can be trusted; `rotor-avc bag "
                             "recover BAG` keeps every intact chunk, or record the run again")
