"""The ``controllers:`` section is declared once (rotor_avc.control.spec.ControllerSettings): every
key an entry may carry, read in one step into typed entries, from which both the continuous
G_c(s) and the digital block are built."""
import copy
import dataclasses
import math

import numpy as np
import pytest

from rotor_avc.config import Section, load_config
from rotor_avc.control import spec
from rotor_avc.control.block import DigitalController, build_digital_controllers
from rotor_avc.control.discretize import discretize_controller
from rotor_avc.control.spec import (BLOCK_KEYS, CONTROLLER_KEYS, CONTROLLER_SETTINGS,
                                    OPTIONAL_KEYS, PLAUSIBLE_LIMITS, ControllerSettings,
                                    controller_from_config, controller_settings)
from rotor_avc.errors import ConfigError
from rotor_avc.machine import machine_from_config

I_ACC = {"type": "I", "feedback": "acceleration", "ki": 1.4e5}


def case3(entry) -> dict:
    data = copy.deepcopy(load_config("foot_mount_case3").data)
    data["controllers"] = {"DL": entry}
    return data


def refused(entry) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        machine_from_config(case3(entry), "m.yaml")
    return info.value


def test_every_key_of_an_entry_is_declared_once():
    names = [f.name for f in dataclasses.fields(CONTROLLER_SETTINGS)]
    used = {"type", "feedback", *BLOCK_KEYS}
    for kind in spec.STRUCTURES:
        used |= {*CONTROLLER_KEYS[kind], *OPTIONAL_KEYS[kind]}
    assert len(names) == len(set(names)) and set(names) == used
    for f in dataclasses.fields(CONTROLLER_SETTINGS):
        assert f.metadata["doc"], f.name
    # gains and limits whose unit depends on the feedback kind say so (no single declared unit)
    for name in ("kp", "ki", "kd", "gain", "num", "measurement_limit"):
        f = next(f for f in dataclasses.fields(CONTROLLER_SETTINGS) if f.name == name)
        assert f.metadata["unit"] == "" and "velocity" in f.metadata["doc"], name
    assert "100 m/s" in next(f for f in dataclasses.fields(CONTROLLER_SETTINGS)
                             if f.name == "measurement_limit").metadata["doc"]


def test_shipped_config_reads_into_typed_entries():
    entries = controller_settings(load_config("foot_mount_case3"))
    assert list(entries) == ["DL", "DR", "NL"]
    assert entries["DL"] == ControllerSettings(type="I", feedback="acceleration", ki=1.4e5)
    assert controller_settings(Section({"controllers": None})) == {}
    assert controller_settings(Section({})) == {}


@pytest.mark.parametrize("entry,factory", [
    ({"type": "P", "feedback": "velocity", "kp": 3e4}, lambda: spec.p_controller(3e4, "velocity")),
    ({**I_ACC, "leak_hz": 0.5}, lambda: spec.i_controller(1.4e5, "acceleration", 0.5)),
    ({"type": "PI", "feedback": "displacement", "kp": 1e6, "ki": 1e7},
     lambda: spec.pi_controller(1e6, 1e7, "displacement")),
    ({"type": "PD", "feedback": "displacement", "kp": 1e6, "kd": 1e3,
      "derivative_filter_s": 1e-4}, lambda: spec.pd_controller(1e6, 1e3, "displacement", 1e-4)),
    ({"type": "PID", "feedback": "velocity", "kp": 1e3, "ki": 1e5, "kd": 1.0,
      "derivative_filter_s": 1e-4, "leak_hz": 1.0},
     lambda: spec.pid_controller(1e3, 1e5, 1.0, "velocity", 1e-4, 1.0)),
    ({"type": "lead_lag", "feedback": "velocity", "gain": 1e4, "zero_hz": 5.0, "pole_hz": 50.0},
     lambda: spec.lead_lag_controller(1e4, 5.0, 50.0, "velocity")),
    ({"type": "tf", "feedback": "acceleration", "num": [1.4e5], "den": [1.0, 3.0]},
     lambda: spec.ContinuousController(np.array([1.4e5]), np.array([1.0, 3.0]), "acceleration")),
])
def test_continuous_controller_is_built_from_the_typed_entry(entry, factory):
    got = machine_from_config(case3(entry)).controllers["DL"]
    want = factory()
    assert np.array_equal(got.num, want.num) and np.array_equal(got.den, want.den)
    assert (got.feedback, got.structure, got.gains) == (want.feedback, want.structure, want.gains)


