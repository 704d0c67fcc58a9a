"""The declared keys of ``model: sleeve_bearing_motor`` (Werner 2019), ``model:
roller_bearing_rotor`` (Werner 2017) and ``model: active_bearing`` (Sci. Rep. 2023): misspelt keys
answered with the closest one, bounds refused with field and unit, cross-field rules, and a
reference row for every key the shipped configs use."""
import pytest
from declared_models import (ROOT, assert_every_shipped_key_has_a_reference_row,
                             assert_model_keys_are_the_declared_fields, changed, loaded,
                             parent, refused)

from rotor_avc.config import Section, load_yaml
from rotor_avc.errors import ConfigError
from rotor_avc.machine import machine_from_config
from rotor_avc.model_config import active_bearing, roller_bearing_rotor, sleeve_bearing_motor

MODULES = {"sleeve_bearing_motor": sleeve_bearing_motor,
           "roller_bearing_rotor": roller_bearing_rotor, "active_bearing": active_bearing}
SLEEVE, ROLLER, ACTIVE = "sleeve_bearing_motor", "roller_bearing_stability", "active_bearing"


@pytest.mark.parametrize("config,path,wrong,right", [
    (SLEEVE, "sleeve_bearing.oil.nu40_mm2_s", "nu40_mm2", "nu40_mm2_s"),
    (SLEEVE, "sleeve_bearing.grid.n_theta", "n_thetha", "n_theta"),
    (SLEEVE, "motor.housing_stiffness_n_per_m", "housing_stifness_n_per_m",
     "housing_stiffness_n_per_m"),
    (SLEEVE, "foundation.L.mass_kg", "mass_kgs", "mass_kg"),
    (SLEEVE, "electromagnetic.field_damping_depth", "field_damping_dept", "field_damping_depth"),
    ("scenario_sleeve_velocity", "actuator.armature_mass_kg", "armatur_mass_kg",
     "armature_mass_kg"),
    (ROLLER, "housings.stiffness_n_per_m", "stifness_n_per_m", "stiffness_n_per_m"),
    (ROLLER, "foundation.tan_delta", "tan_delt", "tan_delta"),
    (ROLLER, "studies.fig10.variants", "variant", "variants"),
    ("scenario_stability_demo", "stator.cog_height_m", "cog_heigth_m", "cog_height_m"),
    (ACTIVE, "active_bearings.1.y.k_ac_n_per_m", "k_ac_n_m", "k_ac_n_per_m"),
    (ACTIVE, "active_bearings.2", "02", "2"),
    (ACTIVE, "rotor.bearing_arm_m.1", "01", "1"),
    (ACTIVE, "piezo.bandwidth_hz", "bandwith_hz", "bandwidth_hz"),
    ("scenario_active_bearing", "feedforward.method", "methd", "method"),
])
def test_a_misspelt_nested_key_is_answered_with_the_closest_one(config, path, wrong, right):
    data = loaded(config)
    sub, key = parent(data, path)
    sub[wrong] = sub.pop(key)
    where = path.rpartition(".")[0] + "." + wrong
    msg = refused(data)
    assert f"{where}: unknown key (did you mean '{right}'?)" in msg, msg


@pytest.mark.parametrize("config,path,value,words", [
    (SLEEVE, "motor.stator_mass_kg", -7040.0, "must be > 0 (got -7040.0 kg)"),
    (SLEEVE, "motor.rotor_tan_delta", 3.0, "loss factor 3.0 is implausibly large -- fix: give "
     "tan(delta) as a fraction (0.04), not a percentage"),
    (SLEEVE, "foundation.R.stiffness_n_per_m.y", 0.0, "must be > 0 (got 0.0 N/m)"),
    (SLEEVE, "sleeve_bearing.relative_clearance", 0.03, "must be <= 0.02 (got 0.03)"),
    (SLEEVE, "sleeve_bearing.table_points", 4, "must be >= 8 (got 4)"),
    (SLEEVE, "sleeve_bearing.oil.expansion_per_k", -1e-4, "must be >= 0 (got -0.0001 1/K)"),
    (SLEEVE, "electromagnetic.rotor_time_constant_s", 0.0, "must be > 0 (got 0.0 s)"),
    (SLEEVE, "electromagnetic.field_damping_depth", 1.5, "must be <= 1.0 (got 1.5)"),
    (SLEEVE, "environment.gravity_m_s2", -9.81, "must be > 0 (got -9.81 m/s^2)"),
    (ROLLER, "stator.cog_height_m", -0.9, "must be >= 0 (got -0.9 m)"),
    (ROLLER, "bearings.stiffness_n_per_m.z", 0.0, "must be > 0 (got 0.0 N/m)"),
    (ROLLER, "rotor.tan_delta", 1.0, "loss factor 1.0 is not a loss factor tan(delta) < 1"),
    (ACTIVE, "active_bearings.2.x.c_pre_n_s_per_m", -1.0, "must be >= 0 (got -1.0 N s/m)"),
    (ACTIVE, "active_bearings.1.housing_mass_kg", 0.0, "must be > 0 (got 0.0 kg)"),
    (ACTIVE, "rotor.tilt_stiffness_n_m_per_rad", -1.0, "must be >= 0 (got -1.0 N m/rad)"),
    (ACTIVE, "rotor.bearing_arm_m.1", -0.08, "must be > 0 (got -0.08 m)"),
    (ACTIVE, "rotor.bearing_arm_m.2", 0.15, "bearing 2 at 0.15 m from the centre of mass is "
     "off the 0.2 m shaft -- fix: give a distance <= 0.1 m"),
    (ACTIVE, "piezo.bandwidth_hz", 0.0, "must be > 0 (got 0.0 Hz)"),
    (ACTIVE, "unbalance.eccentricity_m", -5e-3, "must be > 0 (got -0.005 m)"),
])
def test_a_value_out_of_bounds_is_refused_naming_field_and_unit(config, path, value, words):
    msg = refused(changed(config, path, value))
    assert f"bad.yaml: {path}: {words}" in msg, msg


