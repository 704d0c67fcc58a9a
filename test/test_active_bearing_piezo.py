"""Piezo stack limits (stroke, blocked force, voltage, bandwidth) and what they leave of the IL:
the speed above which the quantified force saturates and the IL that remains."""
import numpy as np
import pytest

from rotor_avc.analysis.active_bearing_ff import (il_zero_crossing, saturated_forces,
                                                  saturation_onset, solve_feedforward)
from rotor_avc.config import load_config
from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.machine import load_machine
from rotor_avc.model_config.active_bearing import piezo_from_config
from rotor_avc.models.piezo import PiezoStack
from test_active_bearing_model import variant

TWO_PI = 2 * np.pi
CASES = TWO_PI * np.array([400, 6000, 18000, 30000]) / 60
U = 5e-6
GRID = TWO_PI * np.linspace(1.0, 1000.0, 300)


@pytest.fixture(scope="module")
def plant():
    return load_machine("active_bearing").plant


def test_limits_follow_the_stack_data():
    """k_p = F_b / delta_0; a sinusoid about the mid voltage uses half of a unipolar range; the
    first-order lag costs 3 dB at the bandwidth; the lag-compensated voltage reproduces the force."""
    pz = PiezoStack(free_stroke_m=6e-6, blocked_force_n=300.0, bandwidth_hz=800.0,
                    max_voltage_v=120.0, min_voltage_v=-30.0)
    assert pz.stiffness_n_per_m == pytest.approx(5e7)
    w_b = TWO_PI * 800.0
    assert pz.force_limit_n(0.0) == pytest.approx(300.0 * 150.0 / 240.0)
    assert pz.force_limit_n(w_b) == pytest.approx(pz.force_limit_n(0.0) / np.sqrt(2))
    speeds = TWO_PI * np.array([50.0, 800.0, 2400.0])
    F = np.array([[10.0 * np.exp(0.3j)], [20.0], [5j]])
    V = pz.voltage_phasor_v(F, speeds)
    delivered = pz.blocked_force_n / pz.max_voltage_v * pz.lag(speeds)[:, None] * V
    np.testing.assert_allclose(delivered, F, rtol=1e-12)
    assert np.angle(V[1, 0] / F[1, 0]) == pytest.approx(np.pi / 4)         # phase lead at w_b
    # a force at the limit needs exactly the largest sinusoidal voltage amplitude
    at_limit = pz.force_limit_n(speeds)[:, None] * np.exp(0.4j)
    np.testing.assert_allclose(np.abs(pz.voltage_phasor_v(at_limit, speeds)), 75.0, rtol=1e-12)
    assert pz.free_stroke_amplitude_m(pz.force_limit_n(0.0)) == pytest.approx(6e-6 * 150 / 240)


def test_saturation_onset_is_where_the_required_force_meets_the_limit(plant):
    pz = piezo_from_config(load_config("active_bearing"))
    onset = saturation_onset(plant, "paper", pz, GRID, U)
    assert onset is not None
    at = solve_feedforward(plant, [0.97 * onset, onset, 1.03 * onset], "paper", U)
    need = np.abs(at.forces).max(axis=1)
    limit = pz.force_limit_n(at.speed_rad_s)
    assert need[1] == pytest.approx(limit[1], rel=1e-6)
    assert need[0] < limit[0] and need[2] > limit[2]
    alpha, forces = saturated_forces(at, pz)
    assert alpha[0] == 1.0 and alpha[2] < 1.0
    assert np.abs(forces[2]).max() == pytest.approx(limit[2], rel=1e-12)
    # the four case speeds are below it: nothing changes there
    cases = solve_feedforward(plant, CASES, "paper", U)
    a_c, f_c = saturated_forces(cases, pz)
    assert np.all(a_c == 1.0) and onset > CASES[-1]
    np.testing.assert_array_equal(cases.insertion_loss_db(f_c), cases.insertion_loss_db())


