"""A node parameter given with another type than the declared one, refused in one line.

rclpy refuses such a value when the parameter is declared (``-p max_stamp_jump_s:=2`` is an
integer to ROS, the parameter a double) with a message that names neither what to write nor
why. :func:`type_refusal` says it as the other refusals of rotor_avc.nodes.runtime do: the
parameter, the type it must have in ROS's words, what was given, and a value of the right type
to give instead (``-p max_stamp_jump_s:=2.0``; a string that reads as a number quoted:
``-p foot_id:="'5'"``).
"""
from __future__ import annotations

from typing import Any

#: ROS's names of the parameter types (``ros2 param describe``), by the default's Python type
ROS_TYPES = {bool: "bool", int: "integer", float: "double", str: "string"}


def type_refusal(param, node_name: str, got: Any = None) -> str:
    """The refusal of ``got`` (a value of another type; None when unknown) for ``param`` (a
    rotor_avc.nodes.runtime.Param: name, default, description, choices)."""
    want, kind = ROS_TYPES[type(param.default)], ros_type(got)
    given = "" if got is None else f" (got the {kind} {shown(got)})"
    if param.choices:
        example, hint = param.choices[0], "one of: " + ", ".join(param.choices)
    elif want == "double":
        example = float(got) if kind == "integer" else float(param.default)
        hint = "a number with a decimal point"
    elif want == "integer":
        whole = isinstance(got, float) and got.is_integer()
        example, hint = int(got) if whole else param.default, "a whole number"
    elif want == "bool":
        example, hint = "true", "true or false"
    elif kind in ("integer", "double", "bool"):
        example, hint = f"\"'{shown(got)}'\"", f"quoted, or ROS reads it as {_a(kind)}"
    else:
        example, hint = param.default or "...", "text"
    return (f"{node_name}: parameter '{param.name}' must be {_a(want)}{given} -- fix: "
            f"-p {param.name}:={example} ({hint}; {param.description})")


def ros_type(value: Any) -> str:
    """ROS's name of the type of a parameter value as rclpy gives it."""
    if isinstance(value, (str, bool, int, float)):
        return ROS_TYPES[type(value)]
    if isinstance(value, (list, tuple)) or hasattr(value, "typecode"):
        return "array"
    return type(value).__name__


def shown(value: Any) -> str:
    """A parameter value as the user wrote it (arrays as lists, booleans in lower case)."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return repr(value)
    return repr(list(value)) if hasattr(value, "typecode") else str(value)


def _a(type_name: str) -> str:
    return ("an " if type_name[0] in "aeiou" else "a ") + type_name
