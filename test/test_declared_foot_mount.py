"""The declared keys of ``model: foot_mount_3d`` (Werner 2021) and ``model: rigid_rotor``
(Zhou & Shi 2001): misspelt keys answered with the closest one, bounds refused with field and
unit, cross-field rules, and a reference row for every key the shipped configs use."""
import pytest
from declared_models import (assert_every_shipped_key_has_a_reference_row,
                             assert_model_keys_are_the_declared_fields, changed, loaded,
                             parent, refused)

from rotor_avc.model_config import foot_mount_3d, rigid_rotor

MODULES = {"foot_mount_3d": foot_mount_3d, "rigid_rotor": rigid_rotor}


@pytest.mark.parametrize("config,path,wrong,right", [
    ("foot_mount_case3", "machine.foot_axial_arm_m", "foot_axial_arms_m", "foot_axial_arm_m"),
    ("foot_mount_case3", "elements.actuator.stiffness_n_per_m", "stifness_n_per_m",
     "stiffness_n_per_m"),
    ("foot_mount_case3", "elements.stiff_element", "stiff_elemnt", "stiff_element"),
    ("foot_mount_case1", "foundation.tan_delta", "tan_delt", "tan_delta"),
    ("balancer_rigid_rotor", "rotor.length_m", "lenght_m", "length_m"),
    ("balancer_rigid_rotor", "bearings.damping_n_s_per_m", "damping_ns_per_m",
     "damping_n_s_per_m"),
])
def test_a_misspelt_nested_key_is_answered_with_the_closest_one(config, path, wrong, right):
    data = loaded(config)
    sub, key = parent(data, path)
    sub[wrong] = sub.pop(key)
    where = path.rpartition(".")[0] + "." + wrong
    msg = refused(data)
    assert f"{where}: unknown key (did you mean '{right}'?)" in msg, msg


@pytest.mark.parametrize("config,path,value,words", [
    ("foot_mount_case3", "machine.rotor_mass_kg", -1900.0, "must be > 0 (got -1900.0 kg)"),
    ("foot_mount_case3", "machine.stator_inertia_kg_m2.x", 0.0, "must be > 0 (got 0.0 kg m^2)"),
    ("foot_mount_case3", "machine.bearing_axial_position_m.N", -1.0,
     "must be >= 0 (got -1.0 m)"),
    ("foot_mount_case3", "elements.actuator.stiffness_n_per_m.z", 0.0,
     "must be > 0 (got 0.0 N/m)"),
    ("foot_mount_case3", "elements.stiff_element.stator_mass_kg", -5.0,
     "must be >= 0 (got -5.0 kg)"),
    ("foot_mount_case1", "foundation.tan_delta", 0.2, "loss factor 0.2 is outside the model's "
     "range (eq. 44 needs tan(delta) < 0.2)"),
    ("foot_mount_case3", "elements.actuator.tan_delta", 4.0, "loss factor 4.0 is outside the "
     "model's range (eq. 44 needs tan(delta) < 0.2) -- fix: give the loss factor tan(delta), "
     "not a percentage"),
    ("balancer_rigid_rotor", "rotor.density_kg_m3", 0.0, "must be > 0 (got 0.0 kg/m^3)"),
    ("balancer_rigid_rotor", "bearings.damping_n_s_per_m", -1.0, "must be >= 0 (got -1.0 N s/m)"),
    ("balancer_rigid_rotor", "rotor.gyroscopic", "yes", "must be true or false (got 'yes')"),
])
def test_a_value_out_of_bounds_is_refused_naming_field_and_unit(config, path, value, words):
    msg = refused(changed(config, path, value))
    assert f"bad.yaml: {path}: {words}" in msg, msg


def test_the_mounting_rules_name_the_field_and_the_fix():
    msg = refused(changed("foot_mount_case3", "mounting", "direct"))
    assert "feet: mounting: direct ties every foot rigidly" in msg
    assert "set every foot to `none` or use `mounting: elements`" in msg
    data = loaded("foot_mount_case3")
    del data["feet"]
    assert "feet: missing" in refused(data)
    data = changed("foot_mount_case2_4act", "elements", {})
    assert "elements.actuator: missing -- fix: add `actuator:` to elements" in refused(data)


def test_model_keys_are_the_declared_fields():
    assert_model_keys_are_the_declared_fields(MODULES.values())


@pytest.mark.parametrize("model", sorted(MODULES))
def test_every_key_of_the_shipped_configs_has_a_reference_row(model):
    assert_every_shipped_key_has_a_reference_row(MODULES[model], model)
