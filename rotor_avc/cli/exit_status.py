"""The exit statuses of the ``rotor-avc`` commands, declared once (the README's table of exit
statuses is checked against these, and every status a command's code returns must be here).

:data:`COMMON`: what every command may end with; :data:`BY_COMMAND`: the statuses particular to
a command (a check that fails, a recording that misses samples, ...)."""

COMMON = {
    0: "done (and, where the command checks something, every check passed)",
    2: "usage, configuration or input refused: one line naming the field or file and the fix",
    74: "the operating system refused to write an output (disk full, read-only, permission)",
    130: "interrupted (Ctrl-C, SIGTERM): outputs are complete files or absent",
    141: "stdout's reader stopped early (`| head`)",
}

_BAG = {3: "the recording misses samples (the sample-sequence check)",
        4: "the bag is corrupt (CRC, index or record errors)"}

BY_COMMAND = {
    "compare": {1: "a check fails", **_BAG,
                5: "no verdict (too few usable points; the reason is printed)",
                6: "the run was not lockstep (its lockstep record says so)"},
    "replay": {1: "`--check`: a replayed answer differs from the recorded one", **_BAG,
               6: "`--check` on a run that was not lockstep"},
    "runup": {1: "a run-up check fails", **_BAG},
    "calibrate": {1: "a fit or validation check fails", **_BAG},
    "bag": {**_BAG},
    "api684": {1: "an API 684 requirement fails"},
    "demo": {1: "a comparison of the demo fails"},
    "harmonic": {1: "commissioning refused (the margin, the test levels; the reason is printed)"},
}


def statuses(command: str) -> dict[int, str]:
    """Every exit status of ``command`` with its meaning."""
    return dict(sorted({**COMMON, **BY_COMMAND.get(command, {})}.items()))
