"""The block contract (rotor_avc.blocks): every block of the loop implements its protocol, and
resuming from a ``state`` snapshot repeats the same outputs bit for bit."""
import numpy as np
import pytest

from rotor_avc import blocks
from rotor_avc.control.synchronous import SynchronousForceGenerator
from rotor_avc.errors import ModelError
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
