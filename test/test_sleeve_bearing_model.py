"""Werner 2019 model (rotor_avc.models.sleeve_bearing_motor): M, D, C against the paper's eqs. (11)-(13)
written out entry by entry (digest 3.1), excitations (eqs. 8-10), actuator vectors (eqs. 16-17),
the electromagnetic field model's limits, and config refusals."""
import math

import numpy as np
import pytest

from rotor_avc.config import Section, load_config
from rotor_avc.errors import ConfigError
from rotor_avc.machine import build_plant, load_machine
from rotor_avc.models.journal_bearing import JournalBearing, Oil, coefficient_table
from rotor_avc.models.sleeve_bearing_motor import COORDS, ElectromagneticField

P = dict(m_s=7040.0, th=1550.0, m_w=1900.0, m_v=10.0, m_b=80.0, c=6e8, h=0.56, b=0.53,
         c_by=4.8e8, c_bz=5.7e8, tb=0.04, ti=0.03, m_fL=30.0, m_fR=30.0, c_fz=1.5e8, c_fy=1.0e8,
         tf=0.04, m_as=10.0, m_aa=3.0, c_az=1.2e8, c_ay=3.0e8, ta=0.04)


def paper_matrices(p, oil_c, oil_d, c_md, d_m, d_i_omega, w_F):
    """M (eq. 11), D (eq. 12), C (eq. 13), entry by entry from the digest's tables (1-based);
    oil_c / oil_d: per-bearing 2x2 [[zz, zy], [yz, yy]]; loss factors at w_F (eq. 1)."""
    M, C, D = (np.zeros((14, 14)) for _ in range(3))
    b, h, m_aa = p["b"], p["h"], p["m_aa"]
    M[1, 1] = M[3, 3] = p["m_s"] + 2 * m_aa
    M[2, 2] = M[4, 4] = p["m_w"]
    M[3, 5] = M[5, 3] = -2 * m_aa * h
    M[5, 5] = p["th"] + 2 * m_aa * (b**2 + h**2)
    M[6, 6] = M[10, 10] = 2 * p["m_v"]
    M[7, 7] = M[11, 11] = 2 * p["m_b"]
    M[8, 8] = M[12, 12] = p["m_as"] + p["m_fL"]
    M[9, 9] = M[13, 13] = p["m_as"] + p["m_fR"]

    def fill(X, c, c_i, c_bz, c_by, c_az, c_ay, c_fz, c_fy, oil, em, circ):
        zz, zy, yz, yy = oil[0, 0], oil[0, 1], oil[1, 0], oil[1, 1]
        X[1, 1] = 2 * (c_az + c_bz) + em; X[1, 2] = -em; X[1, 7] = -2 * c_bz
        X[1, 8] = X[1, 9] = -c_az
        X[2, 1] = -em; X[2, 2] = c_i + em; X[2, 4] = circ; X[2, 6] = -c_i; X[2, 10] = -circ
        X[3, 3] = 2 * (c_ay + c_by) + em; X[3, 4] = -em; X[3, 5] = -2 * c_ay * h
        X[3, 11] = -2 * c_by; X[3, 12] = X[3, 13] = -c_ay
        X[4, 2] = -circ; X[4, 3] = -em; X[4, 4] = c_i + em; X[4, 6] = circ; X[4, 10] = -c_i
        X[5, 3] = -2 * c_ay * h; X[5, 5] = 2 * (c_ay * h**2 + c_az * b**2); X[5, 8] = c_az * b
        X[5, 9] = -c_az * b; X[5, 12] = X[5, 13] = c_ay * h
        X[6, 2] = -c_i; X[6, 4] = -circ; X[6, 6] = 2 * zz + c_i; X[6, 7] = -2 * zz
        X[6, 10] = 2 * zy + circ; X[6, 11] = -2 * zy
        X[7, 1] = -2 * c_bz; X[7, 6] = -2 * zz; X[7, 7] = 2 * (zz + c_bz); X[7, 10] = -2 * zy
        X[7, 11] = 2 * zy
        X[8, 1] = -c_az; X[8, 5] = c_az * b; X[8, 8] = c_az + c_fz
        X[9, 1] = -c_az; X[9, 5] = -c_az * b; X[9, 9] = c_az + c_fz
        X[10, 2] = circ; X[10, 4] = -c_i; X[10, 6] = 2 * yz - circ; X[10, 7] = -2 * yz
        X[10, 10] = 2 * yy + c_i; X[10, 11] = -2 * yy
        X[11, 3] = -2 * c_by; X[11, 6] = -2 * yz; X[11, 7] = 2 * yz; X[11, 10] = -2 * yy
        X[11, 11] = 2 * (yy + c_by)
        X[12, 3] = -c_ay; X[12, 5] = c_ay * h; X[12, 12] = c_ay + c_fy
        X[13, 3] = -c_ay; X[13, 5] = c_ay * h; X[13, 13] = c_ay + c_fy

    fill(C, p["c"], p["c"], p["c_bz"], p["c_by"], p["c_az"], p["c_ay"], p["c_fz"], p["c_fy"],
         oil_c, -c_md, d_i_omega)
    d = {k: p[k] * p[t] / w_F for k, t in (("c", "ti"), ("c_bz", "tb"), ("c_by", "tb"),
                                          ("c_az", "ta"), ("c_ay", "ta"), ("c_fz", "tf"), ("c_fy", "tf"))}
    fill(D, d["c"], d["c"], d["c_bz"], d["c_by"], d["c_az"], d["c_ay"], d["c_fz"], d["c_fy"],
         oil_d, d_m, 0.0)
    return M[1:, 1:], D[1:, 1:], C[1:, 1:]


