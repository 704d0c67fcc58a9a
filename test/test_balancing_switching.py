"""Zhou & Shi 2001 eqs. 7-13: the switching instants (paper 2.9506 s with W = l_s; 2.68411 s with the
derived W = |d| l_s), their sensitivity to the shaft density (digest 8), the geometric solution of
eq. 13 against brute force, the balancer targets and the rate-limited actuator."""

import numpy as np
import pytest

from rotor_avc.balancing.actuator import BalancerActuator
from rotor_avc.balancing.switching import (eq13_minimiser, mode_amplifications, mode_target,
                                           switching_schedule, switching_weight)
from rotor_avc.config import load_config
from rotor_avc.errors import ModelError
from rotor_avc.model_config.rigid_rotor import rotor_from_config

CFG = load_config("balancer_rigid_rotor")
ROTOR = rotor_from_config(CFG)
W_Y = 0.3


def rotor_with_density(rho):
    data = dict(CFG.data, rotor=dict(CFG.data["rotor"], density_kg_m3=rho))
    return rotor_from_config(type(CFG)(data))


def test_paper_switching_time_with_weight_half():
    W = switching_weight(ROTOR, W_Y, "paper")
    assert W == 0.5
    sched = switching_schedule(ROTOR, 300.0, 4.0, W)
    assert sched.start_mode == 1
    (t_sw, mode, kind), = sched.switches
    assert (mode, kind) == (2, "root")
    assert round(t_sw, 4) == 2.9506                          # paper, 4 digits
    m1, m2 = mode_amplifications(ROTOR, np.array([t_sw]), 300.0)
    assert m1[0] == pytest.approx(0.5 * m2[0], rel=1e-9)


def test_derived_weight_and_switch_back():
    W = switching_weight(ROTOR, W_Y, "derived")
    assert W == pytest.approx(3.495146 * 0.5, rel=1e-6)       # |d| l_s, digest 9 item 2
    assert switching_schedule(ROTOR, 300.0, 4.0, W).times == pytest.approx([2.68411], abs=1e-5)
    # with W = 0.5 the law returns to mode 1 at 4.17796 s (digest 9 item 3)
    sched = switching_schedule(ROTOR, 300.0, 4.5, 0.5)
    assert sched.times == pytest.approx([2.95060, 4.17796], abs=1e-5)
    assert [sched.mode_at(t) for t in (1.0, 3.0, 4.3)] == [1, 2, 1]


@pytest.mark.parametrize("rho, t_ref", [(7750.0, 2.95821), (7850.0, 2.94308), (7900.0, 2.93564)])
def test_switching_time_on_other_densities(rho, t_ref):
    rot = rotor_with_density(rho)
    assert switching_schedule(rot, 300.0, 4.0, 0.5).times[0] == pytest.approx(t_ref, abs=2e-5)


def test_eq13_geometric_solution_against_brute_force():
    """eq. 10 minimised on a grid over (x, y) for random imbalances and amplifications: the
    geometric solution (x = -a or x = -c a/d, y = (b/a) x) attains the grid minimum."""
    rng = np.random.default_rng(0)
    for _ in range(20):
        a, b = rng.normal(size=2) * 1e-4
        c, d = rng.normal(size=2) * 4
        M1, M2 = rng.uniform(0.1, 10, size=2)

        def cost(x, y):
            return (np.hypot(a + x, b + y) * M1 + np.hypot(c * b + d * y, c * a + d * x) * M2)
        x = eq13_minimiser(a, c, d, M1, M2)
        g = np.linspace(-1, 1, 401) * 6 * max(abs(a), abs(b), abs(c * a / d), abs(c * b / d))
        X, Y = np.meshgrid(g, g)
        assert cost(x, b / a * x) <= cost(X, Y).min() * (1 + 1e-9)


def test_mode_targets_cancel_force_or_moment():
    # LinearPlant amplitudes of the paper's imbalance: static m_u (u_x - j u_z), moment * u_y
    static = 0.5 * (0.1 - 0.05j)
    moment = static * -0.3
    assert mode_target(1, static, moment, 0.5, W_Y) == pytest.approx(-0.1 - 0.05j)
    assert mode_target(2, static, moment, 0.5, W_Y) == pytest.approx(0.1 + 0.05j)
    assert mode_target(0, static, moment, 0.5, W_Y) == 0
    with pytest.raises(ModelError, match="w_y = 0"):
        mode_target(2, static, moment, 0.5, 0.0)


def test_bad_weight_and_duration():
    with pytest.raises(ModelError, match="switching weight"):
        switching_weight(ROTOR, W_Y, "half")
    with pytest.raises(ModelError, match="duration"):
        switching_schedule(ROTOR, 300.0, 0.0, 0.5)


def test_actuator_moves_linearly_and_is_rate_limited():
    act = BalancerActuator(move_time_s=0.2)
    act.command(-0.1 - 0.05j, 1.0)
    assert act.position(1.1) == pytest.approx(-0.05 - 0.025j)
    assert act.position(1.2) == pytest.approx(-0.1 - 0.05j)
    act.command(0.1 + 0.05j, 2.0)                      # straight through the centre
    assert act.position(2.1) == pytest.approx(0)
    slow = BalancerActuator(move_time_s=0.2, max_rate=0.1, max_radius=0.05)
    slow.command(1.0, 0.0)                             # saturates at the radius limit
    assert slow.saturated and slow.target == pytest.approx(0.05)
    assert slow.position(0.25) == pytest.approx(0.025)  # 0.05 at 0.1 per s takes 0.5 s
    with pytest.raises(ModelError, match="cannot jump"):
        BalancerActuator(move_time_s=0.0)
