"""The real-time plant's absolute schedule (rotor_avc.nodes.timing.Schedule): sample k is due at
t0 + k T whatever happened before, so late ticks never accumulate into drift; lateness and
overruns are counted per sample (a fake clock, no ROS, no wall-clock assertion)."""
import numpy as np
import pytest

from rotor_avc.nodes.timing import Schedule

T = 1e-3


def run(lateness_s: np.ndarray) -> Schedule:
    """Take every sample as a real-time plant does: as soon as it is due, ``lateness_s[k]``
    late -- or at once after the previous one when that was later (catching up)."""
    s = Schedule(T)
    s.begin(100.0)
    now = 100.0
    for k, late in enumerate(lateness_s):
        now = max(now, s.due(k) + late)
        s.record(k, now)
    return s


def test_late_ticks_do_not_shift_the_later_samples():
    rng = np.random.default_rng(1)
    late = rng.exponential(50e-6, 20_000)
    late[5000] = 0.2                               # one stall of 200 periods: the run catches up
    s = run(late)
    assert s.due(19_999) == pytest.approx(100.0 + 19_999 * T, abs=1e-12)
    st = s.summary()
    assert abs(st["period_error"]) < 1e-3          # the mean period stays the nominal one
    assert st["overruns"] >= 199                   # the stall and the samples that caught up
    assert st["late_max_s"] == pytest.approx(0.2)
    assert st["late_p50_s"] == pytest.approx(np.log(2) * 50e-6, rel=0.1)


def test_a_plant_that_cannot_keep_up_drifts_and_says_so():
    s = run(np.arange(1000) * 0.5 * T)             # every tick costs 1.5 periods
    st = s.summary()
    assert st["period_error"] == pytest.approx(0.5, rel=1e-6)
    assert st["overruns_per_10k"] > 9000
