"""Sci. Rep. 2023 model: matrices against eqs. (1)-(5) written out, the digest's derived and reproduced
values (sections 5, 11), the sensor transform (eqs. 11-15) and the equation corrections A2, A3,
A4, A7, A8, A12 each checked by the physics the printed form breaks (digest section 9)."""
import copy
import dataclasses

import numpy as np
import pytest

from rotor_avc.config import Section, load_config
from rotor_avc.errors import ConfigError
from rotor_avc.machine import build_plant, load_machine
from rotor_avc.model_config import active_bearing as ab_config
from rotor_avc.models import active_bearing as ab

TWO_PI = 2 * np.pi
BASE = load_config("active_bearing")


def variant(planes=None, per_plane=None, **top):
    """The shipped config with per-plane values changed everywhere (``planes``), per
    ``(bearing, plane)`` (``per_plane``) or top-level sections merged (``top``), as a Section."""
    data = copy.deepcopy(BASE.data)
    for i in ab.BEARINGS:
        for d in ab.PLANES:        # fresh dicts: the YAML aliases one plane mapping four times
            data["active_bearings"][i][d] = dict(data["active_bearings"][i][d], **(planes or {}),
                                                 **(per_plane or {}).get((i, d), {}))
    for key, value in top.items():
        data[key] = dict(data.get(key, {}), **value)
    return Section(data, "", BASE.source)


def asymmetric():
    """A parameter set where every bearing/plane differs and l1 != l2, k_r != 0, c_b != 0."""
    per_plane = {}
    for n, (i, d) in enumerate([(i, d) for i in ab.BEARINGS for d in ab.PLANES]):
        per_plane[(i, d)] = {"actuator_mass_kg": 0.015 + 0.004 * n, "k_b_n_per_m": 8e6 + 2e6 * n,
                             "c_b_n_s_per_m": 5.0 * n, "k_ac_n_per_m": 1.5e7 + 3e6 * n,
                             "c_ac_n_s_per_m": 15.0 + 4 * n, "k_sp_n_per_m": 8e4 + 1e4 * n,
                             "c_sp_n_s_per_m": 2.0 * n, "k_pre_n_per_m": 2e5 + 5e4 * n,
                             "c_pre_n_s_per_m": 50.0 + 7 * n}
    cfg = variant(per_plane=per_plane,
                  rotor={"bearing_arm_m": {"1": 0.06, "2": 0.09}, "tilt_stiffness_n_m_per_rad": 40.0})
    cfg.data["active_bearings"]["2"]["housing_mass_kg"] = 0.31
    cfg.data["sensors"] = {"bearing1_side_m": [0.03, 0.07], "bearing2_side_m": [0.05, 0.1]}
    return cfg


def paper_plane_matrices(p, l1, l2, k_r, plane, printed=False):
    """K and C of eqs. (2)-(5) entry by entry (1-based in the comments) for one plane; ``p`` maps
    bearing -> plane parameters. ``printed``: row 5 with k_ac,1 as the paper prints it (A3)."""
    s = 1.0 if plane == "y" else -1.0             # eq. (4): every lever term sign-flipped
    out = []
    for k in ("k", "c"):
        b1, b2 = p["1"][f"{k}_b"], p["2"][f"{k}_b"]
        ac1, ac2 = p["1"][f"{k}_ac"], p["2"][f"{k}_ac"]
        A = np.zeros((6, 6))
        A[0, 0] = b1 + b2
        A[0, 1] = A[1, 0] = -b1
        A[0, 3] = A[3, 0] = -b2
        A[0, 5] = A[5, 0] = s * (b1 * l1 - b2 * l2)
        A[1, 1] = b1 + ac1 + p["1"][f"{k}_pre"]
        A[1, 2] = A[2, 1] = -ac1
        A[1, 5] = A[5, 1] = -s * b1 * l1
        A[2, 2] = ac1 + p["1"][f"{k}_sp"]
        A[3, 3] = b2 + ac2 + p["2"][f"{k}_pre"]
        A[3, 4] = A[4, 3] = -ac2
        A[3, 5] = A[5, 3] = s * b2 * l2
        A[4, 4] = (ac1 if printed else ac2) + p["2"][f"{k}_sp"]
        A[5, 5] = b1 * l1**2 + b2 * l2**2 + (k_r if k == "k" else 0.0)
        out.append(A)
    return out


