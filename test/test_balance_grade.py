"""ISO 21940-11:2016 balance grades against hand computations: G = e Omega, the Table 1 class,
the clause 7 allocation to the bearing planes (checked with the models' own point-mass
unbalance), the declared permissible grade, and `rotor-avc balance` printing the grades of the
balancer's estimate and of the residual (recomputed from its saved run)."""
import json
import math

import numpy as np
import pytest

from rotor_avc.balancing.grade import (GRADES_MM_S, RotorGrade, grade_class, grade_mm_s,
                                       plane_shares)
from rotor_avc.balancing.plane import point_mass_unbalance
from rotor_avc.balancing.scenario import machine_setup, rigid_setup
from rotor_avc.cli import main
from rotor_avc.config import find_config, load_config
from rotor_avc.errors import ConfigError
from rotor_avc.machine import load_machine


def test_grade_of_a_hand_computation():
    """U = 1e-4 kg m on m = 10 kg: e = 10 um; 3000 r/min: Omega = 314.16 rad/s -> G = 3.14 mm/s."""
    omega = 3000 * 2 * math.pi / 60
    assert omega == pytest.approx(314.159, abs=1e-3)
    assert grade_mm_s(1e-4, 10.0, omega) == pytest.approx(3.14159, abs=1e-5)
    assert grade_class(grade_mm_s(1e-4, 10.0, omega)) == 6.3


def test_grade_classes_are_table_1s():
    """Table 1: 0.4 .. 4000, each about 2.5 times the previous; the class is the smallest grade
    >= the value."""
    assert GRADES_MM_S == (0.4, 1, 2.5, 6.3, 16, 40, 100, 250, 630, 1600, 4000)
    ratios = np.array(GRADES_MM_S[1:]) / np.array(GRADES_MM_S[:-1])
    assert np.all((ratios >= 2.5) & (ratios <= 2.54))
    assert [grade_class(g) for g in (0.1, 0.4, 0.41, 2.5, 2.51, 6.3, 3999.0)] == [
        0.4, 0.4, 1.0, 2.5, 6.3, 6.3, 4000.0]
    assert grade_class(4001.0) is None


def test_allocation_to_the_bearing_planes():
    """Clause 7: U_per,A = U_per L_B / L, U_per,B = U_per L_A / L, each share in 0.3 .. 0.7."""
    assert plane_shares(-0.4, 0.6) == pytest.approx((0.6, 0.4))
    assert plane_shares(-0.1, 0.9) == pytest.approx((0.7, 0.3))        # 0.9 / 0.1 limited
    with pytest.raises(Exception, match="between the bearings"):
        plane_shares(0.1, 0.9)


@pytest.mark.parametrize("lever", [1.0, 1j])
def test_static_and_couple_unbalance_by_hand(lever):
    """A symmetric rotor (bearings at -+0.5 m, 100 kg, 100 rad/s): a static U splits half and
    half, so each plane's grade is the resultant's; a couple +-U in the bearing planes has
    |U| in each, i.e. G = U Omega / (m / 2)."""
    rotor = RotorGrade(100.0, (("A", -0.5), ("B", 0.5)), lever, 100.0, 2.5)
    u = 2e-3 * np.exp(0.3j)
    static = rotor.assess(u, 0.0)
    assert static["static_grade_mm_s"] == pytest.approx(1e3 * 2e-3 / 100 * 100)      # 2.0
    assert static["grade_mm_s"] == pytest.approx(2.0) and static["within_permissible"]
    couple = rotor.assess(0.0, lever * (-0.5 * u + 0.5 * -u))
    assert [p["unbalance_kg_m"] for p in couple["planes"].values()] == pytest.approx([2e-3] * 2)
    assert couple["grade_mm_s"] == pytest.approx(4.0) and not couple["within_permissible"]
    assert couple["static_grade_mm_s"] == pytest.approx(0.0, abs=1e-15)


