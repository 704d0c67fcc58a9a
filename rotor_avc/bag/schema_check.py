"""Does a schema say what its type is? Checks shared by the integrity pass and recovery.

* :func:`standard_text_problem` -- a schema named as one of the standard types the package
  knows (:mod:`.msgdefs`) must define exactly that type (and the standard types it uses); a
  foreign type is fine when its messages decode;
* :func:`hash_problem` -- a channel's ``topic_type_hash`` (RIHS01, REP-2011) must be the hash
  of its schema's text and name (a renamed or altered type changes it).
"""
from __future__ import annotations

from mcap.records import Channel, Schema

from .msgdefs import DEFINITIONS, MsgDefError, full_name, known_specs, parse_schema, type_hash

_KNOWN = known_specs()


def standard_text_problem(name: str, data: bytes) -> str | None:
    """Why the ``ros2msg`` text ``data`` of schema ``name`` is not the definition of the
    standard types it names (:mod:`.msgdefs`), or None (also for a foreign type, which is
    fine when its messages decode)."""
    try:
        specs = parse_schema(name, data.decode())
    except (MsgDefError, UnicodeDecodeError) as exc:
        return f"schema {name!r} cannot be parsed ({exc})" if _full(name) in DEFINITIONS else None
    for sub, spec in specs.items():
        if sub in DEFINITIONS and spec != _KNOWN[sub]:
            return (f"the schema text of {name} defines {sub} as ({_fields(spec)}), not as the "
                    f"standard ({_fields(_KNOWN[sub])})")
    return None


def hash_problem(channel: Channel, schema: Schema) -> str | None:
    """Why the channel's ``topic_type_hash`` is not the RIHS01 hash of its (parseable) schema,
    or None (also when the channel carries no hash)."""
    claimed = channel.metadata.get("topic_type_hash", "")
    if not claimed.startswith("RIHS01_"):
        return None
    try:
        actual = type_hash(schema.name, parse_schema(schema.name, schema.data.decode()))
    except (MsgDefError, UnicodeDecodeError, KeyError):
        return None
    if actual == claimed:
        return None
    return (f"topic_type_hash {claimed[:20]}... is not the hash of the schema text of "
            f"{schema.name} (renamed or altered type)")


def _full(name: str) -> str:
    try:
        return full_name(name)
    except MsgDefError:
        return name


def _fields(spec) -> str:
    return ", ".join(f"{f.type} {f.name}" for f in spec.fields)
