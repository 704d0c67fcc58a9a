"""Werner 2017 model (roller-bearing rotor, rigid stator on a soft foundation): matrices against the
digest's equation-by-equation table (3.3), model properties (mirror symmetry, identifiable
stator ratios, rigid-foundation reduction), standstill frequencies and feed-through against the
digest's reproduced values, and config validation."""
import copy

import numpy as np
import pytest

from rotor_avc.closed_loop.loop import ClosedLoop
from rotor_avc.analysis.stability_threshold import StateMatrices
from rotor_avc.config import Section, load_config
from rotor_avc.errors import ConfigError
from rotor_avc.machine import build_controllers, build_plant
from rotor_avc.model_config.roller_bearing_rotor import read_params
from rotor_avc.models.roller_bearing_rotor import COORDS, eq14_whirl_rad_s, matrices

CONFIG = "roller_bearing_stability"


def config(**overrides) -> Section:
    """The shipped config with ``section__key`` overrides (dict values replace whole entries)."""
    cfg = load_config(CONFIG)
    data = copy.deepcopy(cfg.data)
    for key, value in overrides.items():
        node = data
        *parents, leaf = key.split("__")
        for p in parents:
            node = node[p]
        node[leaf] = value
    return Section(data, "", cfg.source)


def table_matrices(p):
    """C, D_eta (loss-factor parts, d = . / w_F) and N_eta written out entry by entry from the
    digest's tables of eqs. (9)-(10) (section 3.3) -- independent of the spring assembly."""
    i = {c: k for k, c in enumerate(COORDS)}
    C = np.zeros((9, 9))
    D = np.zeros((9, 9))
    N = np.zeros((9, 9))
    b, h = p.b, p.h

    def put(X, r, c, v):
        X[i[r], i[c]] = v

    for X, k in ((C, 1.0), (D, None)):
        d = (lambda c, tan: c * tan) if k is None else (lambda c, tan: c)
        fz, fy = d(p.c_fz, p.tan_f), d(p.c_fy, p.tan_f)
        bz, by = d(p.c_bz, p.tan_b), d(p.c_by, p.tan_b)
        cs = d(p.c, p.tan_i)
        rz, ry = (p.c_rz, p.c_ry) if k is not None else (0.0, 0.0)
        put(X, "z_s", "z_s", 2 * (fz + bz)); put(X, "z_s", "z_b", -2 * bz)
        put(X, "z_w", "z_w", cs); put(X, "z_w", "z_v", -cs)
        put(X, "y_s", "y_s", 2 * (fy + by)); put(X, "y_s", "phi_s", -2 * fy * h)
        put(X, "y_s", "y_b", -2 * by)
        put(X, "y_w", "y_w", cs); put(X, "y_w", "y_v", -cs)
        put(X, "phi_s", "y_s", -2 * fy * h); put(X, "phi_s", "phi_s", 2 * (fz * b**2 + fy * h**2))
        put(X, "z_v", "z_w", -cs); put(X, "z_v", "z_v", cs + 2 * rz); put(X, "z_v", "z_b", -2 * rz)
        put(X, "z_b", "z_s", -2 * bz); put(X, "z_b", "z_v", -2 * rz); put(X, "z_b", "z_b", 2 * (rz + bz))
        put(X, "y_v", "y_w", -cs); put(X, "y_v", "y_v", cs + 2 * ry); put(X, "y_v", "y_b", -2 * ry)
        put(X, "y_b", "y_s", -2 * by); put(X, "y_b", "y_v", -2 * ry); put(X, "y_b", "y_b", 2 * (ry + by))
    k = p.c * p.tan_i                                # k_Omega = d_i Omega = k * Omega / w_F
    for r, c, sign in (("z_w", "y_w", 1), ("z_w", "y_v", -1), ("y_w", "z_w", -1), ("y_w", "z_v", 1),
                       ("z_v", "y_w", -1), ("z_v", "y_v", 1), ("y_v", "z_w", 1), ("y_v", "z_v", -1)):
        put(N, r, c, sign * k)
    return C, D, N


