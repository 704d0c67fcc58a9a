"""A calibration from recordings to results: each recording compared with the configured
machine (exactly as ``rotor-avc compare`` takes it), its measured points fitted
(rotor_avc.calibration.fit), the calibrated machine written as a configuration and compared
again, on the fitted recordings and on held-out ones (``validate``).

The configuration written, ``calibrated.yaml``, includes ``configured.yaml`` (the given
configuration with its includes merged, so the folder stands alone) and sets the identifiable
fitted values, each with its 95 % interval in a comment; the parameters the data do not
determine keep their configured values and are listed with the reason.
"""
from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from ..compare.comparison import Comparison, compare_bag
from ..compare.mapped_stream import compare_mapped
from ..config import find_config, load_yaml
from ..errors import ConfigError
from ..machine import machine_from_config
from ..output_files import write_text
from .assessment import assess, dense_model
from .fit import IDENTIFIED_WITHIN, Fit, calibrate
from .parameters import Parameter, applied, parameters
from .problem import DEFAULT_SENSOR_UNCERTAINTY, Problem
from .targets import DEFAULT_POINT_UNCERTAINTY, Target, target_of
from .uff_data import is_uff, read_uff_map, uff_target

CONFIGURED, CALIBRATED = "configured.yaml", "calibrated.yaml"


@dataclass(frozen=True)
class Recording:
    """A recording as ``compare`` takes it: a bag of this package (the configured machine
    replaces the bag's) or, with ``map``, any .mcap file or rosbag2 directory; or a UFF file of
    measured FRFs (rotor_avc.calibration.uff_data) with ``uff_map``."""

    path: Path
    map: Path | None
    uff_map: Path | None = None

    def compare(self, config_path: Path) -> Comparison | None:
        """The comparison with the machine of ``config_path`` (None for measured FRFs)."""
        if is_uff(self.path):
            return None
        if self.map is not None:
            return compare_mapped(self.path, config_path, self.map)
        data = load_yaml(config_path)
        return compare_bag(self.path, machine=machine_from_config(data, str(config_path)))

    def target(self, comp: Comparison | None, name: str, machine) -> Target:
        if comp is not None:
            return target_of(comp, name)
        if self.uff_map is None:
            raise ConfigError("--uff-map", f"{self.path} is a UFF file: its responses need a "
                              "mapping", fix="give --uff-map MAP.yaml (uff: input, responses)")
        return uff_target(self.path, read_uff_map(self.uff_map), machine.plant,
                          str(self.uff_map))


def _verdict(comp: Comparison | None) -> str | None:
    return None if comp is None else comp.verdict


@dataclass
class Calibration:
    config_path: Path
    data: dict
    params: list[Parameter]
    fit: Fit
    fitted: list[dict]                 # per fitted recording: name, before, after
    validation: list[dict] = field(default_factory=list)
    #: per recording (fitted, then held out): its measured points and both models over speed
    curves: list[dict] = field(default_factory=list)
    left_out: list[str] = field(default_factory=list)
    floor: float = 0.0
    point: float = 0.0
    calibrated_text: str = ""

    @property
    def values(self) -> np.ndarray:
        """The calibrated values: fitted where fitted, configured elsewhere."""
        return np.array([v if ok else p.initial for p, v, ok in
                         zip(self.params, self.fit.values, self.fit.fitted)])


def _names(recordings: list[Recording]) -> list[str]:
    names = [r.path.name for r in recordings]
    return [str(r.path) if names.count(n) > 1 else n for r, n in zip(recordings, names)]


def _yaml_scalar(value) -> str:
    return yaml.safe_dump(value, default_flow_style=True, width=10_000).strip().removesuffix(
        "\n...").strip()


def calibrated_yaml(config_path: Path, data: dict, params: list[Parameter], fit: Fit,
                    values: np.ndarray, recordings: list[str]) -> str:
    """The text of ``calibrated.yaml`` (module docstring)."""
    lines = [f"# {config_path.name} calibrated to {', '.join(recordings)} (rotor-avc calibrate):",
             "# fitted values with their 95 % intervals; the rest as configured",
             f"include: [{CONFIGURED}]"]
    tree: dict = {}
    calibrated = applied(data, params, values)
    for p, value, std, ci, fitted, why in zip(params, fit.values, fit.std, fit.ci95,
                                              fit.fitted, fit.reasons):
        if not fitted:
            lines.insert(2, f"# not fitted, configured value kept: {p.label}: {why}")
            continue
        note = (f"fitted {'factor ' if p.factor else ''}{value:.6g}{'' if p.factor else ' ' + p.unit}"
                f", 95 % interval [{ci[0]:.6g}, {ci[1]:.6g}], std {std:.3g}; configured "
                f"{p.initial:.6g}" + (f"; {why}" if why else ""))
        node, keys = calibrated, p.path.split(".")
        for key in keys:
            node = node[key]
        _leaves(tree, keys, node, note)
    lines += _emit(tree, 0)
    return "\n".join(lines) + "\n"


