"""The declared keys of ``simulation.speed`` (one settings class per profile type),
``simulation.unbalance`` (named entries) and ``simulation.test_signal``: every key typed and
bounded, unknown keys refused with the closest valid one, cross-field rules naming the field."""
import dataclasses
import math
import typing

import numpy as np
import pytest

from rotor_avc import settings
from rotor_avc.config import Section
from rotor_avc.errors import ConfigError
from rotor_avc.scenario import scenario_from_config
from rotor_avc.settings import SimulationSettings, UnbalanceEntry, read_settings
from rotor_avc.sim.speed_profile import PROFILE_SETTINGS, profile_from_config

TWO_PI = 2 * math.pi


def speed_error(data) -> ConfigError:
    with pytest.raises(ConfigError) as exc:
        profile_from_config(Section(data, "simulation.speed", "scn.yaml"))
    return exc.value


def test_every_profile_type_has_a_class_declaring_its_type():
    assert list(PROFILE_SETTINGS) == ["constant", "ramp", "stepped", "sequence"]
    for name, cls in PROFILE_SETTINGS.items():
        first = dataclasses.fields(cls)[0]
        assert first.name == "type" and first.metadata["choices"] == (name,)
        assert first.default is dataclasses.MISSING                     # required
        assert all(f.metadata["doc"] for f in dataclasses.fields(cls))


def test_an_unknown_type_is_refused_with_the_valid_ones():
    err = speed_error({"type": "rampe", "start_hz": 0.0})
    assert err.field == "simulation.speed.type"
    assert "unknown value 'rampe'" in str(err)
    assert err.fix == "use one of: constant, ramp, stepped, sequence"


@pytest.mark.parametrize("data, field, words", [
    ({"type": "ramp", "start_hz": 0.0, "stop_hz": 5.0, "duraton_s": 1.0}, "duraton_s",
     "did you mean 'duration_s'?"),
    ({"type": "constant", "speed_hz": 5.0, "dwell_s": 1.0}, "dwell_s", "unknown key"),
    ({"type": "ramp", "start_hz": 0.0, "stop_hz": 5.0, "rate_hz_per_s": -2.0}, "rate_hz_per_s",
     "must be > 0 (got -2.0 Hz/s)"),
    ({"type": "ramp", "start_hz": -1.0, "stop_hz": 5.0, "duration_s": 1.0}, "start_hz",
     "must be >= 0 (got -1.0 Hz)"),
    ({"type": "ramp", "stop_hz": 5.0, "duration_s": 1.0}, "start_hz", "missing"),
    ({"type": "stepped", "speeds_hz": [], "dwell_s": 1.0}, "speeds_hz", "at least 1"),
    ({"type": "stepped", "speeds_hz": [1.0], "dwell_s": 1.0, "transition_s": -0.1},
     "transition_s", "must be >= 0 (got -0.1 s)"),
    ({"type": "stepped", "speeds_hz": [1.0, "fast"], "dwell_s": 1.0}, "speeds_hz[1]",
     "must be a number"),
    ({"type": "sequence", "parts": [{"type": "constant", "speed_hz": 1.0, "duration_s": 1.0}],
      "loop": True}, "loop", "unknown key"),
    ({"type": "sequence", "parts": [{"type": "constant", "speed_hz": 1.0, "duration_s": 1.0},
                                    {"type": "stepped", "speeds_hz": [2.0], "dwel_s": 1.0}]},
     "parts[1].dwel_s", "did you mean 'dwell_s'?"),
    ({"type": "sequence", "parts": [{"type": "sequence", "parts": []}]}, "parts[0].type",
     "do not nest"),
])
def test_profile_keys_are_declared(data, field, words):
    err = speed_error(data)
    assert err.field == f"simulation.speed.{field}"
    assert words in str(err)


def test_cross_field_rules_give_a_fix():
    err = speed_error({"type": "ramp", "start_hz": 0.0, "stop_hz": 5.0})
    assert err.field == "simulation.speed.duration_s" and "exactly one" in str(err) and err.fix
    err = speed_error({"type": "stepped", "speeds_hz": [3.0, -1.0], "dwell_s": 1.0})
    assert str(err).startswith("scn.yaml: simulation.speed.speeds_hz: speeds must be >= 0 "
                               "(got [3.0, -1.0])") and err.fix


