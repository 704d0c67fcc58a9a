"""Controllers stay sane: absurd measurements never reach the filter, its state never becomes
non-finite, a saturated output recovers, and bad stamps cost a bounded number of samples.

Each case runs the block built from the shipped case-3 config (G_c = 1.4e5/s on acceleration,
Werner 2021 eq. 50) against a reference block that never saw the fault; "recovered" means the
faulty block's force equals the reference's again (exactly, or within 1 N where the fault
legitimately moved the state), and the number of samples that takes is asserted."""
import math

import numpy as np
import pytest
import yaml

from rotor_avc.config import find_config
from rotor_avc.control.block import PLAUSIBLE_LIMITS, build_digital_controllers
from rotor_avc.control.stamps import StampScreen
from rotor_avc.machine import load_machine

T = 1 / 5000.0
N = 2000
K_FAULT = 500


def signal(n=N, amplitude=0.5):
    """A foot acceleration as case 3 sees it: 1x at 20 Hz plus broadband noise (m/s^2)."""
    k = np.arange(n)
    noise = np.random.default_rng(7).standard_normal(n)
    return (amplitude * np.sin(2 * np.pi * 20.0 * k * T) + 0.05 * noise).tolist()


def block(tmp_path, base="foot_mount_case3.yaml", **keys):
    cfg = {"include": str(find_config(base).resolve()), "controllers": {"DL": keys}}
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump(cfg))
    b = build_digital_controllers(load_machine(path), T)["DL"]
    b.reset()
    return b


@pytest.mark.parametrize("bad", [1.797e308, 1e300, -1e300, math.inf, math.nan, 1e6])
@pytest.mark.parametrize("keys", [{}, {"force_limit_n": 2000.0}])
def test_absurd_measurement_is_rejected_and_costs_one_sample(tmp_path, bad, keys):
    faulty, ref = block(tmp_path, **keys), block(tmp_path, **keys)
    x = signal()
    got = []
    for k, v in enumerate(x):
        got.append(faulty.step(bad if k == K_FAULT else v))
    expected = [ref.step(v) for k, v in enumerate(x) if k != K_FAULT]
    assert got[K_FAULT] == got[K_FAULT - 1]                 # safe output: hold
    # recovery: every later force is the reference's exactly (the bad sample never stepped)
    assert got[:K_FAULT] + got[K_FAULT + 1:] == expected
    assert faulty.faults == {"implausible": 1, "filter_reset": 0}
    assert all(math.isfinite(z) for z in faulty.filter.state)


def test_zero_safe_output(tmp_path):
    b = block(tmp_path)
    b.safe_output = "zero"
    b.step(1.0)
    assert b.step(math.nan) == 0.0 and b.step(0.0) != 0.0


def test_saturating_spike_recovers_with_the_default_anti_windup(tmp_path):
    """A 1e6 m/s^2 spike inside a raised measurement_limit saturates force_limit_n 2000 N. With a
    leaky integrator (leak 5 Hz, tau = 1/(2 pi 5) s) the back-calculation that a limit now
    brings by default holds the stored excess at the limit, so the force is back within 1 N of
    the reference within ln(2 * 2000 N / 1 N) tau; without anti-windup the excess of
    b0 * 1e6 = 1.4e7 N takes about ln(1.4e7) tau, twice as long."""
    keys = {"force_limit_n": 2000.0, "measurement_limit": 1e7, "leak_hz": 5.0}
    tau_samples = 1 / (2 * np.pi * 5.0) / T
    x = signal(6000)
    recovery = {}
    for strategy in ("default", "none"):
        extra = {} if strategy == "default" else {"anti_windup": "none"}
        faulty, ref = block(tmp_path, **keys, **extra), block(tmp_path, **keys, **extra)
        assert faulty.anti_windup == ("back_calculation" if strategy == "default" else "none")
        f = np.array([faulty.step(1e6 if k == K_FAULT else v) for k, v in enumerate(x)])
        r = np.array([ref.step(v) for v in x])
        assert abs(f[K_FAULT]) == 2000.0
        off = np.flatnonzero(np.abs(f - r) > 1.0)
        recovery[strategy] = int(off[-1]) - K_FAULT + 1
    assert recovery["default"] <= math.ceil(math.log(2 * 2000.0) * tau_samples) + 2
    assert recovery["none"] >= 1.8 * recovery["default"]


def test_unstable_controller_state_resets_instead_of_overflowing(tmp_path):
    """G_c = 1.4e5 / (s - 100): its state grows e^(100 t) and would overflow after ~7 s; each
    time the output stops being finite the filter is reset to rest, and no force is non-finite."""
    b = block(tmp_path, "foot_mount_case2.yaml", type="tf", feedback="acceleration",
              num=[1.4e5], den=[1.0, -100.0])
    forces = [b.step(v) for v in signal(40_000, 1.0)]
    assert b.faults["filter_reset"] >= 1
    assert all(math.isfinite(f) for f in forces)


def test_default_plausible_range_is_stated_per_feedback(tmp_path):
    b = block(tmp_path)
    assert b.measurement_limit == PLAUSIBLE_LIMITS["acceleration"]
    assert "measurements beyond +-100000 m/s^2 rejected (hold)" in b.describe()
    assert block(tmp_path, measurement_limit=50.0).measurement_limit == 50.0


def test_future_stamp_costs_one_sample_and_nothing_latches():
    screen = StampScreen(T, max_jump_s=1.0, resync_samples=10)
    ns = [round(k * T * 1e9) for k in range(100)]
    verdicts = [screen.classify(s) for s in ns[:50]]
    verdicts.append(screen.classify((2**31 - 1) * 10**9))      # one message stamped 2^31-1 s
    verdicts += [screen.classify(s) for s in ns[50:]]
    assert verdicts.count("future") == 1 and verdicts[51:] == ["ok"] * 50
    assert screen.counts["dropped"] == 0 and screen.last_ns == ns[-1]


def test_first_stamp_far_ahead_resyncs_after_the_stated_samples():
    screen = StampScreen(T, max_jump_s=1.0, resync_samples=10)
    assert screen.classify((2**31 - 1) * 10**9) == "ok"        # nothing to compare with yet
    v = [screen.classify(round(k * T * 1e9)) for k in range(1, 30)]
    assert v[:9] == ["stale"] * 9 and v[9] == "resync" and v[10:] == ["ok"] * 19
    assert screen.counts["resync"] == 1


def test_gaps_in_the_stamps_count_the_dropped_samples():
    rng = np.random.default_rng(3)
    keep = np.sort(rng.choice(10_000, 7_000, replace=False))
    jitter = rng.uniform(-0.2, 0.2, keep.size) * T          # below a quarter period
    screen = StampScreen(T)
    for k, j in zip(keep, jitter):
        assert screen.classify(round((k * T + j) * 1e9)) == "ok"
    assert screen.counts["dropped"] == (keep[-1] - keep[0] + 1) - keep.size


def test_samples_answered_at_the_force_limit_are_counted(tmp_path):
    """An in-range spike through G_c = b0/s on acceleration (no leak) drives the force to
    force_limit_n; the block counts every sample answered at the limit (the node reports it
    as ``saturated`` on /diagnostics), so a force held at its limit is never silent, and a
    saturation is not a fault."""
    b = block(tmp_path, force_limit_n=2000.0)
    x = signal()
    forces = np.array([b.step(5e4 if k == K_FAULT else v) for k, v in enumerate(x)])
    at_limit = int(np.sum(np.abs(forces) >= 2000.0))
    assert at_limit > 0 and b.saturated_samples == at_limit
    assert b.faults == {"implausible": 0, "filter_reset": 0}