@pytest.mark.parametrize("config,path,value,words", [
    (SLEEVE, "electromagnetic", {"model": "off", "field_damping_depth": 0.8},
     "electromagnetic.field_damping_depth: only used with `model: field_damping` -- fix: drop "
     "field_damping_depth or set model: field_damping"),
    (SLEEVE, "electromagnetic.rotor_time_constant_s", None,
     "electromagnetic.rotor_time_constant_s: missing -- fix: add `rotor_time_constant_s:` to "
     "electromagnetic (model field_damping needs it), or set model: off"),
    (SLEEVE, "sleeve_bearing.speed_range_rpm", [3000.0, 100.0],
     "sleeve_bearing.speed_range_rpm: need 0 < min < max (got [3000.0, 100.0])"),
    (SLEEVE, "sleeve_bearing.speed_range_rpm", [100.0, 3000.0, 6000.0],
     "sleeve_bearing.speed_range_rpm: must have 2 entries (got 3)"),
    (SLEEVE, "sleeve_bearing.grid.n_theta", 30, "sleeve_bearing.grid: film grid 30 x 12"),
    (SLEEVE, "sleeve_bearing.oil.nu100_mm2_s", 40.0,
     "sleeve_bearing.oil: oil viscosities must satisfy 0 < nu100 < nu40"),
    (ROLLER, "foundation.tan_delta", None, "foundation.tan_delta: missing -- fix: add "
     "`tan_delta:` to foundation (kind soft needs it), or set kind: rigid"),
    (ROLLER, "studies.fig7.vary", ["a=1:2:3", "b=1:2:3", "c=1:2:3"],
     "studies.fig7.vary: must be a list of one or two `PATHS=RANGE` strings"),
    (ROLLER, "studies.fig10.variants", "d", "studies.fig10.variants: must be a list of names"),
    (ROLLER, "variants.b", 0.0, "variants.b: must be a mapping"),
    (ACTIVE, "active_bearings.2", None, "active_bearings.2: missing"),
    (ACTIVE, "sensors.bearing1_side_m", [0.02, 0.12], "sensors.bearing1_side_m: every offset "
     "must lie on the shaft, 0 < l_sen <= 0.1 m (got [0.02, 0.12])"),
    (ACTIVE, "sensors.bearing2_side_m", [0.02], "sensors.bearing2_side_m: has 1 entries, "
     "bearing1_side_m has 5 -- fix: give the sensors in pairs (eq. 11)"),
    (ACTIVE, "piezo.min_voltage_v", 130.0, "piezo.min_voltage_v: 130.0 V is not below "
     "max_voltage_v 120.0 V"),
])
def test_the_cross_field_rules_name_the_field_and_the_fix(config, path, value, words):
    msg = refused(changed(config, path, value))
    assert f"bad.yaml: {words}" in msg, msg


def test_a_rigid_foundation_needs_neither_stiffness_nor_loss_factor():
    data = changed(ROLLER, "foundation", {"kind": "rigid"})
    assert machine_from_config(data).plant.n == 6


def test_the_analysis_sections_are_required_by_their_readers_only():
    data = changed(ACTIVE, "unbalance", None)
    del data["piezo"]
    cfg = machine_from_config(data, "bad.yaml").config           # the plant does without them
    for read, key in ((active_bearing.unbalance_kg_m, "unbalance"),
                      (active_bearing.piezo_from_config, "piezo")):
        with pytest.raises(ConfigError, match=f"bad.yaml: {key}: missing -- fix: add `{key}:`"):
            read(cfg)
    shipped_cfg = Section(load_yaml(ROOT / "config" / f"{ACTIVE}.yaml"), "", ACTIVE)
    assert active_bearing.unbalance_kg_m(shipped_cfg) == 1.0e-3 * 5.0e-3


def test_model_keys_are_the_declared_fields():
    assert_model_keys_are_the_declared_fields(MODULES.values())


@pytest.mark.parametrize("model", sorted(MODULES))
def test_every_key_of_the_shipped_configs_has_a_reference_row(model):
    assert_every_shipped_key_has_a_reference_row(MODULES[model], model)
