"""Journal-bearing film solver (rotor_avc.models.journal_bearing): published reference data
(Raimondi & Boyd 1958, the digest-001 check), the short-bearing (Ocvirk) closed forms, grid
convergence, the linearisation against the nonlinear film, the operating points, refusals."""
import math

import numpy as np
import pytest

from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.machine import build_plant
from rotor_avc.config import load_config, Section
from rotor_avc.models.journal_bearing import (JournalBearing, Oil, _film, _Grid, coefficient_table,
                                              dimensionless_table, film_solution)

# Raimondi & Boyd (1958), full journal bearing, L/D = 1: eps -> (Sommerfeld number S, attitude
# angle [deg], flow variable Q/(R C N L), side-flow ratio Q_s/Q). The digest (001 section 7
# item 1) quotes the S column and its solver's 1 % agreement.
RAIMONDI_BOYD_LD1 = {
    0.2: (0.631, 74.02, 3.59, 0.280),
    0.4: (0.264, 63.10, 3.99, 0.497),
    0.6: (0.121, 50.58, 4.33, 0.680),
    0.8: (0.0446, 36.24, 4.62, 0.842),
    0.9: (0.0188, 26.45, 4.74, 0.919),
}


def short_bearing(eps: float, ld: float):
    """Ocvirk short bearing, pi film: dimensionless force Fbar (F = mu omega R L (R/C)^2 Fbar),
    attitude angle, and the load-frame coefficients K C / W, D C omega / W (index 0 = load
    direction, 1 = 90 deg ahead in the direction of rotation). Closed forms as in Friswell et al.,
    Dynamics of Rotating Machines (2010) sec. 5.5 (their u, v = our y, -z)."""
    pi, s = math.pi, math.sqrt(1 - eps**2)
    force = ld**2 * eps / (1 - eps**2) ** 2 * math.sqrt(pi**2 * (1 - eps**2) + 16 * eps**2)
    attitude = math.atan(pi * s / (4 * eps))
    h0 = 1 / (pi**2 * (1 - eps**2) + 16 * eps**2) ** 1.5
    a_uu = 4 * (pi**2 * (2 - eps**2) + 16 * eps**2) * h0
    a_uv = pi * (pi**2 * (1 - eps**2) ** 2 - 16 * eps**4) / (eps * s) * h0
    a_vu = -pi * (pi**2 * (1 - eps**2) * (1 + 2 * eps**2) + 32 * eps**2 * (1 + eps**2)) / (eps * s) * h0
    a_vv = 4 * (pi**2 * (1 + 2 * eps**2) + 32 * eps**2 * (1 + eps**2) / (1 - eps**2)) * h0
    b_uu = 2 * pi * s * (pi**2 * (1 + 2 * eps**2) - 16 * eps**2) / eps * h0
    b_uv = -8 * (pi**2 * (1 + 2 * eps**2) - 16 * eps**2) * h0
    b_vv = 2 * pi * (pi**2 * (1 - eps**2) ** 2 + 48 * eps**2) / (eps * s) * h0
    k = np.array([[a_vv, -a_vu], [-a_uv, a_uu]])
    c = np.array([[b_vv, -b_uv], [-b_uv, b_uu]])
    return force, attitude, k, c


@pytest.mark.parametrize("eps", sorted(RAIMONDI_BOYD_LD1))
def test_raimondi_boyd_square_bearing(eps):
    S, phi, flow, side = RAIMONDI_BOYD_LD1[eps]
    sol = film_solution(eps, 1.0, 240, 16)
    assert sol.sommerfeld == pytest.approx(S, rel=0.02)           # 0.2 .. 1.5 % in fact
    assert math.degrees(sol.attitude_rad) == pytest.approx(phi, abs=1.0)       # 0.04 .. 0.53 deg
    assert sol.flow == pytest.approx(flow, rel=0.01)
    assert sol.side_flow / sol.flow == pytest.approx(side, rel=0.01)