@pytest.mark.parametrize("overrides", [
    {},
    {"bearings__stiffness_n_per_m": {"z": 2.5e8, "y": 1.2e8}, "stator__cog_height_m": 0.6},
    {"foundation__stiffness_n_per_m": {"z": 3e7, "y": 9e8}, "housings__tan_delta": 0.07,
     "rotor__tan_delta": 0.01, "housings__stiffness_n_per_m": {"z": 4e8, "y": 9e8}},
])
def test_matrices_match_the_written_out_equations(overrides):
    p = read_params(config(**overrides))
    M, C, D_eta, N_eta = matrices(p)
    C_t, D_t, N_t = table_matrices(p)
    assert np.allclose(C, C_t, rtol=0, atol=1e-9 * np.abs(C_t).max())
    assert np.allclose(D_eta, D_t, rtol=0, atol=1e-9 * np.abs(D_t).max())
    assert np.allclose(N_eta, N_t, rtol=0, atol=1e-9 * np.abs(N_t).max())
    assert np.allclose(N_eta, -N_eta.T)                 # the circulatory part is skew (Sec. 3)
    assert np.allclose(np.diag(M), [p.m_s, p.m_w, p.m_s, p.m_w, p.theta_sx,
                                    2 * p.m_v, 2 * p.m_b, 2 * p.m_v, 2 * p.m_b])


def test_plant_carries_the_loss_factor_and_circulatory_terms():
    plant = build_plant(config())
    w_F, speed = 394.0, 2700.0
    _, C, D_eta, N_eta = matrices(read_params(config()))
    assert np.allclose(plant.damping(speed, w_F), D_eta / w_F)
    assert np.allclose(plant.stiffness_at(speed, w_F), C + speed / w_F * N_eta)
    # the rotor's force law in complex form (digest 2): with u = z + j y, the internal damping
    # force on the rotor mass is d_i (u_rel' - j Omega u_rel); it vanishes for synchronous
    # forward whirl u_rel = e^{j Omega t}, i.e. q_rel = Re/Im of it with s = j Omega
    iz, iy = plant.coords.index("z_w"), plant.coords.index("y_w")
    q = np.zeros(plant.n, complex)
    q[iz], q[iy] = 1.0, -1j                     # z = cos, y = sin  <=>  phasors 1, -j
    s = 1j * speed
    f_int = (s * plant.damping(speed, w_F) + plant.stiffness_at(speed, w_F) - plant.stiffness) @ q
    assert abs(f_int[iz]) < 1e-9 * abs(D_eta[iz, iz] / w_F * speed)


def test_undamped_frequencies_at_standstill_match_the_digest():
    """Digest 7.1 (reproduced by ref003): soft 142.8, 230.6, 374.1, 412.7, 465.3, 5522.4 (x2),
    8491.2 (x2) rad/s; rigid 344.8 (x2), 5498 (x2), 8487.5 (x2) rad/s."""
    for overrides, expected in (
            ({}, [142.8, 230.6, 374.1, 412.7, 465.3, 5522.4, 5522.4, 8491.2, 8491.2]),
            ({"foundation__kind": "rigid"}, [344.8, 344.8, 5498, 5498, 8487.5, 8487.5])):
        plant = build_plant(config(**overrides))
        w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(plant.mass, plant.stiffness)).real))
        assert np.allclose(w, expected, rtol=5e-4)


def test_rigid_foundation_deletes_the_stator():
    soft, rigid = build_plant(config()), build_plant(config(foundation__kind="rigid"))
    keep = [soft.coords.index(c) for c in rigid.coords]
    assert rigid.coords == ("z_w", "y_w", "z_v", "z_b", "y_v", "y_b")
    ix = np.ix_(keep, keep)
    for name in ("mass", "stiffness", "loss_damping", "circulatory"):
        assert np.array_equal(getattr(rigid, name), getattr(soft, name)[ix])
    assert rigid.actuators == () and {a.id for a in soft.actuators} == {"L", "R"}
    # housings grounded through 2 c_bz, 2 d_bz (digest 3.3)
    p = read_params(config())
    assert rigid.stiffness[3, 3] == pytest.approx(2 * (p.c_rz + p.c_bz))