def _leaves(tree: dict, keys: list[str], value, note: str) -> None:
    if isinstance(value, dict):
        for key, item in value.items():
            _leaves(tree, keys + [str(key)], item, note)
        return
    node = tree
    for key in keys[:-1]:
        node = node.setdefault(key, {})
    node[keys[-1]] = (value, note)


def _emit(tree: dict, indent: int) -> list[str]:
    out = []
    for key, item in tree.items():
        if isinstance(item, dict):
            out.append(" " * indent + f"{key}:")
            out += _emit(item, indent + 2)
        else:
            value, note = item
            text = (repr(float(value)) if isinstance(value, float) else _yaml_scalar(value))
            out.append(" " * indent + f"{key}: {text}   # {note}")
    return out


def _assessments(problem: Problem, machines: dict, values: dict, curves: list) -> list[dict]:
    """Per recording of ``problem``, :func:`assess` of each named machine; the measured points
    and the models over speed appended to ``curves``."""
    rows = []
    for target in problem.targets:
        one = Problem(problem.data, problem.source, problem.params, [target], problem.floor,
                      problem.point)
        row = {"data": target.name, "points": target.points, "left_out": target.left_out}
        curve = {"data": target.name, "target": target, "models": {}, "band": {}}
        for label, machine in machines.items():
            r = one.residual(values[label])
            dense = dense_model(target, machine)
            row[label] = assess(target, machine, r, max(r.size - len(problem.params), 1), dense)
            curve["models"][label] = dense
            loops = target.loops(machine)[1]
            curve["band"][label] = [b.model(loops) for b in target.band]
        rows.append(row)
        curves.append(curve)
    return rows


def run_calibration(data_paths, config, map_path, fit_paths, bounds=(), priors=(),
                    validate=(), backend=None, starts: int = 0, seed: int = 0,
                    sensor_uncertainty: float = DEFAULT_SENSOR_UNCERTAINTY, report=None,
                    batch_size: int | None = None, uff_map=None,
                    point_uncertainty: float = DEFAULT_POINT_UNCERTAINTY,
                    identified_within: float = IDENTIFIED_WITHIN) -> Calibration:
    """The whole calibration (module docstring); ``report(evaluations, cost)`` is called after
    every Jacobian (progress)."""
    floor = sensor_uncertainty
    for flag, value in (("--sensor-uncertainty", floor), ("--point-uncertainty", point_uncertainty)):
        if not math.isfinite(value) or value < 0:
            raise ConfigError(flag, f"must be a finite number >= 0 (got {value})",
                              fix=f"give {flag} 0.01 (1 %)")
    config_path = find_config(config)
    data = load_yaml(config_path)
    configured = machine_from_config(data, str(config_path))   # a bad config fails here, once
    params = parameters(data, list(fit_paths), list(bounds), list(priors))
    fitted = [Recording(Path(p), map_path, uff_map) for p in data_paths]
    held = [Recording(Path(p), map_path, uff_map) for p in validate]
    names = _names(fitted + held)
    comps = [rec.compare(config_path) for rec in fitted]
    targets = [rec.target(c, n, configured) for rec, c, n in zip(fitted, comps, names)]
    problem = Problem(data, str(config_path), params, targets, floor, point_uncertainty)
    result = calibrate(problem, backend, starts, seed, report, batch_size, identified_within)
    cal = Calibration(config_path, data, params, result, [], floor=floor, point=point_uncertainty,
                      left_out=[x for t in targets for x in t.left_out])
    values = {"configured": problem.initial, "calibrated": cal.values}
    machines = {k: problem.machine(v) for k, v in values.items()}
    cal.calibrated_text = calibrated_yaml(config_path, data, params, result, cal.values,
                                          names[:len(fitted)])
    with tempfile.TemporaryDirectory(prefix="rotor_avc_calibrated_") as tmp:
        written = write_configs(Path(tmp), cal)
        cal.fitted = _assessments(problem, machines, values, cal.curves)
        for row, rec, comp in zip(cal.fitted, fitted, comps):
            row["configured"]["verdict"] = _verdict(comp)
            row["calibrated"]["verdict"] = _verdict(rec.compare(written))
        if held:
            before = [rec.compare(config_path) for rec in held]
            check = Problem(data, str(config_path), params,
                            [rec.target(c, n, configured) for rec, c, n in
                             zip(held, before, names[len(fitted):])], floor, point_uncertainty)
            cal.validation = _assessments(check, machines, values, cal.curves)
            for row, rec, comp in zip(cal.validation, held, before):
                row["configured"]["verdict"] = _verdict(comp)
                row["calibrated"]["verdict"] = _verdict(rec.compare(written))
    return cal


def configured_text(cal: Calibration) -> str:
    return (f"# {cal.config_path} with its includes merged (rotor-avc calibrate)\n"
            + yaml.safe_dump(cal.data, sort_keys=False))


def write_configs(folder: Path, cal: Calibration) -> Path:
    """``configured.yaml`` and ``calibrated.yaml`` in ``folder``; the latter's path."""
    write_text(folder / CONFIGURED, configured_text(cal))
    return write_text(folder / CALIBRATED, cal.calibrated_text)