def plane_params(cfg, plane):
    out = {}
    for i in ab.BEARINGS:
        sec = cfg.data["active_bearings"][i][plane]
        out[i] = {key.split("_n_")[0]: v for key, v in sec.items() if key != "actuator_mass_kg"}
    return out


def test_matrices_follow_eqs_1_to_5():
    cfg = asymmetric()
    plant = ab_config.build(cfg)
    r = cfg.data["rotor"]
    l1, l2 = r["bearing_arm_m"]["1"], r["bearing_arm_m"]["2"]
    for b, d in enumerate(ab.PLANES):
        K, C = paper_plane_matrices(plane_params(cfg, d), l1, l2, r["tilt_stiffness_n_m_per_rad"], d)
        blk = slice(6 * b, 6 * b + 6)
        np.testing.assert_allclose(plant.stiffness[blk, blk], K, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(plant.viscous_damping[blk, blk], C, rtol=1e-12, atol=1e-12)
        ab_ = cfg.data["active_bearings"]
        m_R = plant.mass[0, 0]
        expected_m = [m_R, ab_["1"]["housing_mass_kg"], ab_["1"][d]["actuator_mass_kg"],
                      ab_["2"]["housing_mass_kg"], ab_["2"][d]["actuator_mass_kg"], plant.mass[5, 5]]
        np.testing.assert_allclose(np.diag(plant.mass)[blk], expected_m)
    assert not np.any(plant.stiffness[:6, 6:]) and not np.any(plant.viscous_damping[:6, 6:])
    assert not np.any(plant.loss_damping)


def test_rotor_values_derived_from_the_stated_geometry():
    """Digest section 5: m_R, I_R, I_p of the 0.01 m x 0.2 m SM45C shaft."""
    plant = load_machine("active_bearing").plant
    assert plant.mass[0, 0] == pytest.approx(0.123308, rel=1e-5)
    assert plant.mass[5, 5] == pytest.approx(4.11796e-4, rel=1e-5)
    assert plant.gyroscopic[5, 11] == pytest.approx(1.54134e-6, rel=1e-5)


def _frequencies(plant, speed=0.0):
    n = plant.n
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -np.linalg.solve(plant.mass, plant.stiffness)
    A[n:, n:] = -np.linalg.solve(plant.mass, plant.damping(speed, 1.0))
    ev = np.linalg.eigvals(A)
    ev = ev[ev.imag > 0]
    ev = ev[np.argsort(ev.imag)]
    return ev.imag / TWO_PI, -ev.real / np.abs(ev)


def test_natural_frequencies_match_the_digest():
    """Digest 11: 174.0 (zeta .082), 182.3 (.086), 2244 (.0015), 2963 (.0006), 5250 (.017) Hz,
    each twice; the gyroscopic split at 30000 rpm is <= 1 Hz."""
    plant = load_machine("active_bearing").plant
    f, zeta = _frequencies(plant)
    np.testing.assert_allclose(f[::2], [174.0, 182.3, 2244.4, 2963.3, 5249.7, 5251.5], rtol=2e-3)
    np.testing.assert_allclose(f[::2], f[1::2], rtol=1e-9)
    half_digit = np.array([5e-4, 5e-4, 5e-5, 5e-5])               # the digest's rounding
    assert np.all(np.abs(zeta[:8:2] - [0.082, 0.086, 0.0015, 0.0006]) <= half_digit)
    f30, _ = _frequencies(plant, TWO_PI * 500)
    assert np.max(np.abs(f30 - f)) <= 1.0


def test_clamped_housings_leave_the_rotor_on_its_bearings():
    """Digest 11: with the housings held still, translation 2027 Hz and rocking 2806 Hz, equal to
    sqrt(2 k_b / m_R) and sqrt(2 k_b l^2 / I_R) (undamped: c_b = 0)."""
    plant = load_machine("active_bearing").plant
    keep = [ab.index(c) for c in ("eps_r_y", "theta_x")]
    K = plant.stiffness[np.ix_(keep, keep)]
    M = plant.mass[np.ix_(keep, keep)]
    f = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(M, K)).real)) / TWO_PI
    k_b, l = 1e7, 0.08
    np.testing.assert_allclose(f, [np.sqrt(2 * k_b / M[0, 0]) / TWO_PI,
                                   np.sqrt(2 * k_b * l**2 / M[1, 1]) / TWO_PI], rtol=1e-12)
    np.testing.assert_allclose(f, [2027, 2806], rtol=1e-3)


