"""The parameters a calibration fits: declared numeric configuration paths, their units, bounds
and priors (``rotor-avc calibrate --fit --bounds --prior``).

A parameter is a dotted path of the machine's configuration (``foundation.stiffness_n_per_m.z``)
whose declaration (rotor_avc.config_schema) is a number; its unit and bounds are the declared
ones. ``PATH*`` fits a dimensionless factor on every number under the path (a stiffness triple
``elements.actuator.stiffness_n_per_m*``, all of a list), starting at 1.

Default bounds: a tenth to ten times the configured value (a factor: 0.1 to 10), inside the
declared bounds; a configured zero ranges over the declared bounds. ``--bounds PATH=LO:HI``
replaces them; bounds that exclude the configured value, or leave the declared range, are
refused. ``--prior PATH=normal(MEAN,STD)`` adds the Gaussian prior's term ``(value - MEAN) / STD``
to the residual (the fit is then the maximum a posteriori estimate).

Internally each parameter is fitted as ``value / reference`` (``reference`` the magnitude of the
configured value, else the bounds' span, else 1), so every fitted number is of order one and
the finite-difference steps scale with the configured values.
"""
from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass

from ..config_schema import LIST, NAME, NAMED, SECTION, UNION, UNION_KEY, VALUE, language
from ..errors import ConfigError

#: default range of a fitted value around the configured one (factor either way)
DEFAULT_RANGE = 10.0
#: top-level sections that describe a run or an analysis, not the machine
NOT_MACHINE = ("simulation", "analysis", "harmonic", "balancer", "model", "name", "description")
_PRIOR = re.compile(r"normal\(\s*([^,()]+)\s*,\s*([^,()]+)\s*\)")


@dataclass(frozen=True)
class Parameter:
    """One fitted quantity: a value at ``path`` (or, with ``factor``, a factor on every number
    under it)."""

    path: str
    factor: bool
    unit: str
    initial: float
    lower: float
    upper: float
    prior: tuple[float, float] | None = None

    @property
    def label(self) -> str:
        return self.path + ("*" if self.factor else "")

    @property
    def reference(self) -> float:
        if self.initial != 0:
            return abs(self.initial)
        span = self.upper - self.lower
        return span if math.isfinite(span) and span > 0 else 1.0


def _numbers(node, path: str) -> list:
    """Every number under a declared node (a factor's leaves), as declaration nodes."""
    if node.kind == VALUE:
        return [node] if node.schema.get("type") in ("number", "integer") else []
    return [leaf for child in node.children.values() for leaf in _numbers(child, path)]


def declared_node(model: str, data: dict, path: str, field: str):
    """The declaration of ``path`` in the language of ``model`` (named entries and ``type``
    unions resolved with the configuration's own values)."""
    node, value = language(model), data
    for depth, key in enumerate(path.split(".")):
        if node.kind == UNION and isinstance(value, dict):
            node = node.children.get(value.get(UNION_KEY), node)
        if node.kind == NAMED:
            node = node.children[NAME]
        elif node.kind != SECTION or key not in node.children:
            here = ".".join(path.split(".")[:depth]) or "(top level)"
            keys = sorted(node.children) if node.kind == SECTION else []
            raise ConfigError(field, f"{path!r}: {here} declares no key {key!r}",
                              fix=("use one of " + ", ".join(keys)) if keys else
                              "give the dotted path of a declared number "
                              "(rotor-avc config reference)")
        else:
            node = node.children[key]
        value = value.get(key) if isinstance(value, dict) else None
    if node.kind == UNION and isinstance(value, dict):
        node = node.children.get(value.get(UNION_KEY), node)
    return node, value


def _bounds_of(node) -> tuple[float, float]:
    s = node.schema
    lo = s.get("minimum", s.get("exclusiveMinimum", -math.inf))
    hi = s.get("maximum", s.get("exclusiveMaximum", math.inf))
    return float(lo), float(hi)


def _declared(model: str, data: dict, path: str, factor: bool, field: str):
    """``(unit, initial, declared lower, declared upper)`` of one ``--fit`` entry."""
    if path.split(".")[0] in NOT_MACHINE:
        raise ConfigError(field, f"{path!r} is not part of the machine ({path.split('.')[0]}: "
                          "describes a run or an analysis)",
                          fix="fit machine parameters: machine.*, foundation.*, elements.*, "
                              "bearings, controllers")
    node, value = declared_node(model, data, path, field)
    if factor:
        if value is None:
            raise ConfigError(field, f"{path!r} has no value in the configuration",
                              fix=f"set {path} in the configuration first")
        leaves = _numbers(node, path) if node.kind in (SECTION, VALUE, LIST) else []
        if not leaves and not (isinstance(value, list) and value):
            raise ConfigError(field, f"{path}*: no number is declared under {path!r}",
                              fix="give a path whose values are numbers")
        return "1", 1.0, 0.0, math.inf
    if node.kind != VALUE or node.schema.get("type") not in ("number", "integer"):
        raise ConfigError(field, f"{path!r} is not a declared number ({node.type_name or node.kind})",
                          fix="fit a numeric key, or a whole vector with a factor: "
                              f"--fit {path}*")
    if value is None:
        value = node.default if isinstance(node.default, (int, float)) else None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(field, f"{path!r} has no value in the configuration",
                          fix=f"set {path} in the configuration first")
    lo, hi = _bounds_of(node)
    return node.unit or "1", float(value), lo, hi


