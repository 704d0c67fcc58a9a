"""The scenario of a recording of a real machine: the machine configuration plus what the
recording itself says, so that ``--config`` needs only the machine.

A machine configuration has no speed profile a recording followed (the shaft says how it
turned), and it may have no ``simulation:`` section at all. The comparison needs from a
scenario only the sample rate (the controllers' rate, which the sampled-loop model is built
at), the unbalance reference, the damping rule and the test force; so:

* speed profile, duration and initial state: from the recording -- the configuration's
  ``simulation.speed``, ``duration_s`` and ``initial_state``, if present, are ignored (and
  listed as such), and a constant profile at the recording's top speed stands in, so that the
  scenario's checks (sample rate above twice the top speed, speeds inside the model's range)
  judge the recorded speeds;
* sample rate: ``simulation.sample_rate_hz`` or ``control.sample_rate_hz`` when the
  configuration gives one; for a machine with controllers and neither, their default rate (the
  rate their digital filters run at, which the sampled-loop model must use); for a machine
  without controllers, the fastest mapped channel's rate;
* unbalance: the mapping's ``unbalance`` over ``simulation.unbalance``; with neither the 1x
  response is not compared (no reference);
* damping rule and test force: the configuration's ``simulation`` keys, or their defaults.

:func:`recording_scenario` returns the scenario and ``assumptions``, each value with where it
came from, which ``rotor-avc compare`` prints and writes to ``metrics.json``.
"""
from __future__ import annotations

import copy

from ..scenario import Scenario, scenario_from_config

#: simulation keys a recording replaces
FROM_RECORDING = ("speed", "duration_s", "initial_state")


def recording_scenario(data: dict, config_path: str, rmap, machine, rates_hz: dict[str, float],
                       span_s: float, top_speed_hz: float) -> tuple[Scenario, dict]:
    """``(scenario, assumptions)`` of a recording of the machine ``data`` (module docstring);
    ``rates_hz`` the mapped channels' recorded rates, ``span_s`` the time they all cover,
    ``top_speed_hz`` the recording's highest rotational frequency."""
    sim = copy.deepcopy(data.get("simulation") or {})
    ignored = [key for key in FROM_RECORDING if key in sim]
    for key in FROM_RECORDING:
        sim.pop(key, None)
    rate = _sample_rate(sim, machine, rates_hz)
    sim["sample_rate_hz"] = rate["value"]
    unbalance = {"value": rmap.unbalance, "from": "the mapping's unbalance"}
    if rmap.unbalance is None:
        unbalance = ({"value": sim.get("unbalance"), "from": "simulation.unbalance"}
                     if sim.get("unbalance") else
                     {"value": None, "from": "none given: the 1x response is not compared"})
    if unbalance["value"] is not None:
        sim["unbalance"] = unbalance["value"]
    sim["speed"] = {"type": "constant", "speed_hz": float(top_speed_hz)}
    sim["duration_s"] = float(span_s)
    scenario = scenario_from_config({**data, "simulation": sim},
                                    f"{config_path} with the speeds of the recording")
    assumptions = {
        "sample_rate_hz": rate,
        "speed": {"value": "recorded", "from": f"the shaft ({rmap.shaft.source}, "
                                                f"{rmap.shaft.topic})"},
        "duration_s": {"value": float(span_s), "from": "the time every mapped channel covers"},
        "unbalance": unbalance,
        "damping": {"value": scenario.damping.describe(),
                    "from": "simulation.damping_at" if "damping_at" in sim else "default"},
        "ignored": [f"simulation.{key}" for key in ignored]}
    return scenario, assumptions


def _sample_rate(sim: dict, machine, rates_hz: dict[str, float]) -> dict:
    if sim.get("sample_rate_hz") is not None:
        return {"value": float(sim["sample_rate_hz"]), "from": "simulation.sample_rate_hz"}
    if machine.control.sample_rate_hz is not None:
        return {"value": float(machine.control.sample_rate_hz), "from": "control.sample_rate_hz"}
    if machine.controllers:
        return {"value": float(machine.sample_rate_hz),
                "from": "the controllers' default rate (control.sample_rate_hz unset)"}
    name, rate = max(rates_hz.items(), key=lambda item: item[1])
    return {"value": float(round(rate, 6)), "from": f"the fastest channel, {name}"}


def describe_assumptions(assumptions: dict) -> str:
    """One line: each assumed value and where it came from."""
    parts = [f"{key} {a['value']!r} ({a['from']})" if not isinstance(a["value"], float)
             else f"{key} {a['value']:.6g} ({a['from']})"
             for key, a in assumptions.items() if key != "ignored"]
    if assumptions["ignored"]:
        parts.append("ignored (the recording says it): " + ", ".join(assumptions["ignored"]))
    return "; ".join(parts)