def test_type_none_gives_no_controller_but_its_block_keys_are_checked():
    machine = machine_from_config(case3({"type": "none", "force_limit_n": 5.0}))
    assert "DL" not in machine.controllers
    assert "DL" not in machine_from_config(case3(None)).controllers
    assert controller_from_config(Section({}, "study")) is None
    err = refused({"delay_samples": -1})                    # refused when loaded, not when run
    assert err.field == "controllers.DL.delay_samples" and ">= 0" in str(err)
    err = refused({"type": "none", "feedback": "jerk"})
    assert err.field == "controllers.DL.feedback" and "unknown value" in str(err)


def test_block_defaults_follow_the_entry():
    T = 1 / 5000.0
    tf = discretize_controller(spec.i_controller(1.4e5, "acceleration"), T)
    plain = DigitalController.from_settings(tf, ControllerSettings(**I_ACC))
    assert plain.anti_windup == "none"
    assert plain.measurement_limit == PLAUSIBLE_LIMITS["acceleration"]
    assert math.isinf(plain.limits.force_limit_n) and plain.delay_samples == 0
    limited = DigitalController.from_settings(
        tf, ControllerSettings(**I_ACC, rate_limit_n_per_s=1e6, measurement_limit=50.0,
                               delay_samples=2), name="DL")
    assert limited.anti_windup == "back_calculation" and limited._kb == 1.0
    assert limited.limits.max_step_n == 1e6 * T and limited.measurement_limit == 50.0
    assert limited.delay_samples == 2 and limited.name == "DL"


def test_controller_set_in_code_without_an_entry_gets_the_block_defaults():
    machine = machine_from_config(case3(I_ACC))
    machine.controllers["DR"] = spec.p_controller(1e3, "velocity")
    machine = dataclasses.replace(machine, controller_settings={
        k: v for k, v in machine.controller_settings.items() if k != "DL"})
    blocks = build_digital_controllers(machine)
    assert blocks["DL"].anti_windup == "none" and blocks["DR"].measurement_limit == 100.0


@pytest.mark.parametrize("entry,field,words", [
    ({**I_ACC, "leak_hz_": 1.0}, "controllers.DL.leak_hz_", "did you mean 'leak_hz'"),
    ({**I_ACC, "ki": None}, "controllers.DL.ki", "missing"),
    ({"type": "I", "feedback": None, "ki": 1.0}, "controllers.DL.feedback", "missing"),
    ({"type": "tf", "feedback": "velocity", "num": [0.0, 1.0], "den": [1.0, 2.0]},
     "controllers.DL.num", "leading coefficient is zero"),
    ({"type": "tf", "feedback": "velocity", "num": [1.0], "den": []},
     "controllers.DL.den", "at least 1"),
    ({"type": "lead_lag", "feedback": "velocity", "gain": 1.0, "zero_hz": -1.0, "pole_hz": 5.0},
     "controllers.DL.zero_hz", "must be > 0 (got -1.0 Hz)"),
    ({**I_ACC, "anti_windup": "clamp"}, "controllers.DL.anti_windup", "unknown value 'clamp'"),
    ({**I_ACC, "measurement_limit": 0.0}, "controllers.DL.measurement_limit", "must be > 0"),
    ({**I_ACC, "delay_samples": 1001}, "controllers.DL.delay_samples", "<= 1000"),
])
def test_bad_entry_names_the_field(entry, field, words):
    err = refused(entry)
    assert err.field == field and words in str(err), str(err)
    assert err.source == "m.yaml"


def test_a_structure_refuses_the_gains_of_another_with_its_own_keys():
    err = refused({**I_ACC, "kp": 3.0})
    assert err.field == "controllers.DL.kp" and "unknown key" in str(err)
    fix = err.fix.split(": ", 1)[1].split(", ")
    assert "ki" in fix and "leak_hz" in fix and "force_limit_n" in fix and "kp" not in fix


def test_missing_gain_names_what_the_structure_needs():
    err = refused({"type": "PID", "feedback": "velocity", "kp": 1.0, "ki": 1.0})
    assert err.field == "controllers.DL.kd" and "PID needs feedback, kp, ki, kd" in err.fix


def test_gain_study_entries_are_read_the_same_way():
    ctrl = controller_from_config(Section({"type": "PI", "feedback": "velocity", "kp": 2,
                                           "ki": 3}, "study"))
    assert ctrl.gains == (("kp", 2.0), ("ki", 3.0))
    with pytest.raises(ConfigError) as info:
        controller_from_config(Section({"type": "P", "feedback": "velocity"}, "study"))
    assert info.value.field == "study.kp"
