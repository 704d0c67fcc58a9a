"""``rotor-avc config``: the configuration language -- its JSON Schema, a file checked and
resolved, one resolved value, a starting config, the reference (rotor_avc.config_schema, rotor_avc.config_documents)."""
from __future__ import annotations

import json
from pathlib import Path

from ..config import find_config
from ..config_documents import (Resolved, nested, reference_document, resolve, template,
                                yaml_text)
from ..config_schema import schema
from ..errors import ConfigError
from ..machine import MODELS, load_machine, model_supports
from ..output_files import write_text

NAME = "config"
HELP = ("The configuration language: its JSON Schema (for editors), a file checked as the "
        "product reads it with every resolved key, its unit and where it comes from, one "
        "resolved value, a commented starting config of a model, the reference.")
EXAMPLE = "rotor-avc config check scenario_case3_steady --json"


def add_arguments(p) -> None:
    sub = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    s = sub.add_parser("schema", help="the JSON Schema (draft 2020-12) of a config file")
    s.add_argument("--out", help="write it to this file (default: print it)")
    s = sub.add_parser("check", help="validate a config as the commands read it and list every "
                                     "resolved key (includes merged, defaults filled)")
    s.add_argument("file", help="a YAML path or a shipped name (scenario_case3_steady)")
    s.add_argument("--json", action="store_true",
                   help="print the resolved configuration as JSON (the schema validates it)")
    s = sub.add_parser("show", help="one resolved value of a config")
    s.add_argument("file", help="a YAML path or a shipped name")
    s.add_argument("--path", required=True, help="dotted key path, e.g. simulation.speed.type "
                                                 "(a list entry by its index)")
    s = sub.add_parser("new", help="a commented starting config of a model family")
    s.add_argument("model", choices=list(MODELS))
    s.add_argument("--out", help="the file to write (refused if it exists; default: print it)")
    s = sub.add_parser("reference", help="the configuration reference (markdown)")
    s.add_argument("--out", help="write it to this file, e.g. docs/config-reference.md")


def load_resolved(name) -> tuple[str, list[Resolved]]:
    """Validate a config as the commands read it -- the machine; the scenario when it has
    ``simulation:``; ``balancer:`` and ``harmonic:``, which a machine's load leaves to the runs
    that use them -- and resolve it: ``(its path, every key)``."""
    from ..balancing.scenario import machine_setup, rigid_setup
    from ..harmonic.config import harmonic_section
    from ..scenario import scenario_from_machine
    machine = load_machine(find_config(name))
    cfg = machine.config
    if cfg.has("simulation"):
        scenario_from_machine(machine)
    if cfg.has("balancer"):
        rigid_setup(cfg) if model_supports(cfg, "rigid_balancer") else machine_setup(machine)
    if cfg.has("harmonic"):
        harmonic_section(cfg)
    return cfg.source, resolve(cfg)


def _lookup(entries: list[Resolved], path: str, source: str):
    value = nested(entries)
    for i, key in enumerate(path.split(".")):
        if isinstance(value, list) and key.isdigit() and int(key) < len(value):
            value = value[int(key)]
        elif isinstance(value, dict) and key in value:
            value = value[key]
        else:
            where = ".".join(path.split(".")[:i]) or "the top level"
            keys = (list(value) if isinstance(value, dict) else
                    [str(n) for n in range(len(value))] if isinstance(value, list) else [])
            raise ConfigError(path, f"no key {key!r} in {where} of the resolved configuration",
                              fix=("use one of: " + ", ".join(keys)) if keys else
                              f"{where} is a value, not a mapping", source=source)
    return value


def _emit(text: str, out: str | None) -> None:
    if out is None:
        print(text, end="" if text.endswith("\n") else "\n")
    else:
        write_text(out, text)
        print(f"wrote {out}")


def _check_table(source: str, entries: list[Resolved]) -> str:
    rows = [(".".join(e.path), yaml_text(e.value), e.unit, e.origin) for e in entries]
    widths = [min(max(len(r[i]) for r in rows + [("key", "value", "unit", "from")]), 40)
              for i in range(3)]
    given = sum(e.origin != "default" for e in entries)
    lines = [f"{source}: valid ({len(entries)} keys: {given} given, "
             f"{len(entries) - given} defaults)",
             *(f"{k:<{widths[0]}}  {v:<{widths[1]}}  {u:<{widths[2]}}  {o}"
               for k, v, u, o in [("key", "value", "unit", "from")] + rows)]
    return "\n".join(lines) + "\n"


def run(args) -> int:
    if args.action == "schema":
        _emit(json.dumps(schema(), indent=1) + "\n", args.out)
    elif args.action == "reference":
        _emit(reference_document(), args.out)
    elif args.action == "new":
        text = template(args.model)
        if args.out is not None and Path(args.out).exists():
            raise ConfigError(args.out, "exists", fix="give a new file name (a starting config "
                              "does not replace a file)")
        _emit(text, args.out)
    else:
        source, entries = load_resolved(args.file)
        if args.action == "show":
            value = _lookup(entries, args.path, source)
            print(value if isinstance(value, str) else json.dumps(value, default=str))
        elif args.json:
            print(json.dumps(nested(entries), indent=1, default=str))
        else:
            print(_check_table(source, entries), end="")
    return 0
