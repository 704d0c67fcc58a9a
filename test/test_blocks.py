"""The block contract (rotor_avc.blocks): every block of the loop implements its protocol, and
resuming from a ``state`` snapshot repeats the same outputs bit for bit."""
import numpy as np
import pytest

from rotor_avc import blocks
from rotor_avc.control.synchronous import SynchronousForceGenerator
from rotor_avc.errors import ModelError
from rotor_avc.harmonic.block import HarmonicController
from rotor_avc.harmonic.block_settings import HarmonicSettings
from rotor_avc.harmonic.influence import InfluenceSchedule
from rotor_avc.scenario import load_scenario

TWO_PI = 2 * np.pi


@pytest.fixture(scope="module")
def case3():
    return load_scenario("scenario_case3_steady")


@pytest.fixture(scope="module")
def balanced():
    return load_scenario("scenario_balance_runup")


def test_every_block_implements_its_protocol(case3, balanced):
    loop_balancer = balanced.balancer()
    generator = SynchronousForceGenerator([10.0, 20.0], [[1.0 + 0j], [2.0 + 0j]], 1e-3, ["y1"])
    assert isinstance(case3.stepper(), blocks.Plant)
    assert all(isinstance(c, blocks.Controller) for c in case3.controllers().values())
    assert isinstance(generator, blocks.Synchronous)
    assert isinstance(harmonic_block(), blocks.Harmonic)
    assert isinstance(loop_balancer, blocks.Balancer)
    assert isinstance(loop_balancer.block, blocks.Estimator)


def test_plant_resumes_from_its_state(case3):
    rng = np.random.default_rng(3)
    forces = rng.standard_normal((120, case3.stepper().n_inputs)) * 50.0
    ref, twin = case3.stepper(), case3.stepper()
    ref.reset()
    twin.reset()
    for u in forces[:60]:
        ref.step(u)
        twin.step(np.zeros_like(u))                       # same sample, another state
    assert not np.array_equal(ref.state, twin.state)
    twin.set_state(ref.state)
    for u in forces[60:]:
        np.testing.assert_array_equal(twin.step(u), ref.step(u))
    with pytest.raises(ModelError, match="state must be"):
        twin.set_state(ref.state[:-1])


def samples(balanced, n, k0=0):
    rng = np.random.default_rng(k0)
    names = tuple(balanced.stepper().layout.names)
    T = balanced.sample_period_s
    for k in range(k0, k0 + n):
        t = k * T
        yield blocks.LoopSample(k, t, (30.0 * t) % TWO_PI, 30.0 + 5.0 * t, 5.0,
                                rng.standard_normal(len(names)) * 1e-3, names)


def test_balancer_resumes_from_its_state(balanced):
    bal = balanced.balancer()
    bal.reset()
    every = bal.every
    for s in samples(balanced, 5 * every):
        bal.step(s)
    snapshot = bal.state
    first = [bal.step(s) for s in samples(balanced, 5 * every, 5 * every)]
    first_estimate = bal.estimate()
    bal.set_state(snapshot)
    again = [bal.step(s) for s in samples(balanced, 5 * every, 5 * every)]
    assert again == first and bal.estimate() == first_estimate
    bal.reset()                                          # without the state: other numbers
    fresh = [bal.step(s) for s in samples(balanced, 5 * every, 5 * every)]
    assert fresh != first or bal.estimate() != first_estimate
    with pytest.raises(ModelError, match="state lacks"):
        bal.set_state({"block": snapshot["block"]})


def test_synchronous_generator_resumes_from_its_state():
    gen = SynchronousForceGenerator([10.0, 20.0], [[1.0 + 0j], [2.0 + 1j]], 1e-3, ["y1"],
                                    sample_period_s=1e-3)
    gen.step(0.3, 15.0)
    snapshot = gen.state
    out = gen.step(0.6, 25.0)                  # out of the table: zero force, not in range
    assert not gen.in_range and not np.any(out)
    gen.set_state(snapshot)
    assert gen.in_range and np.array_equal(gen.force_n, snapshot["force_n"])


def harmonic_block(speed=2 * np.pi * 11.3):
    """A 2-sensor, 2-actuator 1x + 2x controller on a fixed influence matrix, identifying it."""
    G = np.array([[1.0 + 0.5j, -0.3j], [0.2, 0.8 - 0.1j]])
    sched = InfluenceSchedule(np.array([0.5 * speed, 2 * speed]), (1, 2),
                              np.stack([np.stack([G, 0.5 * G])] * 2), ("a", "b"), ("x", "y"))
    return HarmonicController(sched, 1e-3, HarmonicSettings(gain=0.5, min_speed_hz=1,
                                                            identify=True, dither_n=0.1))


def test_harmonic_controller_resumes_from_its_state():
    speed, T = 2 * np.pi * 11.3, 1e-3
    rng = np.random.default_rng(5)
    signals = rng.standard_normal((1200, 2)) + np.cos(speed * T * np.arange(1200))[:, None]
    ref, twin = harmonic_block(), harmonic_block()
    for k in range(600):
        ref.step(list(signals[k]), speed * k * T % TWO_PI, speed)
        twin.step([0.0, 0.0], speed * k * T % TWO_PI, speed)       # same samples, other state
    assert ref.n_updates > 2 and not np.array_equal(ref.U, twin.U)
    twin.set_state(ref.state)
    for k in range(600, 1200):
        angle = speed * k * T % TWO_PI
        assert twin.step(list(signals[k]), angle, speed) == ref.step(list(signals[k]), angle,
                                                                      speed)
    assert np.array_equal(twin.U, ref.U) and np.array_equal(twin.D, ref.D)
    with pytest.raises(ModelError, match="does not fit"):
        twin.set_state({**ref.state, "U": ref.U[:1]})
