"""Validated, path-aware access to a configuration mapping: every value is read through a
:class:`Section`, which knows the dotted path of the value and the file it came from, so that any
problem is reported as ``file: machine.stator_mass_kg: must be > 0 (got -5) -- fix: ...`` instead
of a traceback from deep inside numpy. It knows nothing of files or YAML (rotor_avc.config loads
them), so the rooms that read configurations never import the YAML layer.
"""
from __future__ import annotations

import math
from typing import Any, Iterable

from .errors import ConfigError, did_you_mean

_MISSING = object()
#: numbers in a config beyond this magnitude are refused (no SI quantity of a machine is near it)
MAX_MAGNITUDE = 1.0e20


class Section:
    """A mapping from a config file with validated, path-aware accessors."""

    def __init__(self, data: dict, path: str = "", source: str = ""):
        self.data = data
        self.path = path
        self.source = source

    # -- helpers ---------------------------------------------------------------------------
    def _field(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def error(self, key: str, problem: str, fix: str = "") -> ConfigError:
        return ConfigError(self._field(key), problem, fix, self.source)

    def has(self, key: str) -> bool:
        return key in self.data

    def keys(self) -> list[str]:
        return list(self.data.keys())

    def only(self, keys: Iterable[str]) -> "Section":
        """The same section (path, source) holding only ``keys``: the part of a config that one
        declaration validates (the others are another's)."""
        keys = set(keys)
        return Section({k: v for k, v in self.data.items() if k in keys}, self.path, self.source)

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        if key not in self.data:
            if default is _MISSING:
                raise self.error(key, "missing", fix=f"add `{key}:` to {self.path or 'the file'}")
            return default
        return self.data[key]

    def check_keys(self, allowed: Iterable[str]) -> None:
        """Refuse unknown keys (a misspelt key must not be silently ignored)."""
        allowed = set(allowed)
        for key in self.data:
            if key not in allowed:
                raise self.error(str(key), "unknown key" + did_you_mean(key, allowed),
                                 fix="use one of: " + ", ".join(sorted(allowed)))

    # -- typed accessors --------------------------------------------------------------------
    def section(self, key: str, default: Any = _MISSING) -> "Section":
        value = self.raw(key, default)
        if value is None:
            value = {}
        if not isinstance(value, dict):
            raise self.error(key, f"must be a mapping (got {type(value).__name__})",
                             fix="indent the sub-keys below it")
        return Section(value, self._field(key), self.source)

    def number(self, key: str, default: Any = _MISSING, *, positive: bool = False,
               nonnegative: bool = False, minimum: float | None = None,
               maximum: float | None = None, unit: str = "") -> float:
        value = self.raw(key, default)
        return check_number(value, self._field(key), source=self.source, positive=positive,
                            nonnegative=nonnegative, minimum=minimum, maximum=maximum, unit=unit)

    def integer(self, key: str, default: Any = _MISSING, *, minimum: int | None = None,
                maximum: int | None = None) -> int:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"must be an integer (got {value!r})")
        if minimum is not None and value < minimum:
            raise self.error(key, f"must be >= {minimum} (got {value})")
        if maximum is not None and value > maximum:
            raise self.error(key, f"must be <= {maximum} (got {value})")
        return value

    def string(self, key: str, default: Any = _MISSING) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str):
            raise self.error(key, f"must be a string (got {value!r})")
        return value

    def choice(self, key: str, choices: Iterable[str], default: Any = _MISSING) -> str:
        choices = list(choices)
        value = self.raw(key, default)
        if value not in choices:
            raise self.error(key, f"unknown value {value!r}",
                             fix="use one of: " + ", ".join(map(str, choices)))
        return value

    def number_list(self, key: str, default: Any = _MISSING, *, length: int | None = None,
                    min_length: int = 0, nonempty_leading: bool = False) -> list[float]:
        value = self.raw(key, default)
        if not isinstance(value, (list, tuple)):
            raise self.error(key, f"must be a list of numbers (got {value!r})",
                             fix="write it as [a, b, ...]")
        if length is not None and len(value) != length:
            raise self.error(key, f"must have {length} entries (got {len(value)})")
        if len(value) < min_length:
            raise self.error(key, f"must have at least {min_length} entries (got {len(value)})")
        out = [check_number(v, f"{self._field(key)}[{i}]", source=self.source)
               for i, v in enumerate(value)]
        if nonempty_leading and out and out[0] == 0.0:
            raise self.error(key, "leading coefficient is zero",
                             fix="drop leading zeros (coefficients go highest power first)")
        return out


def check_number(value: Any, field: str, *, source: str = "", positive: bool = False,
                 nonnegative: bool = False, minimum: float | None = None,
                 maximum: float | None = None, unit: str = "") -> float:
    """Validate one number; the message names the field and, where given, its unit."""
    unit_txt = f" {unit}" if unit else ""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        if isinstance(value, str):
            try:
                hint = ("write it without quotes, with a signed exponent (1.0e+6), so YAML reads "
                        "a number" if math.isfinite(float(value)) else "give a finite number")
            except ValueError:
                hint = f"give a plain number in SI units{unit_txt} (no unit suffix)"
        else:
            hint = f"give a number{unit_txt}"
        raise ConfigError(field, f"must be a number (got {value!r})", fix=hint, source=source)
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(field, f"must be finite (got {value})", fix="give a finite number",
                          source=source)
    if abs(value) > MAX_MAGNITUDE:
        raise ConfigError(field, f"{value:g}{unit_txt} is beyond any physical value (|x| > "
                          f"{MAX_MAGNITUDE:g})", fix="give the value in SI units", source=source)
    if positive and value <= 0.0:
        raise ConfigError(field, f"must be > 0 (got {value}{unit_txt})",
                          fix=f"give a positive value in SI units{unit_txt}", source=source)
    if nonnegative and value < 0.0:
        raise ConfigError(field, f"must be >= 0 (got {value}{unit_txt})",
                          fix="give a non-negative value (check the sign convention)", source=source)
    if minimum is not None and value < minimum:
        raise ConfigError(field, f"must be >= {minimum}{unit_txt} (got {value})", source=source)
    if maximum is not None and value > maximum:
        raise ConfigError(field, f"must be <= {maximum}{unit_txt} (got {value})", source=source)
    return value
