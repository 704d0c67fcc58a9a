"""One-plane balancing on the Werner 2021 machine: the point-mass -> (static, moment) mapping against
the model's own kinematics, the per-speed optimal corrections (least squares never worse than no
or single-mode balancing), the influence-coefficient RLS with its holds, and a quasi-steady run-up
through the resonances with the balancer block."""
import dataclasses
import math

import numpy as np
import pytest

from rotor_avc.balancing.machine_rls import MachineSample
from rotor_avc.balancing.plane import MachinePlane, point_mass_unbalance
from rotor_avc.balancing.plane_correction import optimal_corrections, residual_response
from rotor_avc.balancing.quasi_steady import resonance_comparison, simulate_machine_runup
from rotor_avc.balancing.scenario import machine_setup
from rotor_avc.config import load_config
from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.machine import Machine, build_controllers, build_plant, load_machine


@pytest.fixture(scope="module")
def setup():
    return machine_setup(load_machine("balancer_foot_mount"))


def test_point_mass_maps_to_the_models_kinematics(setup):
    """P_e u_e + P_alpha u_alpha of a point mass equals the virtual work of its rotating force on
    the axis point's rows (the model's bearing-housing rows at +l_D)."""
    plant = setup.machine.plant
    a = 1.0                                                   # bearing D at +1.0 m
    r_z, r_y = plant.output("bearing_D_vz").row, plant.output("bearing_D_vy").row
    for angle in (0.0, 1.0, 2.5):
        amp = point_mass_unbalance(0.2, 0.3, angle, a)
        excitation = sum(plant.excitation(k).p2 * amp[k] for k in ("static", "moment"))
        direct = (r_z * 1.0 + r_y * -1j) * 0.2 * 0.3 * np.exp(1j * angle)   # F_z + j.. phasors
        np.testing.assert_allclose(excitation, direct, atol=1e-15)


def test_opposite_masses_give_pure_moment_unbalance():
    a, m, e, phi = 0.7, 0.1, 0.25, 0.4
    p = point_mass_unbalance(m, e, phi, a)
    q = point_mass_unbalance(m, e, phi + math.pi, -a)
    assert abs(p["static"] + q["static"]) < 1e-15
    assert p["moment"] + q["moment"] == pytest.approx(2j * a * m * e * np.exp(1j * phi))


def test_plane_outside_rotor_is_refused():
    with pytest.raises(ModelError, match="outside the rotor"):
        MachinePlane(1.2, -1.0, 1.0)
    cfg = load_config("balancer_foot_mount")
    cfg.data["balancer"] = dict(cfg.data["balancer"], plane_axial_position_m=-1.5)
    plant = build_plant(cfg)
    with pytest.raises(ConfigError, match="plane_axial_position_m.*outside the rotor"):
        machine_setup(Machine(cfg, plant, build_controllers(cfg, plant)))


def test_least_squares_is_never_worse(setup):
    G = setup.objective.base
    u = np.array(setup.runup.unbalance)
    norms = {}
    for strategy in ("none", "static", "moment", "bang_bang", "least_squares"):
        c, _ = optimal_corrections(G, u, setup.plane, strategy)
        norms[strategy] = np.linalg.norm(residual_response(G, u, setup.plane, c), axis=1)
    tol = 1e-12 * norms["none"].max()
    for other in ("none", "static", "moment", "bang_bang"):
        assert np.all(norms["least_squares"] <= norms[other] + tol)
    assert np.all(norms["bang_bang"] <= np.minimum(norms["static"], norms["moment"]) + tol)
    # a correction cancelling both unbalance types exactly exists only in their common plane
    assert norms["least_squares"].max() > 1e-6 * norms["none"].max()


def test_tangential_term_of_the_influence_coefficients(setup):
    """The excitations are pure p2 (unbalance): A(Omega, Omega') = A(Omega, 0)(1 - j Omega'/Omega^2)."""
    w, acc = 2 * np.pi * 12.3, 7.0
    np.testing.assert_allclose(setup.signals.at(w, acc), setup.signals.at(w) * (1 - 1j * acc / w**2),
                               rtol=1e-9)


