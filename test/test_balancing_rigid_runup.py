"""Zhou & Shi 2001 Figure 4: the in-process run-up of the paper's rotor with the balancer block. The
simulator against the closed form of App. A, and the digest's strategy comparison (peak whirl of
the output point before / after 2.6 s and RMS over 0-4 s, within 2 %)."""
import dataclasses

import numpy as np
import pytest

from rotor_avc.balancing.rigid_runup import simulate_rigid_runup
from rotor_avc.balancing.runup_response import runup_response
from rotor_avc.balancing.scenario import rigid_setup
from rotor_avc.config import load_config

SETUP = rigid_setup(load_config("balancer_rigid_rotor"))
ROTOR, SC = SETUP.rotor, SETUP.runup

#: digest 8, Figure 4 table: (max|v| t < 2.6 s, max|v| t >= 2.6 s, RMS 0-4 s) in mm
DIGEST = {("none", "paper"): (7.952, 13.330, 3.301),
          ("mode1", "paper"): (1.409, 26.977, 5.686),
          ("mode2", "paper"): (15.495, 1.963, 3.324),
          ("optimal", "paper"): (1.409, 3.835, 1.105),
          ("optimal", "derived"): (1.409, 1.739, 0.648)}


def metrics(rec):
    return rec.peak(0, 2.6)[0] * 1e3, rec.peak(2.6)[0] * 1e3, rec.rms * 1e3


def test_simulator_matches_closed_form():
    """Balancer fixed at zero: v = u1 conj(x1) + i l_s u2 conj(x2) (App. A, digest 3.4)."""
    rec = simulate_rigid_runup(SC, None, SETUP.actuator())
    p1, p2 = (runup_response(rec.t, ROTOR.omega_n[i], ROTOR.zeta[i], SC.accel_rad_s2)
              for i in range(2))
    amp = SC.true_amplitudes()
    v = (np.conj(amp["static"]) / ROTOR.mass_kg * np.conj(p1.total)
         + 1j * ROTOR.output_axial_m * (-1j * np.conj(amp["moment"]) / ROTOR.I_t)
         * np.conj(p2.total))
    assert np.abs(rec.output - v).max() <= 1e-5 * np.abs(v).max()
    assert metrics(rec) == pytest.approx(DIGEST[("none", "paper")], rel=0.02)


def test_gyroscopic_terms_raise_the_conical_critical():
    """With the I_p terms the conical forward critical moves to w2 / sqrt(1 - I_p/I_t)
    (digest 3.1): the unbalanced conical peak comes later in the run-up."""
    gyro = dataclasses.replace(SC, rotor=dataclasses.replace(ROTOR, gyroscopic=True))
    t_peak = {name: simulate_rigid_runup(sc, None, SETUP.actuator()).peak(2.6)[1]
              for name, sc in (("plain", SC), ("gyro", gyro))}
    w2g = ROTOR.omega_n[1] / np.sqrt(1 - ROTOR.I_p / ROTOR.I_t)
    assert w2g == pytest.approx(1004.84, abs=0.01)
    shift = (w2g - ROTOR.omega_n[1]) / SC.accel_rad_s2
    assert t_peak["gyro"] - t_peak["plain"] == pytest.approx(shift, rel=0.1)


@pytest.mark.parametrize("strategy, weight", [("optimal", "paper"), ("optimal", "derived"),
                                              ("mode1", "paper"), ("mode2", "paper")])
def test_strategy_comparison(strategy, weight, full):
    if strategy.startswith("mode") and not full:
        pytest.skip("single-mode strategies run with --full")
    block = SETUP.block(strategy, weight)
    rec = simulate_rigid_runup(SC, block, SETUP.actuator())
    assert metrics(rec) == pytest.approx(DIGEST[(strategy, weight)], rel=0.02)
    if strategy == "optimal":
        t_sw = SETUP.schedule(weight).times[0]
        (t1, m1, w1), (t2, m2, w2) = block.events
        assert (t1, m1) == (pytest.approx(1.0), "mode1")
        assert m2 == "mode2" and 0 <= t2 - t_sw < SC.sample_period_s + 1e-12
        # targets from the live estimate: (-0.1, -0.05) m then (+0.1, +0.05) m (digest 8)
        assert abs(w1 - (-0.1 - 0.05j)) < 0.01 * 0.1118
        assert abs(w2 - (0.1 + 0.05j)) < 0.01 * 0.1118
        assert np.all(np.isfinite(rec.b_hat[1:]))