def parse_fit(texts: list[str]) -> list[tuple[str, bool]]:
    """``--fit PATH[,PATH...]`` (repeatable) -> ``[(path, factor)]``; ``PATH*`` (or ``PATH*=``)
    a factor."""
    out = []
    for text in texts:
        for item in (p.strip() for p in text.split(",")):
            if not item:
                continue
            factor = item.endswith("*") or item.endswith("*=")
            path = item.rstrip("=").rstrip("*")
            if not re.fullmatch(r"[A-Za-z0-9_]+(\.[A-Za-z0-9_]+)*", path):
                raise ConfigError("--fit", f"{item!r} is not a dotted config path",
                                  fix="e.g. --fit foundation.stiffness_n_per_m.z,"
                                      "elements.actuator.stiffness_n_per_m*")
            if any(p == path for p, _ in out):
                raise ConfigError("--fit", f"{path!r} is given twice", fix="give it once")
            out.append((path, factor))
    if not out:
        raise ConfigError("--fit", "no parameter to fit", fix="give --fit PATH[,PATH...]")
    return out


def _keyed(texts: list[str], flag: str, fix: str) -> dict[str, str]:
    out = {}
    for text in texts:
        if "=" not in text:
            raise ConfigError(flag, f"{text!r} has no `=`", fix=fix)
        path, rhs = text.split("=", 1)
        out[path.strip().rstrip("*")] = rhs.strip()
    return out


def _float(text: str, flag: str, fix: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(flag, f"{text!r} is not a number", fix=fix) from None
    if not math.isfinite(value):
        raise ConfigError(flag, f"{text!r} is not finite", fix=fix)
    return value


def _range(p: str, unit: str, initial: float, dlo: float, dhi: float, given: str | None):
    fix = f"write --bounds {p}=LO:HI with LO <= {initial:g} <= HI ({unit})"
    if given is None:
        if initial > 0:
            lo, hi = initial / DEFAULT_RANGE, initial * DEFAULT_RANGE
        elif initial < 0:
            lo, hi = initial * DEFAULT_RANGE, initial / DEFAULT_RANGE
        else:
            lo, hi = dlo, dhi
        return max(lo, dlo), min(hi, dhi)
    parts = given.split(":")
    if len(parts) != 2:
        raise ConfigError("--bounds", f"{p}={given!r} is not LO:HI", fix=fix)
    lo, hi = (_float(x, "--bounds", fix) for x in parts)
    if not lo < hi:
        raise ConfigError("--bounds", f"{p}: LO {lo:g} is not below HI {hi:g}", fix=fix)
    if not lo <= initial <= hi:
        raise ConfigError("--bounds", f"{p}: [{lo:g}, {hi:g}] excludes the configured value "
                                      f"{initial:g} {unit}", fix=fix)
    if lo < dlo or hi > dhi:
        raise ConfigError("--bounds", f"{p}: [{lo:g}, {hi:g}] leaves the declared range "
                                      f"[{dlo:g}, {dhi:g}] {unit}", fix=fix)
    return lo, hi


def _prior(p: str, text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    fix = f"write --prior {p}=normal(MEAN,STD) with STD > 0"
    match = _PRIOR.fullmatch(text)
    if not match:
        raise ConfigError("--prior", f"{p}={text!r} is not normal(MEAN,STD)", fix=fix)
    mean, std = (_float(x, "--prior", fix) for x in match.groups())
    if std <= 0:
        raise ConfigError("--prior", f"{p}: STD {std:g} must be > 0", fix=fix)
    return mean, std


def parameters(data: dict, fit: list[str], bounds: list[str] = (),
               priors: list[str] = ()) -> list[Parameter]:
    """The parameters of ``--fit`` with their ``--bounds`` and ``--prior`` (module docstring)."""
    entries = parse_fit(fit)
    given = _keyed(bounds, "--bounds", "write --bounds PATH=LO:HI")
    prior = _keyed(priors, "--prior", "write --prior PATH=normal(MEAN,STD)")
    names = {p for p, _ in entries}
    for flag, table in (("--bounds", given), ("--prior", prior)):
        for path in table:
            if path not in names:
                raise ConfigError(flag, f"{path!r} is not fitted", fix=f"add it to --fit, or "
                                        f"drop it from {flag}")
    out = []
    for path, factor in entries:
        unit, initial, dlo, dhi = _declared(data["model"], data, path, factor, "--fit")
        lo, hi = _range(path, unit, initial, dlo, dhi, given.get(path))
        if not lo < hi:
            raise ConfigError("--bounds", f"{path}: the declared range leaves no room around "
                                          f"{initial:g} {unit}", fix=f"give --bounds {path}=LO:HI")
        out.append(Parameter(path, factor, unit, initial, lo, hi, _prior(path, prior.get(path))))
    return out


def _scaled(value, factor: float):
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return float(value) * factor
    if isinstance(value, dict):
        return {k: _scaled(v, factor) for k, v in value.items()}
    if isinstance(value, list):
        return [_scaled(v, factor) for v in value]
    return value


def applied(data: dict, params: list[Parameter], values) -> dict:
    """A copy of the configuration ``data`` with each parameter set to its value (a factor
    multiplying the configured numbers under its path)."""
    out = copy.deepcopy(data)
    for p, value in zip(params, values):
        keys = p.path.split(".")
        node = out
        for key in keys[:-1]:
            node = node.setdefault(key, {})
        node[keys[-1]] = (_scaled(node[keys[-1]], float(value)) if p.factor else float(value))
    return out