def test_a_mass_in_a_bearing_plane_is_all_in_that_plane():
    """The models' own point-mass unbalance: Werner 2021's (u_alpha = j a u_e) and Zhou & Shi
    2001's (moment = u_y x static) put a mass in bearing plane D / y+ wholly into that plane."""
    machine = machine_setup(load_machine("balancer_foot_mount"))
    d = machine.grade.planes[1][1]
    amp = point_mass_unbalance(0.05, 0.3, 0.7, d)
    u_n, u_d = machine.grade.plane_unbalance(amp["static"], amp["moment"])
    assert abs(u_n) == pytest.approx(0.0, abs=1e-15) and abs(u_d) == pytest.approx(0.015)
    rigid = rigid_setup(load_config("balancer_rigid_rotor"))
    half = rigid.rotor.length_m / 2
    s = 0.5 * complex(0.1, -0.05)                          # m_u (u_x - j u_z), at u_y = L/2
    u_a, u_b = rigid.grade.plane_unbalance(s, half * s)
    assert abs(u_a) == pytest.approx(0.0, abs=1e-15) and u_b == pytest.approx(s)
    assert rigid.grade.speed_rad_s == pytest.approx(300.0 * 4.0)      # alpha x duration from rest
    assert rigid.grade.mass_kg == pytest.approx(7800 * math.pi * 0.1**2 * 1.0)


def test_the_permissible_grade_is_declared_and_refused_when_negative(tmp_path):
    assert rigid_setup(load_config("balancer_rigid_rotor")).grade.permissible_mm_s == 2.5
    path = tmp_path / "bad.yaml"
    path.write_text(f"include: {find_config('balancer_rigid_rotor')}\n"
                    "balancer: {permissible_grade_mm_s: -1.0}\n")
    with pytest.raises(ConfigError, match="permissible_grade_mm_s"):
        rigid_setup(load_config(str(path)))


def test_balance_prints_the_grades_of_estimate_and_residual(tmp_path, capsys):
    """Zhou & Shi 2001's run-up to 1.5 s (one move, to cancel the force imbalance) with a
    permissible G 150: the true unbalance (G 164) is not within it, the residual is. The printed
    grades are recomputed from balance.npz: the estimate from b_hat (static m (b1 - j b2)), the
    residual static unbalance m_u (u_x - j u_z) + m_b conj(w) at the final position."""
    config = tmp_path / "g.yaml"
    config.write_text(f"include: {find_config('balancer_rigid_rotor')}\n"
                      "balancer: {permissible_grade_mm_s: 150.0}\n")
    out = tmp_path / "bal"
    assert main(["balance", str(config), "--duration-s", "1.5", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    lines = {k: next(line for line in text.splitlines() if k in line)
             for k in ("true unbalance", "balancer's estimate", "residual after correction")}
    assert "(within G 150: no" in lines["true unbalance"]
    assert "(within G 150: yes" in lines["residual after correction"]
    grades = json.loads((out / "balance.json").read_text())["iso21940_11"]
    run = np.load(out / "balance.npz")
    m, omega = 7800 * math.pi * 0.1**2, 300.0 * 1.5
    b = run["b_hat"][-1]
    assert grades["estimate"]["static_grade_mm_s"] == pytest.approx(
        1e3 * abs(m * complex(b[0], -b[1])) / m * omega, rel=1e-9)
    residual = 0.5 * complex(0.1, -0.05) + 0.5 * np.conj(run["position"][-1])
    assert grades["residual"]["static_grade_mm_s"] == pytest.approx(
        1e3 * abs(residual) / m * omega, rel=1e-9)
    assert grades["true"]["static_grade_mm_s"] == pytest.approx(
        1e3 * 0.5 * math.hypot(0.1, 0.05) / m * omega, rel=1e-12)
    for name in ("estimate", "residual"):
        g = grades[name]["grade_mm_s"]
        assert f"G {g:.3g} (within G 150: {'yes' if g <= 150 else 'no'}" in lines[
            {"estimate": "balancer's estimate", "residual": "residual after correction"}[name]]
