"""The files of a commissioning (rotor_avc.harmonic.commission), written alike by
``rotor-avc harmonic commission`` and the harmonic controller node's ``commission`` mode:

* ``commission.json``: sensors, actuators, harmonics, accepted or the refusal, and per speed the
  identified and the model's matrices (``[re, im]``), the test levels, their settling, the
  phase margins (quasi-steady, exact one-revolution map, its radius) and the halvings' log;
* ``commissioned.yaml`` (accepted only): the scenario included (its own file where a config may
  include it from, else a merged copy ``scenario.yaml`` beside it) with
  ``harmonic.influence.table`` set and no declared model error -- the config the controller
  then adapts with.

:func:`live_commissioning` is the node's block: the commissioning on live signals
(:class:`rotor_avc.harmonic.commission_block.CommissioningBlock`) that writes these files and
then adapts with the written config's controller.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import yaml

from ..config import config_dirs
from ..output_files import make_folder, write_text


def document(result) -> dict:
    """``commission.json`` of a :class:`rotor_avc.harmonic.commission.Commissioning`."""
    def cx(a):
        return [[[float(v.real), float(v.imag)] for v in row] for row in a]
    return {"sensors": list(result.sensors), "actuators": list(result.actuators),
            "harmonics": list(result.harmonics), "accepted": result.refusal is None,
            "refusal": result.refusal, "min_phase_margin_deg": result.min_phase_margin_deg,
            "speeds": [{"speed_hz": r.speed_hz, "identified": [cx(G) for G in r.identified],
                        "model": [cx(G) for G in r.margin.model],
                        "test_force_n": r.levels_n.tolist(), "settling": r.settling.tolist(),
                        "phase_margin_deg": r.margin.phase_margin_deg,
                        "quasi_steady_limit_deg": list(r.margin.quasi_steady_deg),
                        "exact_limit_deg": r.margin.exact_deg, "radius": r.margin.radius,
                        "log": list(r.log)} for r in result.speeds]}


def _include(source: str, out: Path, data: dict) -> str:
    """The scenario as the written config includes it: its own file where a config may
    include it from (the output folder or a shipped config), else a copy in ``out``."""
    path = Path(source).resolve()
    if path.is_relative_to(out.resolve()) or any(path.is_relative_to(Path(d).resolve())
                                                  for d in config_dirs()):
        return os.path.relpath(path, out.resolve())
    write_text(out / "scenario.yaml", f"# {source}, merged\n" + yaml.safe_dump(data))
    return "scenario.yaml"


def write_commission(result, out, source: str, data: dict, command: str) -> Path | None:
    """Write ``commission.json`` into ``out`` and, when ``result`` is accepted,
    ``commissioned.yaml`` (module docstring; its first line names ``command``); the path of
    ``commissioned.yaml``, or None when refused."""
    out = make_folder(Path(out))
    write_text(out / "commission.json", json.dumps(document(result), indent=1) + "\n")
    if result.refusal is not None:
        return None
    doc = {"include": [_include(source, out, data)],
           "harmonic": {"influence": {"phase_error_deg": 0.0, "magnitude_factor": 1.0,
                                      "table": result.table()}}}
    header = (f"# {command} {Path(source).name}: the influence matrix identified on the "
              f"machine, phase margin {result.phase_margin_deg:.1f} deg\n")
    return write_text(out / "commissioned.yaml", header + yaml.safe_dump(doc, sort_keys=False))


def live_commissioning(scenario, out, model_machine=None,
                       command: str = "harmonic_controller commission"):
    """The commissioning block of ``scenario`` at its constant speed (the margin on
    ``model_machine``'s loop, default its own machine): the test level checked against the
    limits now, the files written into ``out`` at the end, then the controller of
    ``commissioned.yaml``. ConfigError for a scenario it cannot commission."""
    from ..harmonic.commission import constant_speed_hz, plan
    from ..harmonic.commission_block import CommissioningBlock
    from ..harmonic.config import harmonic_from_config
    from ..scenario import load_scenario
    p = plan(scenario, model_machine)
    if p.settings.adapt_in != "forces":
        raise p.section.error("adapt_in", "the measured table has no disturbance model to adapt "
                              "the excitations with", fix="use adapt_in: forces (the default)")
    speed_hz = constant_speed_hz(scenario, "run the commission mode on a scenario at a "
                                           "constant speed (the one to commission at)")
    cfg = scenario.machine.config

    def finish(result):
        path = write_commission(result, out, cfg.source, cfg.data, command)
        if path is None:
            return None
        sc = load_scenario(path)
        return harmonic_from_config(sc.machine, sc.sample_period_s, sc.profile.max_speed_rad_s,
                                    sc.damping.whirl_rad_s)
    return CommissioningBlock(p, speed_hz, finish)