def test_defaults_and_typed_values():
    ramp = read_settings(PROFILE_SETTINGS["ramp"], Section(
        {"type": "ramp", "start_hz": 10, "stop_hz": 4.0, "rate_hz_per_s": 2}))
    assert (ramp.start_hz, ramp.duration_s, ramp.rate_hz_per_s) == (10.0, None, 2.0)
    assert ramp.profile().length_s == pytest.approx(3.0)          # 6 Hz at 2 Hz/s
    stepped = read_settings(PROFILE_SETTINGS["stepped"], Section(
        {"type": "stepped", "speeds_hz": [1, 2], "dwell_s": 0.5}))
    assert stepped.speeds_hz == (1.0, 2.0) and stepped.transition_s == 0.0
    assert stepped.profile().sample(np.array(0.5))[0] == TWO_PI * 2.0      # a jump
    constant = profile_from_config(Section({"type": "constant", "speed_hz": 3.0}))
    assert constant.length_s is None and constant.max_speed_rad_s == TWO_PI * 3.0


def test_unbalance_entries_are_typed():
    sim = read_settings(SimulationSettings, Section(
        {"speed": {"type": "constant", "speed_hz": 1.0},
         "unbalance": {"static": {"magnitude": 2.0, "phase_deg": 90.0},
                       "moment": {"magnitude": 1.0e-3}}}, "simulation"))
    assert sim.unbalance == {"static": UnbalanceEntry(2.0, 90.0),
                             "moment": UnbalanceEntry(1.0e-3, 0.0)}
    assert sim.unbalance["static"].amplitude == 2.0 * complex(math.cos(math.pi / 2), 1.0)
    assert sim.unbalance["moment"].amplitude == 1.0e-3
    assert sim.test_signal is None


def scenario(**simulation):
    from rotor_avc.config import find_config, load_yaml
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"sample_rate_hz": 5000.0, "duration_s": 0.01,
                          "speed": {"type": "constant", "speed_hz": 20.0}, **simulation}
    return scenario_from_config(data, "scn.yaml")


@pytest.mark.parametrize("unbalance, field, words", [
    ({"statc": {"magnitude": 1.0}}, "statc", "unknown key (did you mean 'static'?)"),
    ({"static": {"magnitude": 1.0, "phase": 3.0}}, "static.phase",
     "unknown key (did you mean 'phase_deg'?)"),
    ({"static": {"phase_deg": 3.0}}, "static.magnitude", "missing"),
    ({"static": 1.0e-3}, "static", "must be a mapping"),
])
def test_unbalance_names_are_the_plants_excitations(unbalance, field, words):
    with pytest.raises(ConfigError) as exc:
        scenario(unbalance=unbalance)
    assert exc.value.field == f"simulation.unbalance.{field}" and words in str(exc.value)
    assert scenario(unbalance=None).amplitudes == {}


def read_test_signal(**change):
    data = {"actuator": "DL", "kind": "white", "rms_n": 10.0, "band_hz": [1.0, 100.0], **change}
    return read_settings(settings.TestSignalSettings, Section(data, "simulation.test_signal"))


def test_test_signal_is_declared():
    signal = read_test_signal()
    assert (signal.band_hz, signal.seed, signal.sweep_s) == ((1.0, 100.0), 0, 1.0)
    assert read_test_signal(kind="chirp", sweep_s=2).sweep_s == 2.0
    hints = typing.get_type_hints(SimulationSettings)
    assert hints["test_signal"] == settings.TestSignalSettings | None
    assert hints["unbalance"] == dict[str, UnbalanceEntry] | None


@pytest.mark.parametrize("change, match", [
    ({"band_hz": [1.0, 2.0, 3.0]}, r"test_signal.band_hz: must have 2 entries \(got 3\) -- fix"),
    ({"band_hz": [1.0]}, r"test_signal.band_hz: must have at least 2 entries"),
    ({"seed": -1}, r"test_signal.seed: must be >= 0"),
    ({"seed": 1.5}, r"test_signal.seed: must be an integer"),
    ({"sweep_s": 0.0, "kind": "chirp"}, r"test_signal.sweep_s: must be > 0 \(got 0.0 s\)"),
    ({"rms": 3.0}, r"test_signal.rms: unknown key \(did you mean 'rms_n'\?\)"),
    ({"actuator": 3}, r"test_signal.actuator: must be a string"),
])
def test_test_signal_errors_name_the_field(change, match):
    with pytest.raises(ConfigError, match=match):
        read_test_signal(**change)


def test_the_reference_lists_the_declared_keys():
    rows = {path: (kind, default) for path, kind, default, _ in
            settings._rows(SimulationSettings, "simulation")}
    assert rows["simulation.unbalance.<name>.magnitude"] == ("float", "required")
    assert rows["simulation.unbalance.<name>.phase_deg"] == ("float [deg]", "`0.0`")
    assert rows["simulation.test_signal.band_hz"] == ("list of float [Hz]", "required")
    assert rows["simulation.test_signal.kind"] == ("`white` \\| `chirp`", "required")
    assert rows["simulation.test_signal.seed"] == ("int", "`0`")
