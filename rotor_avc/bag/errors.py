"""The error every bag problem is reported with (a one-line message, no traceback)."""
from __future__ import annotations

from ..errors import RotorAvcError


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
