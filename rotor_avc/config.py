"""Configuration files: finding them, loading YAML with includes, validated access.

Every value is read through a :class:`Section`, which knows the dotted path of the value and the
file it came from, so that any problem is reported as ``file: machine.stator_mass_kg: must be
> 0 (got -5) -- fix: ...`` instead of a traceback from deep inside numpy.

Files may say ``include: other.yaml`` (or a list): the included files are loaded first (relative
to the including file) and the including file's values override them, mapping by mapping. An
included file must lie in the including file's folder or below it, or in the package's ``config``
folder (:func:`config_dirs`), symbolic links resolved; any other is refused before it is opened,
so a config cannot make the loader read (or quote in an error) a file the user did not name.
"""
from __future__ import annotations

import difflib
import math
import os
import re
import sys
from pathlib import Path
from typing import Any, Iterable

from .errors import ConfigError
from .yaml_reading import parse, read_text

PACKAGE = "rotor_avc"
_MISSING = object()


def share_dirs() -> list[Path]:
    """Where the package's installed files may live, most specific first.

    The ament index (colcon install), then ``<prefix>/share/rotor_avc`` of this interpreter
    (``pip install .``), then the source tree (editable install or running from a checkout).
    """
    dirs: list[Path] = []
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            dirs.append(Path(prefix) / "share" / PACKAGE)
    for prefix in (sys.prefix, sys.base_prefix):
        dirs.append(Path(prefix) / "share" / PACKAGE)
    dirs.append(Path(__file__).resolve().parent.parent)
    return dirs


def config_dirs() -> list[Path]:
    """Existing ``config`` folders, in search order."""
    return [d / "config" for d in share_dirs() if (d / "config").is_dir()]


def find_config(name: str | os.PathLike) -> Path:
    """Resolve a config given as a path, or as a bare name of a file shipped in ``config/``."""
    path = Path(name)
    if path.is_file():
        return path
    candidates = [path.name] if path.suffix else [path.name + ".yaml", path.name + ".yml"]
    for folder in config_dirs():
        for candidate in candidates:
            if (folder / candidate).is_file():
                return folder / candidate
    shipped = sorted({p.name for d in config_dirs() for p in d.glob("*.yaml")})
    raise ConfigError(
        str(name), "no such file, and no shipped config of that name",
        fix="give a path to a YAML file or one of: " + ", ".join(shipped))


def _merge(base: dict, override: dict) -> dict:
    out = dict(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


#: numbers in a config beyond this magnitude are refused (no SI quantity of a machine is near it)
MAX_MAGNITUDE = 1.0e20
def _key_line(text: str, key: str) -> str:
    """``line N`` of a top-level ``key:`` in ``text`` (for values checked after loading)."""
    match = re.search(rf"^{re.escape(key)}\s*:", text, re.MULTILINE)
    return f"line {text.count(chr(10), 0, match.start()) + 1}: {key}" if match else key


def _include_list(value, text: str, path: Path) -> list[str]:
    """``include:`` as a list of file names (one name or a list of names)."""
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, list) or not all(isinstance(n, str) and n for n in names):
        raise ConfigError(_key_line(text, "include"),
                          f"must be a file name or a list of file names (got {value!r})",
                          fix="write `include: other.yaml` or `include: [a.yaml, b.yaml]`",
                          source=str(path))
    return names


def _include_path(name: str, text: str, path: Path) -> Path:
    """The file an ``include:`` entry of ``path`` names, confined (see the module docstring):
    refused -- without opening it, and alike whether it exists or not -- outside the including
    file's folder and the package's ``config`` folders."""
    where = _key_line(text, "include")
    target = path.parent / name
    folder = path.parent                          # ``path`` is resolved already
    shipped = [Path(os.path.abspath(d)) for d in config_dirs()]
    try:
        real = target.resolve()
        inside = (real.is_relative_to(folder)
                  or any(real.is_relative_to(d.resolve()) for d in shipped)
                  or any(Path(os.path.abspath(target)).is_relative_to(d) for d in shipped))
        found = inside and target.is_file()
    except (OSError, RuntimeError, ValueError) as exc:      # too long, a symlink loop, NUL
        why = getattr(exc, "strerror", None) or type(exc).__name__
        raise ConfigError(where, f"included file {name!r} cannot be resolved ({why})",
                          fix="give a plain relative path", source=str(path)) from None
    if not inside:
        raise ConfigError(where, f"included file {name!r} is outside the folders a config may "
                          f"include from ({folder} and below, the package's config folder)",
                          fix="copy the file next to the including one (or below it), or give "
                              "the path of a shipped config", source=str(path))
    if not found:
        raise ConfigError(where, f"included file {name!r} not found",
                          fix="give a path relative to the including file", source=str(path))
    return target


def load_yaml(path: str | os.PathLike, _seen: tuple[Path, ...] = ()) -> dict:
    """Load a YAML mapping, resolving ``include:`` recursively (cycles are refused).

    Bounded (rotor_avc.yaml_reading): files above its size limit, nesting deeper than its depth
    limit and aliases expanding beyond its node limit are refused; so are
    duplicate keys, tabs in indentation, control characters and non-UTF-8 bytes -- each error
    names the line. Included files are confined (:func:`_include_path`)."""
    path = Path(path).resolve()
    if path in _seen:
        raise ConfigError("include", f"include cycle through {path.name}",
                          fix="remove the circular include", source=str(_seen[0]))
    text = read_text(path)
    data = parse(text, path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError("(top level)", "must be a mapping of keys to values",
                          fix="write `key: value` lines", source=str(path))
    includes = _include_list(data.pop("include", []), text, path)
    merged: dict = {}
    for inc in includes:
        merged = _merge(merged, load_yaml(_include_path(inc, text, path), _seen + (path,)))
    return _merge(merged, data)


def load_config(name: str | os.PathLike) -> "Section":
    """Find and load a configuration file as a validated :class:`Section`."""
    path = find_config(name)
    return Section(load_yaml(path), "", str(path))


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
                close = difflib.get_close_matches(str(key), sorted(allowed), n=1)
                raise self.error(str(key), "unknown key" + (f" (did you mean {close[0]!r}?)"
                                                            if close else ""),
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
