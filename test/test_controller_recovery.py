"""Fault recovery of the controller block after a filter reset (rotor_avc.control.block).

The block's contract (module docstring): an output that is not finite resets the filter to rest
and answers the safe output (``hold``: the last force, ``zero``: 0 N) for that sample only; the
next sample steps the filter from rest. The independent reference is a fresh block -- built
from the same coefficients, never faulted -- fed the signal from the sample after the reset:
from there on the recovered block's forces must equal the fresh block's bit for bit, so a block
that stays on its safe output, keeps a non-finite state or forgets the held force fails here.
"""
import math

import numpy as np
import pytest

from rotor_avc.control.block import DigitalController
from rotor_avc.control.discretize import DiscreteTf

T = 1e-3


def signal(n, seed=3):
    """A 7 Hz tone with noise: every sample differs, so a held force is told from a live one."""
    k = np.arange(n)
    noise = np.random.default_rng(seed).standard_normal(n)
    return (np.sin(2 * np.pi * 7.0 * k * T) + 0.1 * noise).tolist()


def unstable_tf():
    """G_d = (1 - 0.5 z^-1) / (1 - 1.5 z^-1): a pole at z = 1.5, the output grows 1.5^k and
    overflows double precision (1.8e308) after about 1750 samples."""
    return DiscreteTf([1.0, -0.5], [1.0, -1.5], T)


@pytest.mark.parametrize("policy", ["hold", "zero"])
@pytest.mark.parametrize("delay", [0, 2])
def test_after_a_filter_reset_the_block_equals_a_fresh_one(policy, delay):
    x = signal(6000)
    blk = DigitalController(unstable_tf(), delay_samples=delay, safe_output=policy)
    forces, reset_at = [], []
    for k, v in enumerate(x):
        before = blk.faults["filter_reset"]
        forces.append(blk.step(v))
        if blk.faults["filter_reset"] > before:
            reset_at.append(k)
    # 1.5^k passes 1.8e308 after ln(1.8e308 / 2) / ln 1.5 ~ 1748 samples: at least 3 resets
    assert len(reset_at) >= 3 and blk.faults == {"implausible": 0, "filter_reset": len(reset_at)}
    assert 1600 < reset_at[0] < 1900
    for i, k in enumerate(reset_at):
        safe = forces[k - 1] if policy == "hold" else 0.0
        assert forces[k] == safe                          # the reset sample: the safe output
        end = reset_at[i + 1] if i + 1 < len(reset_at) else len(x)
        fresh = DigitalController(unstable_tf(), delay_samples=delay, safe_output=policy)
        expected = [fresh.step(v) for v in x[k + 1:end]]
        # one sample later the block is back on its normal output, exactly a fresh block's
        assert forces[k + 1:end] == expected
        assert all(math.isfinite(f) for f in forces[k + 1:end])
        assert forces[k + 1 + delay] != safe                # the delay line restarts at rest
    assert all(math.isfinite(z) for z in blk.filter.state)


def test_a_reset_keeps_the_held_force_for_a_following_rejected_sample():
    """A stable G_d = 2 (1 - 0.9 z^-1)/(1 - 0.5 z^-1) driven with 1.5e308 (inside a block
    built without a measurement limit) overflows to inf: filter reset, the held force answered.
    A NaN at the next sample is rejected and must answer that same held force (the force before
    the fault), and from the sample after the block equals a fresh block on the rest."""
    tf = DiscreteTf([2.0, -1.8], [1.0, -0.5], T)
    x = signal(400)
    k_fault = 200
    blk = DigitalController(tf)
    got = []
    for k, v in enumerate(x):
        got.append(blk.step(1.5e308 if k == k_fault else math.nan if k == k_fault + 1 else v))
    assert blk.faults == {"implausible": 1, "filter_reset": 1}
    held = got[k_fault - 1]
    assert held != 0.0 and got[k_fault] == held and got[k_fault + 1] == held
    fresh = DigitalController(tf)
    assert got[k_fault + 2:] == [fresh.step(v) for v in x[k_fault + 2:]]
    # before the fault: the block is the fresh block too (the fault changed nothing earlier)
    ref = DigitalController(tf)
    assert got[:k_fault] == [ref.step(v) for v in x[:k_fault]]


def test_zero_policy_after_a_reset_answers_zero_for_a_following_rejected_sample():
    tf = DiscreteTf([2.0, -1.8], [1.0, -0.5], T)
    blk = DigitalController(tf, safe_output="zero")
    for v in signal(50):
        blk.step(v)
    assert blk.step(1.5e308) == 0.0 and blk.step(math.inf) == 0.0
    assert blk.faults == {"implausible": 1, "filter_reset": 1}
    assert blk.step(0.25) == -2.0 * 0.25                  # from rest: -b0 x