@pytest.mark.parametrize("eps", [0.3, 0.6, 0.8])
def test_short_bearing_limit(eps):
    """Small L/D: force, attitude and all eight coefficients approach the Ocvirk closed forms,
    and the force error shrinks as L/D does."""
    force, attitude, k, c = short_bearing(eps, 1 / 16)
    sol = film_solution(eps, 1 / 16, 240, 8)
    assert sol.force == pytest.approx(force, rel=0.01)
    assert math.degrees(sol.attitude_rad) == pytest.approx(math.degrees(attitude), abs=0.1)
    for got, want in ((sol.stiffness / sol.force, k), (sol.damping / sol.force, c)):
        assert np.linalg.norm(got - want) / np.linalg.norm(want) < 0.015
    wide = film_solution(eps, 1 / 4, 240, 8)
    assert abs(wide.force / short_bearing(eps, 1 / 4)[0] - 1) > abs(sol.force / force - 1)


def test_grid_convergence():
    """Refining the grid changes force and coefficients less and less (B/D of Werner 2019)."""
    sols = [film_solution(0.6, 0.74, nt, nz) for nt, nz in ((60, 6), (120, 12), (240, 24))]
    vec = [np.concatenate([[s.force, s.attitude_rad], s.stiffness.ravel(), s.damping.ravel()])
           for s in sols]
    d1 = np.linalg.norm(vec[1] - vec[0]) / np.linalg.norm(vec[2])
    d2 = np.linalg.norm(vec[2] - vec[1]) / np.linalg.norm(vec[2])
    assert d2 < 0.6 * d1
    assert d2 < 0.01


@pytest.mark.parametrize("eps,ld", [(0.6, 0.74), (0.3, 1.0), (0.85, 0.5)])
def test_linearised_coefficients_match_perturbed_film(eps, ld):
    """Lund's linearised perturbation equations == central differences of the nonlinear
    (cavitating) film force under small displacements and velocities of the journal."""
    grid = _Grid(120, 12, ld)
    sol = film_solution(eps, ld, 120, 12)

    def force(pos, vel):
        return grid.integrate(_film(grid, pos, vel)[0])

    h = 1e-5
    K, C = np.zeros((2, 2)), np.zeros((2, 2))
    for j in range(2):
        d = np.eye(2)[j] * h
        K[:, j] = -(force((eps + d[0], d[1]), (0, 0)) - force((eps - d[0], -d[1]), (0, 0))) / (2 * h)
        C[:, j] = -(force((eps, 0), d) - force((eps, 0), -d)) / (2 * h)
    f0 = force((eps, 0), (0, 0))
    u = -f0 / np.hypot(*f0)
    R = np.array([[u[0], u[1]], [-u[1], u[0]]])
    assert np.allclose(R @ K @ R.T, sol.stiffness, rtol=0, atol=1e-6 * np.abs(sol.stiffness).max())
    assert np.allclose(R @ C @ R.T, sol.damping, rtol=0, atol=1e-6 * np.abs(sol.damping).max())
    assert np.allclose(sol.damping, sol.damping.T, atol=1e-9 * np.abs(sol.damping).max())


def test_oil_walther_rule():
    oil = Oil(32.0, 5.4, 860.0, 6.5e-4, 2000.0)
    assert oil.kinematic_viscosity_m2_s(40.0) == pytest.approx(32e-6, rel=1e-12)
    assert oil.kinematic_viscosity_m2_s(100.0) == pytest.approx(5.4e-6, rel=1e-12)
    nu = oil.kinematic_viscosity_m2_s(np.array([20.0, 50.0, 70.0]))
    assert np.all(np.diff(nu) < 0) and nu[0] > 32e-6
    assert oil.dynamic_viscosity_pa_s(40.0) == pytest.approx(32e-6 * 860 * (1 - 6.5e-4 * 25))


@pytest.fixture(scope="module")
def seed001_table():
    bearing = JournalBearing(0.110, 0.0814, 88e-6)
    oil = Oil(32.0, 5.4, 860.0, 6.5e-4, 2000.0)
    rpm = np.geomspace(300, 4500, 12)
    return bearing, oil, rpm, coefficient_table(bearing, oil, 9417.6, rpm * math.pi / 30, 40.0)