# -- A3: K(5,5) / C(5,5) -----------------------------------------------------------------------
def test_a3_an_undeformed_piezo_transmits_no_force():
    """Moving a housing and its actuator mass together leaves the piezo undeformed: the only
    force on the actuator mass is its backing spring's. The printed row 5 (k_ac,1 + k_sp) puts a
    piezo force (k_ac,1 - k_ac,2) delta there when the two stacks differ."""
    cfg = asymmetric()
    plant = ab_config.build(cfg)
    delta = 1e-6
    for i in ab.BEARINGS:
        for d in ab.PLANES:
            q = np.zeros(12)
            q[ab.index(f"eps_bh_{d}_{i}")] = q[ab.index(f"eps_ac_{d}_{i}")] = delta
            force = (plant.stiffness @ q)[ab.index(f"eps_ac_{d}_{i}")]
            k_sp = cfg.data["active_bearings"][i][d]["k_sp_n_per_m"]
            assert force == pytest.approx(k_sp * delta, rel=1e-12)
    r = cfg.data["rotor"]
    K_printed, _ = paper_plane_matrices(plane_params(cfg, "y"), r["bearing_arm_m"]["1"],
                                        r["bearing_arm_m"]["2"], 0.0, "y", printed=True)
    q = np.zeros(6)
    q[3] = q[4] = delta
    k_sp2 = cfg.data["active_bearings"]["2"]["y"]["k_sp_n_per_m"]
    assert abs((K_printed @ q)[4] - k_sp2 * delta) > 0.1 * k_sp2 * delta


# -- A2: the gyroscopic matrix ----------------------------------------------------------------
def test_a2_free_rotor_nutates_forward_at_ip_omega_over_it():
    """A torque-free axisymmetric rotor spinning at Omega nutates forward (whirling from +x to +y
    like the spin) at I_p Omega / I_t (Euler's equations)."""
    plant = load_machine("active_bearing").plant
    t = [ab.index("theta_x"), ab.index("theta_y")]
    M = plant.mass[np.ix_(t, t)]
    omega = TWO_PI * 500
    G = omega * plant.gyroscopic[np.ix_(t, t)]
    ev, vec = np.linalg.eig(-np.linalg.solve(M, G))      # theta'' = -M^-1 G theta' (no springs)
    k = np.argmax(ev.imag)
    I_p, I_t = plant.gyroscopic[t[0], t[1]], M[0, 0]
    assert ev[k].imag == pytest.approx(I_p * omega / I_t, rel=1e-12)
    th_x, th_y = vec[:, k]
    # shaft tip at z > 0: x = z theta_y, y = -z theta_x; forward: y phasor = -j x phasor
    assert (-th_x) / th_y == pytest.approx(-1j, abs=1e-12)