@pytest.fixture(scope="module")
def machine():
    return load_machine("sleeve_bearing_motor")


@pytest.fixture(scope="module")
def oil_table():
    """The oil-film table computed independently of the plant, on the plant's table speeds."""
    speeds = np.geomspace(100.0, 6000.0, 64) * math.pi / 30
    return speeds, coefficient_table(JournalBearing(0.110, 0.0814, 1.6e-3 * 0.055),
                                     Oil(32.0, 5.4, 860.0, 6.5e-4, 2000.0), (950.0 + 10.0) * 9.81,
                                     speeds, 40.0)


@pytest.mark.parametrize("node,w_factor", [(20, 1.0), (41, 1.0), (41, 2.7), (55, 0.4)])
def test_matrices_match_paper(machine, oil_table, node, w_factor):
    speeds, table = oil_table
    speed = speeds[node]
    w_F = w_factor * speed
    em = ElectromagneticField(3.0e7, 0.8, 0.5, 1.885, 3600 * math.pi / 30)
    c_md, d_m = em.coefficients(speed, w_F)
    M, D, C = paper_matrices(P, table.stiffness[node], table.damping[node], c_md, d_m,
                             P["c"] * P["ti"] / w_F * speed, w_F)
    plant = machine.plant
    assert plant.coords == COORDS
    assert np.allclose(plant.mass, M, rtol=0, atol=1e-9)
    for got, want in ((plant.stiffness_at(speed, w_F), C), (plant.damping(speed, w_F), D)):
        assert np.allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())


def test_excitations_and_actuators(machine):
    """Eqs. (8)-(10) per unit amplitude, and P_azL,R (eqs. 16-17) with the foot sensor rows."""
    plant = machine.plant
    w = 2390 * math.pi / 30
    em = ElectromagneticField(3.0e7, 0.8, 0.5, 1.885, 3600 * math.pi / 30)
    c_md, d_m = em.coefficients(w, w)
    e = np.zeros(13, complex)
    e[[1, 3]] = P["m_w"] * w**2 * np.array([1, -1j])
    assert np.allclose(plant.excitation("mass_eccentricity").phasor(w), e)
    e = np.zeros(13, complex)
    e[:4] = [-c_md + 1j * w * d_m, c_md - 1j * w * d_m, 1j * c_md + w * d_m, -1j * c_md - w * d_m]
    assert np.allclose(plant.excitation("magnetic_eccentricity").phasor(w), e)
    e = np.zeros(13, complex)
    e[[1, 3, 5, 9]] = P["c"] * np.array([1, -1j, -1, 1j])
    assert np.allclose(plant.excitation("bent_rotor").phasor(w), e)
    b = P["b"]
    for act, sign, fnd in ((plant.actuator("L"), -1, 7), (plant.actuator("R"), 1, 8)):
        s = np.zeros(13)
        s[0], s[4] = 1.0, sign * b
        p = s.copy()
        p[fnd] = -1.0
        assert np.allclose(act.sensor_row, s) and np.allclose(act.force_vector, p)
    names = [o.name for o in plant.outputs]
    assert names == ["bearing_vz", "bearing_vy", "foundation_L_vz", "foundation_L_vy",
                     "foundation_R_vz", "foundation_R_vy"]


