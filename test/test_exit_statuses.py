"""Every command's exit statuses: the README's table is the declaration
(rotor_avc/cli/exit_status.py), every status a command's code returns is declared, and the
common ones happen as documented."""
import ast
import importlib
import inspect
import re
from pathlib import Path

import pytest

from rotor_avc.cli import COMMANDS, MODULES, main
from rotor_avc.cli.exit_status import BY_COMMAND, COMMON, statuses

README = Path(__file__).resolve().parent.parent / "README.md"


def _readme_rows() -> list[tuple[int, str, str]]:
    text = README.read_text()
    start = text.index("| exit status | meaning | commands |")
    rows = []
    for line in text[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        rows.append((int(cells[0]), cells[1].replace("\\|", "|"), cells[2]))
    return rows


def test_the_readme_table_is_the_declaration():
    declared = [(code, text, "every command") for code, text in COMMON.items()]
    groups: dict = {}
    for command, codes in BY_COMMAND.items():
        for code, text in codes.items():
            groups.setdefault((code, text), []).append(command)
    declared += [(code, text, ", ".join(f"`{c}`" for c in commands))
                 for (code, text), commands in sorted(groups.items(), key=lambda kv: kv[0][0])]
    assert _readme_rows() == declared
    assert set(BY_COMMAND) <= set(COMMANDS)


def _status_values(expr, module) -> set[int] | None:
    """The statuses an expression of ints and ``EXIT_*`` names can take (conditionals, a dict's
    ``.get`` with a default); None for any other expression."""
    if isinstance(expr, ast.Constant) and type(expr.value) is int:
        return {expr.value}
    if isinstance(expr, ast.Name) and expr.id.startswith("EXIT_"):
        return {getattr(module, expr.id)}
    parts = None
    if isinstance(expr, ast.IfExp):
        parts = [expr.body, expr.orelse]
    elif isinstance(expr, ast.Call) and isinstance(expr.func, ast.Attribute) \
            and expr.func.attr == "get" and isinstance(expr.func.value, ast.Dict):
        parts = list(expr.func.value.values) + list(expr.args[1:])
    if parts is None:
        return None
    values = [_status_values(p, module) for p in parts]
    return None if None in values else set().union(*values)


def _returned_statuses(command: str) -> set[int]:
    """The statuses the command module's functions return (expressions of ints and
    ``EXIT_*`` names)."""
    module = importlib.import_module(f"rotor_avc.cli.{MODULES.get(command, command.replace('-', '_'))}")
    found = set()
    for node in ast.walk(ast.parse(inspect.getsource(module))):
        if isinstance(node, ast.Return) and node.value is not None:
            found |= _status_values(node.value, module) or set()
    return found


@pytest.mark.parametrize("command", COMMANDS)
def test_every_status_a_command_returns_is_declared(command):
    assert _returned_statuses(command) <= set(statuses(command)), command


def test_a_status_returned_but_not_declared_is_caught():
    # bag returns EXIT_CORRUPT (4): without its declaration the check above fails
    assert 4 in _returned_statuses("bag") and 4 not in COMMON


@pytest.mark.parametrize("command", COMMANDS)
def test_usage_errors_end_with_status_2(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--no-such-option"])
    assert exc.value.code == 2
    assert "error:" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["poles", "no_such_machine"], ["frf", "nope.yaml", "--out", "x"],
                                  ["compare", "no_such.mcap"], ["bag", "info", "no_such.mcap"],
                                  ["simulate", "no_such_scenario", "--out", "x.npz"],
                                  ["runup", "no_such.mcap", "--out", "r"]])
def test_missing_inputs_end_with_status_2_and_one_line(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"rotor-avc {argv[0]}: error: ")