def test_saturated_force_leaves_one_minus_alpha_of_the_housing_motion(plant):
    """The saturated forces are the full cancelling set scaled by alpha, so the exact method
    leaves (1 - alpha) of every housing's uncontrolled motion: IL = -20 log10(1 - alpha)."""
    pz = PiezoStack(free_stroke_m=1e-6, blocked_force_n=20.0, bandwidth_hz=1000.0,
                    max_voltage_v=120.0)
    res = solve_feedforward(plant, TWO_PI * np.array([300.0, 400.0, 500.0, 600.0]), "exact", U)
    alpha, forces = saturated_forces(res, pz)
    assert alpha[0] == 1.0 and np.all(alpha[1:] < 1.0)
    housings = res.outputs("housing_")
    il = res.insertion_loss_db(forces)[:, housings]
    np.testing.assert_allclose(il[1:], -20 * np.log10(1 - alpha[1:, None]) * np.ones((1, 4)),
                               rtol=1e-7)


def test_smaller_stroke_or_larger_unbalance_saturates_earlier(plant):
    """The force needed grows with the unbalance and (above the support resonance) with Omega^2:
    halving the stroke or doubling m_o e moves the onset down, and both give the same onset."""
    pz = piezo_from_config(load_config("active_bearing"))
    half = PiezoStack(pz.free_stroke_m / 2, pz.blocked_force_n / 2, pz.bandwidth_hz,
                      pz.max_voltage_v, pz.min_voltage_v)
    base = saturation_onset(plant, "paper", pz, GRID, U)
    smaller = saturation_onset(plant, "paper", half, GRID, U)
    larger_u = saturation_onset(plant, "paper", pz, GRID, 2 * U)
    assert smaller < base and smaller == pytest.approx(larger_u, rel=1e-6)


def test_stroke_limit_reported_at_the_case_speeds():
    """A 1 um / 20 N stack saturates at 30000 rpm (needs 24.6 N, gets 10 N |G|): the report's
    case: IL left at 30000 rpm well below the unlimited 10.5 dB; lower speeds untouched."""
    plant = load_machine("active_bearing").plant
    pz = PiezoStack(free_stroke_m=1e-6, blocked_force_n=20.0, bandwidth_hz=1000.0,
                    max_voltage_v=120.0)
    res = solve_feedforward(plant, CASES, "paper", U)
    alpha, forces = saturated_forces(res, pz)
    np.testing.assert_allclose(alpha[:3], 1.0)
    assert alpha[3] == pytest.approx(10.0 / np.sqrt(1 + 0.25) / np.abs(res.forces[3]).max(), rel=1e-9)
    shaft = res.outputs("shaft_")
    il_full, il_sat = res.insertion_loss_db()[:, shaft], res.insertion_loss_db(forces)[:, shaft]
    np.testing.assert_array_equal(il_sat[:3], il_full[:3])
    # after = (1 - alpha) before + alpha after_full: IL left >= -20 log10(1 - alpha + alpha r)
    r = 10 ** (-il_full[3] / 20)
    assert np.all(il_sat[3] >= -20 * np.log10(1 - alpha[3] + alpha[3] * r) - 1e-9)
    assert np.all(il_sat[3] < il_full[3])
    onset = saturation_onset(plant, "paper", pz, GRID, U)
    assert CASES[2] < onset < CASES[3]


def test_saturated_il_crossing_differs_from_the_linear_one(plant):
    """Once saturated the IL depends on the unbalance (no longer linear in it)."""
    pz = piezo_from_config(load_config("active_bearing"))
    lin = il_zero_crossing(plant, "paper", GRID)
    sat = [il_zero_crossing(plant, "paper", GRID, piezo=pz, unbalance_kg_m=u) for u in (U, 3 * U)]
    assert lin is not None and sat[0] is not None
    assert sat[0] != pytest.approx(lin, rel=1e-3) and sat[0] != pytest.approx(sat[1], rel=1e-3)


@pytest.mark.parametrize("change, field", [
    ({"min_voltage_v": 130.0}, "piezo.min_voltage_v"),
    ({"free_stroke_m": -1e-6}, "piezo.free_stroke_m"),
    ({"stroke_um": 5.0}, "piezo.stroke_um"),
])
def test_piezo_config_errors_name_the_field(change, field):
    with pytest.raises(ConfigError) as err:
        piezo_from_config(variant(piezo=change))
    assert err.value.field == field


def test_piezo_refuses_nonsense_directly():
    with pytest.raises(ModelError, match="bandwidth_hz"):
        PiezoStack(5e-6, 100.0, 0.0, 120.0)
    with pytest.raises(ModelError, match="min_voltage_v"):
        PiezoStack(5e-6, 100.0, 1000.0, 120.0, 120.0)