def test_internal_damping_vanishes_for_synchronous_forward_whirl(machine):
    """Digest 2: the rotating-damping force (d_i on the shaft plus its circulatory terms) is zero
    for a synchronous forward whirl of the shaft deflection (z = cos, y = sin: y = -j z)."""
    plant = machine.plant
    w = 1500 * math.pi / 30
    q = np.zeros(13, complex)
    q[[1, 3]] = [1.0, -1j]                       # rotor mass whirls, journals at rest
    D_i = plant.loss_damping / w                 # only the shaft part acts on z_w, y_w rows
    force = (1j * w * D_i + plant.circulatory) @ q      # circulatory term at Omega / w_F = 1
    assert abs(force[1]) < 1e-6 * P["c"] * P["ti"] and abs(force[3]) < 1e-6 * P["c"] * P["ti"]


def test_electromagnetic_field_limits():
    rated = 3600 * math.pi / 30
    em = ElectromagneticField(3.0e7, 0.8, 0.5, 1.885, rated)
    assert np.allclose(ElectromagneticField(3.0e7, 0.0, 0.5, 1.885, rated).coefficients(200.0, 150.0),
                       (3.0e7, 0.0))                    # no rotor currents: undamped spring
    c_md, d_m = em.coefficients(0.0, 80.0)              # standstill: the two waves cancel
    assert d_m == pytest.approx(0.0, abs=1e-9)
    x = 0.5 * 1.885                                     # rated, synchronous: both waves at slip
    c_md, d_m = em.coefficients(rated, rated)
    assert c_md == pytest.approx(3.0e7 * (1 - 0.8 * x**2 / (1 + x**2)))
    assert d_m == pytest.approx(3.0e7 * 0.8 * x / (1 + x**2) / rated)
    weak = em.coefficients(1.25 * rated, 1.25 * rated)   # field weakening: c_m / 1.25^2
    x = 0.5 * 1.885 * 1.25**4
    assert weak[0] == pytest.approx(3.0e7 / 1.25**2 * (1 - 0.8 * x**2 / (1 + x**2)))
    assert em.pull(rated) == pytest.approx(c_md - 1j * rated * d_m)


def test_field_off_removes_magnetic_terms():
    cfg = load_config("sleeve_bearing_motor")
    cfg.data["electromagnetic"] = {"model": "off"}
    plant = build_plant(Section(cfg.data, "", cfg.source))
    w = 2000 * math.pi / 30
    assert not np.any(plant.excitation("magnetic_eccentricity").phasor(w))
    on = load_machine("sleeve_bearing_motor").plant
    diff = on.stiffness_at(w, w) - plant.stiffness_at(w, w)
    assert np.count_nonzero(np.abs(diff) > 1e-6) == 8   # the +-c_md pattern only


@pytest.mark.parametrize("path,value,field", [
    (("motor", "stator_mass_kg"), -7040.0, "motor.stator_mass_kg"),
    (("motor", "rotor_tan_delta"), 3.0, "motor.rotor_tan_delta"),
    (("foundation", "L", "stiffness_n_per_m", "z"), 0.0, "foundation.L.stiffness_n_per_m.z"),
    (("actuator", "stiffness_n_per_m", "x"), 1.0e+8, "actuator.stiffness_n_per_m.x"),
    (("electromagnetic", "model"), "fancy", "electromagnetic.model"),
    (("sleeve_bearing", "speed_range_rpm"), [3000.0, 100.0], "sleeve_bearing.speed_range_rpm"),
])
def test_config_refusals(path, value, field):
    cfg = load_config("sleeve_bearing_motor")
    node = cfg.data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    with pytest.raises(ConfigError) as err:
        build_plant(Section(cfg.data, "", cfg.source))
    assert err.value.field == field