def test_estimator_holds_at_zero_speed_and_on_nan(setup):
    est = setup.block().estimator
    n = len(setup.signals.channels)
    assert not est.update(MachineSample(0.0, 0.0, 0.0, 0.0, np.zeros(n)))
    assert not est.update(MachineSample(1.0, 1.0, 50.0, 1.0, np.full(n, np.nan)))
    assert est.n_held == 2 and np.all(est.filter.theta == 0)
    with pytest.raises(ModelError, match="expects 3 signals"):
        est.update(MachineSample(1.0, 1.0, 50.0, 1.0, np.zeros(n + 1)))


def test_unknown_signal_name_is_a_clear_error():
    cfg = load_config("balancer_foot_mount")
    cfg.data["balancer"] = dict(cfg.data["balancer"], signals=["NR"])
    plant = build_plant(cfg)
    with pytest.raises(ConfigError, match="unknown signal 'NR'"):
        machine_setup(Machine(cfg, plant, build_controllers(cfg, plant)))


def test_runup_lowers_every_resonance_peak(setup, full):
    """Quasi-steady run-up from rest through the resonances (to 30 Hz, --full: 120 Hz, above the
    highest machine resonance at 104.7 Hz) with the least-squares law: the estimate converges
    before the first resonance and the peak bearing-housing amplitude is lower at every
    resonance passed."""
    runup = setup.runup if full else dataclasses.replace(setup.runup, stop_rad_s=2 * np.pi * 30)
    rec = simulate_machine_runup(runup, setup.signals, setup.objective, setup.plane,
                                 setup.block("least_squares"), setup.actuator())
    u = np.array(runup.unbalance)
    k = np.searchsorted(rec.t, 3.5)                            # 7 Hz, before the first resonance
    assert np.all(np.abs(rec.estimate[k] - u) < 0.05 * np.abs(u))
    assert np.all(np.abs(rec.estimate[-1] - u) < 3 * rec.std[-1] + 1e-4 * np.abs(u))
    none = np.abs(rec.response_none).max(axis=1)
    table = resonance_comparison(rec.speed, none, {"ls": np.abs(rec.response).max(axis=1)})
    expected = [7.5, 9.4, 17.2, 19.8, 24.9] + ([104.8] if full else [])
    assert [r["speed_hz"] for r in table] == pytest.approx(expected, abs=0.15)
    assert all(r["ls_reduction_db"] > 6.0 for r in table)


def test_time_domain_runup_lowers_every_resonance_peak(setup, full):
    """The same balancer in the time domain (rotor_avc.sim stepper, transients included): run-up
    from rest to 30 Hz; the peak bearing-housing velocity near each resonance passed (7.5, 9.4,
    17.2, 19.8, 24.9 Hz) is lower than without balancing. ~1 min: --full only (the quasi-steady
    run-up above is its short form)."""
    from rotor_avc.balancing.time_domain_runup import simulate_machine_time
    if not full:
        pytest.skip("time-domain run-up runs with --full")
    stop_hz = 30.0
    st = dataclasses.replace(setup, runup=dataclasses.replace(setup.runup,
                                                              stop_rad_s=2 * np.pi * stop_hz))
    ref = simulate_machine_time(st)
    bal = simulate_machine_time(st, st.block("least_squares"))
    res_hz = [f for f in (7.52, 9.39, 17.18, 19.76, 24.84) if f < stop_hz - 1]
    table = resonance_comparison(ref.speed, np.abs(ref.outputs).max(axis=1),
                                 {"ls": np.abs(bal.outputs).max(axis=1)},
                                 resonances_rad_s=2 * np.pi * np.array(res_hz))
    assert len(table) == len(res_hz)
    assert all(r["ls_reduction_db"] > 3.0 for r in table)
    assert np.all(np.isfinite(bal.estimate))