def _scaled(cfg, lam):
    """Change the mass unit (kg -> kg/lam): every mass-carrying value times lam."""
    data = copy.deepcopy(cfg.data)
    data["rotor"]["density_kg_m3"] *= lam
    data["rotor"]["tilt_stiffness_n_m_per_rad"] *= lam
    data["unbalance"]["mass_kg"] *= lam
    for i in ab.BEARINGS:
        data["active_bearings"][i]["housing_mass_kg"] *= lam
        for d in ab.PLANES:
            data["active_bearings"][i][d] = {k: v * lam for k, v in data["active_bearings"][i][d].items()}
    return Section(data, "", cfg.source)


def test_a2_the_model_is_dimensionally_consistent_the_literal_omega_i_is_not():
    """Results cannot depend on the unit of mass. The gyroscopic reading passes; the literal
    Omega*I block of eq. (10) (a coefficient in 1/s where N s/m belongs) fails."""
    from rotor_avc.analysis.active_bearing_ff import solve_feedforward
    cfg = asymmetric()
    speeds = TWO_PI * np.array([100.0, 300.0, 500.0])
    literal = np.zeros((12, 12))
    literal[:6, 6:], literal[6:, :6] = np.eye(6), -np.eye(6)
    results = {}
    for lam in (1.0, 1000.0):
        plant = ab_config.build(_scaled(cfg, lam))
        u = lam * 5e-6
        for name, p in (("gyro", plant), ("literal", dataclasses.replace(plant, gyroscopic=literal))):
            res = solve_feedforward(p, speeds, "exact", u)
            results[(name, lam)] = (_frequencies(p, speeds[-1])[0], res.before, res.after())
    for a, b in zip(results[("gyro", 1.0)], results[("gyro", 1000.0)]):
        np.testing.assert_allclose(a, b, rtol=1e-7, atol=1e-20)
    f1, f2 = results[("literal", 1.0)][0], results[("literal", 1000.0)][0]
    assert np.max(np.abs(f1 / f2 - 1)) > 0.1


def test_a2_literal_omega_i_destroys_the_reported_control():
    """The paper reports clear reduction at every sensor for all four cases; with the literal
    Omega*I the paper's own method loses it at the high speeds (digest A2: IL -> about 0 dB)."""
    from rotor_avc.analysis.active_bearing_ff import solve_feedforward
    plant = load_machine("active_bearing").plant
    literal = np.zeros((12, 12))
    literal[:6, 6:], literal[6:, :6] = np.eye(6), -np.eye(6)
    speeds = TWO_PI * np.array([400, 6000, 18000, 30000]) / 60
    for p, ok in ((plant, True), (dataclasses.replace(plant, gyroscopic=literal), False)):
        res = solve_feedforward(p, speeds, "paper")
        il = res.insertion_loss_db()[:, res.outputs("shaft_")]
        assert bool(np.all(il > 5.0)) is ok


