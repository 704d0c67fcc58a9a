"""The loop's fast path (rotor_avc.sim.fused: plant and linear controllers in one matrix per
sample) against the per-sample path it replaces: the same time series to 1e-12 of each
signal's peak and the same fault and saturation counts, on runs that stay linear, saturate at
the force and rate limits, reject implausible measurements and step between speed nodes."""
import numpy as np
import pytest

from rotor_avc.control.block import DigitalController, build_digital_controllers
from rotor_avc.machine import load_machine
from rotor_avc.sim import fused
from rotor_avc.sim.loop import run_blocks, run_loop
from rotor_avc.sim.speed_profile import constant_speed, stepped
from rotor_avc.sim.stepper import PlantStepper

TWO_PI = 2 * np.pi
FS = 5000.0
AMP = {"static": 1.0e-2 * np.exp(0.7j), "moment": 2.0e-3 * np.exp(-0.2j)}


@pytest.fixture(scope="module")
def machine():
    return load_machine("foot_mount_case3_4act")


def controllers(machine, **limits):
    """The machine's blocks, rebuilt with ``limits`` (force/rate limits, measurement limit)."""
    blocks = build_digital_controllers(machine, 1 / FS)
    if not limits:
        return blocks
    return {k: DigitalController(c.tf, name=k, **limits) for k, c in blocks.items()}


def both_paths(machine, monkeypatch, n, profile=None, initial_state="steady_state", **limits):
    """``(fast, per_sample)``: each ``(time series, controllers, samples on the fast path)``."""
    out = []
    for fast in (True, False):
        st = PlantStepper(machine.plant, 1 / FS, profile or constant_speed(TWO_PI * 50), AMP)
        ctrls = controllers(machine, **limits)
        taken = []
        real = st.advance_to
        monkeypatch.setattr(st, "advance_to", lambda s, *a: taken.append(s) or real(s, *a))
        ts = run_loop(st, ctrls, n, initial_state=initial_state, progress=False,
                      fast_path=fast)
        assert st.k == n
        out.append((ts, ctrls, sum(taken)))
    return out


def assert_same(a, b, rel=1e-12):
    assert a.channels.keys() == b.channels.keys()
    for name, values in b.channels.items():
        peak = np.abs(values).max()
        assert np.abs(a.channels[name] - values).max() <= rel * peak, name


def counts(ctrls):
    return {k: (dict(c.faults), c.saturated_samples) for k, c in ctrls.items()}


@pytest.mark.parametrize("initial_state", ["steady_state", "rest"])
def test_a_linear_run_takes_the_fast_path_and_equals_the_per_sample_loop(
        machine, monkeypatch, initial_state):
    (fast, fc, taken), (slow, sc, none) = both_paths(machine, monkeypatch, 6000,
                                                     initial_state=initial_state)
    assert_same(fast, slow)
    assert none == 0 and taken >= 6000 - 2 * 4096 // fused.MIN_SEGMENT
    assert counts(fc) == counts(sc)
    for k in fc:
        np.testing.assert_allclose(fc[k].filter.z, sc[k].filter.z, rtol=1e-12, atol=1e-300)
        assert fc[k].last_force_n == pytest.approx(sc[k].last_force_n, rel=1e-12)


def test_force_and_rate_limits_are_taken_by_the_blocks_own_path(machine, monkeypatch):
    """Limits below the run's forces from rest: saturated and rate-limited samples, wound back
    by back-calculation, counted alike; between them the fast path runs."""
    peak = np.abs(both_paths(machine, monkeypatch, 2000, initial_state="rest")[1][0]
                  .channels["actuator_DL_fz"]).max()
    (fast, fc, taken), (slow, sc, _) = both_paths(
        machine, monkeypatch, 6000, initial_state="rest", force_limit_n=0.6 * peak,
        rate_limit_n_per_s=0.6 * peak * TWO_PI * 50, anti_windup="back_calculation")
    assert_same(fast, slow)
    assert counts(fc) == counts(sc)
    assert all(c.saturated_samples > 0 for c in sc.values())
    assert 0 < taken < 6000


def test_implausible_measurements_are_rejected_as_without_the_fast_path(machine, monkeypatch):
    """A measurement limit inside the signal's range: rejected samples answered with the held
    force and counted, the same numbers as the per-sample path."""
    slow = both_paths(machine, monkeypatch, 1000)[1]
    signal = slow[0].channels["foot_DL_az"]
    (fast, fc, taken), (slow, sc, _) = both_paths(
        machine, monkeypatch, 6000, measurement_limit=0.9 * np.abs(signal).max())
    assert_same(fast, slow)
    assert counts(fc) == counts(sc) and sc["DL"].faults["implausible"] > 0
    assert taken > 0


def test_steps_between_speed_nodes_take_the_per_sample_path(machine, monkeypatch):
    """Dwells at 30 and 45 Hz joined by 0.1 s transitions: the dwells fast, the transitions
    (between nodes) per sample, the whole run as without the fast path."""
    profile = stepped([TWO_PI * 30, TWO_PI * 45], dwell_s=0.4, transition_s=0.1)
    (fast, fc, taken), (slow, _, _) = both_paths(machine, monkeypatch, 4500, profile=profile,
                                                 initial_state="rest")
    assert_same(fast, slow)
    assert 2500 < taken < 4500 - 400


def test_blocks_do_not_change_the_numbers(machine):
    """The fast path's segments follow the stepper's chunks, not the caller's blocks: a run in
    blocks of 137 samples equals the run in one block bit for bit."""
    def run(block_steps):
        st = PlantStepper(machine.plant, 1 / FS, constant_speed(TWO_PI * 50), AMP)
        blocks = run_blocks(st, controllers(machine), 5000, block_steps=block_steps,
                            initial_state="steady_state", progress=False)
        return np.concatenate([b.channels["foot_DL_az"] for b in blocks])
    np.testing.assert_array_equal(run(137), run(5000))


def test_what_the_fast_path_cannot_represent_is_not_fused(machine):
    blocks = build_digital_controllers(machine, 1 / FS)
    assert fused.fusable(blocks.values())
    delayed = DigitalController(blocks["DL"].tf, delay_samples=1)
    assert not fused.fusable([*blocks.values(), delayed])
    assert not fused.fusable([lambda signal: 0.0])


def test_an_open_loop_run_takes_the_fast_path(machine, monkeypatch):
    """No controller at all (the open machine at constant speed): the plant alone, fused."""
    out = []
    for fast in (True, False):
        st = PlantStepper(machine.plant, 1 / FS, constant_speed(TWO_PI * 50), AMP)
        out.append(run_loop(st, {}, 3000, progress=False, fast_path=fast))
    assert_same(*out)