def test_operating_points(seed001_table):
    """Equilibrium from the table: the film at the found eccentricity carries the load, the
    coefficients equal a direct solve there, and the journal rises as the speed grows."""
    bearing, oil, rpm, table = seed001_table
    R, L, C = 0.055, 0.0814, 88e-6
    assert np.all(np.diff(table.eccentricity) < 0) and np.all(np.diff(table.temperature_c) > 0)
    assert 40.0 < table.temperature_c[0] and table.temperature_c[-1] < 70.0
    for k in (0, 5, 11):
        sol = film_solution(table.eccentricity[k], bearing.ld_ratio)
        w, mu = rpm[k] * math.pi / 30, table.viscosity_pa_s[k]
        assert mu * w * R * L * (R / C) ** 2 * sol.force == pytest.approx(9417.6, rel=0.005)
        assert mu == pytest.approx(oil.dynamic_viscosity_pa_s(table.temperature_c[k]), rel=1e-9)
        scale = mu * w * R * L * (R / C) ** 2 / C
        for got, want in ((table.stiffness[k], scale * sol.stiffness),
                          (table.damping[k], scale / w * sol.damping)):
            assert np.abs(got - want).max() < 0.01 * np.abs(want).max()
    K, D = table.at(np.array([1000.0, 2000.0]) * math.pi / 30)
    assert K.shape == (2, 2, 2) and D.shape == (2, 2, 2)
    # digest 7 item 2: c_zy > 0 everywhere, c_yz < 0 once the journal rises (eps < 0.7)
    assert np.all(table.stiffness[:, 0, 1] > 0)
    assert np.all(table.stiffness[table.eccentricity < 0.68, 1, 0] < 0)


def test_fixed_effective_temperature(seed001_table):
    bearing, oil, rpm, table = seed001_table
    fixed = coefficient_table(bearing, oil, 9417.6, rpm * math.pi / 30, 40.0, effective_temp_c=48.0)
    assert np.allclose(fixed.temperature_c, 48.0)
    k = int(np.argmin(np.abs(table.temperature_c - 48.0)))
    assert fixed.eccentricity[k] == pytest.approx(table.eccentricity[k], abs=0.01)


def test_refusals(seed001_table):
    bearing, oil, rpm, table = seed001_table
    for eps in (1.0, 1.2, 0.0, -0.1, float("nan")):
        with pytest.raises(ModelError, match="eccentricity"):
            film_solution(eps, 1.0)
    for kwargs in ({"radial_clearance_m": 0.0}, {"radial_clearance_m": -1e-5},
                   {"length_m": 0.0}, {"diameter_m": -0.1}):
        args = {"diameter_m": 0.11, "length_m": 0.08, "radial_clearance_m": 88e-6} | kwargs
        with pytest.raises(ModelError, match=next(iter(kwargs))):
            JournalBearing(**args)
    with pytest.raises(ModelError, match="not small"):
        JournalBearing(0.11, 0.08, 0.01)
    with pytest.raises(ModelError, match="viscosit"):
        Oil(0.0, 5.4, 860, 6.5e-4, 2000)
    with pytest.raises(ModelError, match="viscosit"):
        Oil(32.0, -1.0, 860, 6.5e-4, 2000)
    with pytest.raises(ModelError, match="eccentricity ratio above"):
        coefficient_table(bearing, oil, 9417.6, np.array([2.0, 5.0, 10.0, 20.0]) * math.pi / 30, 40.0)
    with pytest.raises(ModelError, match="tabulated for"):
        table.at(0.0)
    with pytest.raises(ModelError, match="grid"):
        film_solution(0.5, 1.0, 30, 4)


@pytest.mark.parametrize("key,value,field", [
    ("relative_clearance", -1.6e-3, "sleeve_bearing.relative_clearance"),
    ("relative_clearance", 0.0, "sleeve_bearing.relative_clearance"),
    ("diameter_m", 0.0, "sleeve_bearing.diameter_m"),
])
def test_config_refusals(key, value, field):
    cfg = load_config("sleeve_bearing_motor")
    cfg.data["sleeve_bearing"][key] = value
    with pytest.raises(ConfigError) as err:
        build_plant(Section(cfg.data, "", cfg.source))
    assert err.value.field == field


def test_config_refuses_zero_viscosity():
    cfg = load_config("sleeve_bearing_motor")
    cfg.data["sleeve_bearing"]["oil"]["nu40_mm2_s"] = 0.0
    with pytest.raises(ConfigError, match="nu40_mm2_s"):
        build_plant(Section(cfg.data, "", cfg.source))


def test_table_is_cached_and_fast():
    """The data-book table is built once per L/D and grid (the plant's speed table then costs
    microseconds per speed)."""
    assert dimensionless_table(0.74) is dimensionless_table(0.74, 120, 12)