# -- A12: the unbalance force ------------------------------------------------------------------
@pytest.mark.parametrize("accel", [0.0, 350.0])
def test_a12_unbalance_is_the_force_of_a_mass_on_a_circle(accel):
    """The mass m_o at radius e on the turning shaft (angle theta, x towards y) pushes on the
    rotor with -m_o * its acceleration; the excitation Re{(Omega^2 - j Omega') p2 u e^{j theta}}
    must equal it, and the paper's in-phase x/y pair (eqs. 16-17) does not."""
    plant = load_machine("active_bearing").plant
    exc = plant.excitation("unbalance")
    m_o, e, omega = 1e-3, 5e-3, 900.0
    theta = np.linspace(0, TWO_PI, 13)
    acc_x = e * (-accel * np.sin(theta) - omega**2 * np.cos(theta))
    acc_y = e * (accel * np.cos(theta) - omega**2 * np.sin(theta))
    phasor = exc.phasor(omega, accel)
    model = (phasor[None, :] * m_o * e * np.exp(1j * theta)[:, None]).real
    np.testing.assert_allclose(model[:, ab.index("eps_r_x")], -m_o * acc_x, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(model[:, ab.index("eps_r_y")], -m_o * acc_y, rtol=1e-12, atol=1e-15)
    assert np.count_nonzero(np.abs(phasor) > 0) == 2
    paper = (m_o * e * omega**2 * np.exp(1j * theta)).real          # f_x = f_y (eqs. 16-17)
    assert np.max(np.abs(paper + m_o * acc_y)) > 0.5 * m_o * e * omega**2


def test_a12_rotating_unbalance_gives_circular_orbits():
    """On x/y-symmetric supports the shaft whirls on a circle (y lags x by 90 deg, forward);
    the paper's in-phase force would give straight-line orbits (digest A12, Fig. 8)."""
    from rotor_avc.analysis.active_bearing_ff import solve_feedforward
    res = solve_feedforward(load_machine("active_bearing").plant, TWO_PI * np.array([100.0, 300.0]))
    names = res.output_names
    for k in res.outputs("shaft_", "x"):
        X, Y = res.before[:, k], res.before[:, names.index(names[k][:-1] + "y")]
        np.testing.assert_allclose(Y / X, -1j, atol=1e-3)


# -- A4: four actuators on the actuator masses -------------------------------------------------
def test_a4_each_actuator_pushes_its_actuator_mass_and_measures_its_housing():
    plant = load_machine("active_bearing").plant
    assert [a.id for a in plant.actuators] == list(ab.ACTUATOR_IDS)
    for a in plant.actuators:
        d, i = a.id
        assert a.axis == d
        np.testing.assert_array_equal(a.force_vector, ab.basis(f"eps_ac_{d}_{i}"))
        np.testing.assert_array_equal(a.sensor_row, ab.basis(f"eps_bh_{d}_{i}"))


def test_a4_one_actuator_per_plane_cannot_hold_both_housings():
    """Eqs. (8)-(9) print one actuator force per plane (slot 5): cancelling housing 2 with it
    leaves housing 1 moving; the four forces of the corrected vector null all four housings."""
    from rotor_avc.analysis.active_bearing_ff import solve_feedforward
    plant = load_machine("active_bearing").plant
    speeds = TWO_PI * np.array([100.0, 300.0])
    res = solve_feedforward(plant, speeds, "exact")
    housings = res.outputs("housing_")
    assert np.max(np.abs(res.after()[:, housings])) < 1e-9 * np.max(np.abs(res.before[:, housings]))
    only2 = [res.actuator_ids.index(a) for a in ("y2", "x2")]
    h2 = [res.output_names.index(n) for n in ("housing_2_y", "housing_2_x")]
    h1 = res.output_names.index("housing_1_y")
    forces = np.zeros_like(res.forces)
    for n in range(speeds.size):
        A = res.force_response[n][np.ix_(h2, only2)]
        forces[n, only2] = -np.linalg.solve(A, res.before[n, h2])
    after = res.after(forces)
    assert np.max(np.abs(after[:, h2])) < 1e-9 * np.max(np.abs(res.before[:, h2]))
    assert np.all(np.abs(after[:, h1]) > 0.3 * np.abs(res.before[:, h1]))


# -- A7, A8: the sensor transform ---------------------------------------------------------------
def test_a7_sensor_transform_puts_sensor_1_on_the_bearing_1_side_in_both_planes():
    l1s, l2s = 0.03, 0.07
    inv = np.linalg.inv(ab.sensor_transform(l1s, l2s))
    for b, d in enumerate(ab.PLANES):
        np.testing.assert_allclose(inv[6 * b], ab.shaft_row(-l1s, d), atol=1e-14)
        np.testing.assert_allclose(inv[6 * b + 1], ab.shaft_row(l2s, d), atol=1e-14)
    printed = ab.sensor_transform(l1s, l2s)
    L = l1s + l2s
    printed[5, :2] = printed[11, 6:8] = [-1 / L, 1 / L]            # eq. (11) literally
    inv_p = np.linalg.inv(printed)
    np.testing.assert_allclose(inv_p[0], ab.shaft_row(+l1s, "y"), atol=1e-14)   # wrong side
    np.testing.assert_allclose(inv_p[6], ab.shaft_row(-l1s, "x"), atol=1e-14)


def test_a8_transformed_dynamic_stiffness_needs_k_prime():
    """kappa' = -w^2 M Pi + j w (C + G) Pi + K Pi gives q' = Pi^-1 q: its sensor entries equal
    the plant's shaft outputs; the printed "+K" does not (not even statically)."""
    from rotor_avc.analysis.active_bearing_ff import compliance
    cfg = asymmetric()
    plant = ab_config.build(cfg)
    Pi = ab.sensor_transform(0.03, 0.05)
    names = [o.name for o in plant.outputs]
    rows = {n: plant.outputs[names.index(n)].row for n in ("shaft_L1_y", "shaft_R1_y", "shaft_L1_x")}
    F = plant.excitation("unbalance").p2 + 0.3 * ab.basis("eps_ac_y_2")
    for w in (1e-3, TWO_PI * 150, TWO_PI * 700):
        D = plant.damping(w, 1.0)
        H = np.linalg.inv(plant.stiffness - w**2 * plant.mass + 1j * w * D)
        q = H @ F
        q_good = np.linalg.solve((plant.stiffness - w**2 * plant.mass + 1j * w * D) @ Pi, F)
        q_bad = np.linalg.solve((-w**2 * plant.mass + 1j * w * D) @ Pi + plant.stiffness, F)
        np.testing.assert_allclose(compliance(plant, [w], sensor_transform=Pi)[0] @ F, q_good,
                                   rtol=1e-9, atol=1e-9 * np.abs(q_good).max())
        for n, k in (("shaft_L1_y", 0), ("shaft_R1_y", 1), ("shaft_L1_x", 6)):
            assert q_good[k] == pytest.approx(rows[n] @ q, rel=1e-9)
            assert abs(q_bad[k] - rows[n] @ q) > 1e-3 * abs(rows[n] @ q)


def test_outputs_are_the_housings_strokes_and_shaft_pairs():
    plant = load_machine("active_bearing").plant
    names = [o.name for o in plant.outputs]
    assert names[:8] == ["housing_1_y", "stroke_1_y", "housing_1_x", "stroke_1_x",
                         "housing_2_y", "stroke_2_y", "housing_2_x", "stroke_2_x"]
    assert names[8:10] == ["shaft_L1_y", "shaft_L1_x"] and len(names) == 8 + 20
    for n, z in (("shaft_L3_y", -0.06), ("shaft_R5_x", 0.10), ("shaft_R2_y", 0.04)):
        np.testing.assert_allclose(plant.output(n).row, ab.shaft_row(z, n[-1]), atol=1e-14)
    assert all(o.order == 0 and o.unit == "m" for o in plant.outputs)


# -- configuration errors ------------------------------------------------------------------------
@pytest.mark.parametrize("change, field", [
    ({"sensors": {"bearing1_side_m": [0.02, 0.12]}}, "sensors.bearing1_side_m"),
    ({"sensors": {"bearing2_side_m": [0.02]}}, "sensors.bearing2_side_m"),
    ({"rotor": {"bearing_arm_m": {"1": 0.08, "2": 0.15}}}, "rotor.bearing_arm_m.2"),
    ({"rotor": {"diameter": 0.01}}, "rotor.diameter"),
])
def test_config_errors_name_the_field(change, field):
    with pytest.raises(ConfigError) as err:
        build_plant(variant(**change))
    assert err.value.field == field and err.value.fix


@pytest.mark.parametrize("key, value", [("k_ac_n_per_m", 0.0), ("c_pre_n_s_per_m", -1.0),
                                        ("k_b", 1e7), ("k_b_n_per_m", "1e7")])
def test_plane_value_errors_name_the_field(key, value):
    cfg = variant(per_plane={("2", "x"): {key: value}})
    with pytest.raises(ConfigError) as err:
        build_plant(cfg)
    assert err.value.field == f"active_bearings.2.x.{key}"
