"""Configuration files: finding them and loading YAML with includes into one mapping (the YAML
layer: the physics rooms never import it, they read values through
:class:`rotor_avc.section.Section`, which :func:`load_config` returns).

Files may say ``include: other.yaml`` (or a list): the included files are loaded first (relative
to the including file) and the including file's values override them, mapping by mapping. An
included file must lie in the including file's folder or below it, or in the package's ``config``
folder (:func:`config_dirs`), symbolic links resolved; any other is refused before it is opened,
so a config cannot make the loader read (or quote in an error) a file the user did not name.
"""
from __future__ import annotations

import os
import re
import sys
from pathlib import Path

from .errors import ConfigError, did_you_mean, path_suggestion
from .section import Section
from .yaml_reading import parse, read_text

PACKAGE = "rotor_avc"


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
    """Resolve a config given as a path, or as a bare name of a file shipped in ``config/``.

    Neither: the error suggests the closest existing path for a name written as a path (with a
    folder or a suffix; :func:`rotor_avc.errors.path_suggestion`), else the closest shipped name."""
    path = Path(name)
    if path.is_file():
        return path
    candidates = [path.name] if path.suffix else [path.name + ".yaml", path.name + ".yml"]
    for folder in config_dirs():
        for candidate in candidates:
            if (folder / candidate).is_file():
                return folder / candidate
    shipped = sorted({p.stem for d in config_dirs() for p in d.glob("*.yaml")})
    as_path = path_suggestion(path) if path.parent != Path() or path.suffix else ""
    raise ConfigError(
        str(name), "no such file, and no shipped config of that name"
        + (as_path or did_you_mean(path.stem, shipped)),
        fix="give a path to a YAML file or one of: " + ", ".join(shipped))


def _merge(base: dict, override: dict) -> dict:
    out = dict(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


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
    file's folder and the package's ``config`` folders. One inside that does not exist is
    answered with the closest entry of its folder (not for a name with ``..``, so that the
    listed folder is inside too)."""
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
        near = "" if ".." in Path(name).parts else path_suggestion(name, folder)
        raise ConfigError(where, f"included file {name!r} not found{near}",
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


def _includes(path: Path, _seen: tuple[Path, ...] = ()) -> set[Path]:
    """Every file ``path`` includes, directly or through others."""
    path = path.resolve()
    if path in _seen:
        return set()
    text = read_text(path)
    data = parse(text, path)
    found: set[Path] = set()
    if isinstance(data, dict):
        for inc in _include_list(data.get("include", []), text, path):
            child = _include_path(inc, text, path).resolve()
            found |= {child} | _includes(child, _seen + (path,))
    return found


def scenarios_using(name: str | os.PathLike) -> list[str]:
    """The shipped scenarios (configs with a ``simulation:`` section) that include the config
    ``name``, directly or through others."""
    target = find_config(name).resolve()
    names = []
    for folder in config_dirs():
        for path in sorted(folder.glob("*.yaml")):
            try:
                if target in _includes(path) and "simulation" in load_yaml(path):
                    names.append(path.stem)
            except ConfigError:
                continue                  # a broken file is not a suggestion
    return sorted(set(names))