def test_eigenvalues_do_not_depend_on_the_direction_of_rotation():
    """Mirror y -> -y, phi -> -phi maps the model onto itself with Omega -> -Omega (digest 2)."""
    loop = ClosedLoop(build_plant(config()), {})
    A = StateMatrices(loop, 394.0)
    for speed in (1000.0, 2736.0, 5000.0):
        ev_p = np.sort_complex(np.linalg.eigvals(A(speed)[0]))
        ev_n = np.sort_complex(np.linalg.eigvals(A(-speed)[0]))
        assert np.allclose(ev_p, ev_n, rtol=1e-9, atol=1e-9)


def test_only_the_stator_ratios_matter():
    """Eigenvalues depend on Theta/h^2 and b/h only (digest 8.1 step 3)."""
    def eig(h, theta, b):
        cfg = config(stator__cog_height_m=h, stator__roll_inertia_kg_m2=theta,
                     stator__foot_half_distance_m=b)
        A = StateMatrices(ClosedLoop(build_plant(cfg)), 394.0)
        return np.sort_complex(np.linalg.eigvals(A(2736.0)[0]))
    k = 1.7
    assert np.allclose(eig(0.9, 2120.0, 0.85), eig(0.9 * k, 2120.0 * k**2, 0.85 * k), rtol=1e-9)
    assert not np.allclose(eig(0.9, 2120.0, 0.85), eig(1.2, 2120.0, 0.85), rtol=1e-6)


def test_foot_force_feed_through_matches_the_digest():
    """Digest 9: foot force -> foot acceleration 5.97e-4 (own foot), -8.44e-5 (other foot) and
    3.61e-4 1/kg (horizontal foot acceleration)."""
    plant = build_plant(config())
    Minv = np.linalg.inv(plant.mass)
    L, R = plant.actuator("L"), plant.actuator("R")
    ay = plant.output("foot_ay").row
    assert L.sensor_row @ Minv @ L.force_vector == pytest.approx(5.97e-4, rel=2e-3)
    assert R.sensor_row @ Minv @ L.force_vector == pytest.approx(-8.44e-5, rel=2e-3)
    assert abs(ay @ Minv @ L.force_vector) == pytest.approx(3.61e-4, rel=2e-3)


def test_eq14_start_value():
    """Digest 3.5: c_total = 1.1076e8 N/m, omega_stab,0 = 345.11 rad/s."""
    assert eq14_whirl_rad_s(read_params(config())) == pytest.approx(345.11, abs=0.01)


def test_unbalance_turns_from_z_towards_y():
    exc = build_plant(config()).excitation("unbalance")
    F = exc.phasor(100.0)
    i, j = COORDS.index("z_w"), COORDS.index("y_w")
    # f_z = m e W^2 cos(theta), f_y = m e W^2 sin(theta): at theta = pi/2 the force points to +y
    theta = np.pi / 2
    assert np.real(F[i] * np.exp(1j * theta)) == pytest.approx(0.0, abs=1e-9)
    assert np.real(F[j] * np.exp(1j * theta)) == pytest.approx(100.0**2)


@pytest.mark.parametrize("overrides, field", [
    ({"bearings__stiffness_n_per_m": {"z": -2e8, "y": 2e8}}, "bearings.stiffness_n_per_m.z"),
    ({"housings__tan_delta": 4.0}, "housings.tan_delta"),
    ({"rotor__mass": 930.0}, "rotor.mass"),
    ({"foundation__kind": "concrete"}, "foundation.kind"),
    ({"stator__mass_kg": "3.9e3 kg"}, "stator.mass_kg"),
    ({"rotor__journal_mass_kg": 0.0}, "rotor.journal_mass_kg"),
])
def test_bad_config_names_the_field(overrides, field):
    with pytest.raises(ConfigError) as err:
        build_plant(config(**overrides))
    assert err.value.field == field and err.value.fix


def test_controllers_on_a_rigid_foundation_are_refused():
    cfg = config(foundation__kind="rigid",
                 controllers={"L": {"type": "P", "feedback": "velocity", "kp": 1e5}})
    with pytest.raises(ConfigError, match="controllers.L"):
        build_controllers(cfg, build_plant(cfg))
