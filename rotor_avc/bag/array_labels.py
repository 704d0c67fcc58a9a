"""The element names of the blocks' labelled arrays (rotor_avc.bag.topics: ``time_s`` comes
first, then these names), each defined once from the names of what they count.

* ``balancer/command`` and ``balancer/estimate``: ``<excitation>_re``, ``<excitation>_im`` per
  excitation of the plant (the unbalance as complex amplitudes, Zhou & Shi 2001, Sec. 3);
* ``harmonic/forces``: ``<actuator>_f<axis>`` per actuator of the ``harmonic:`` section;
* ``harmonic/status``: ``mode``, ``updates``, ``E<h>_<sensor>`` per harmonic and sensor, then
  ``U<h>_<actuator>`` per harmonic and actuator (error and force phasor magnitudes),
  ``fallbacks``.
"""
from __future__ import annotations

from typing import Sequence

#: the first element of every labelled array: the sample time (the message has no header)
TIME_LABEL = "time_s"


def balancer_labels(excitations: Sequence[str]) -> list[str]:
    """``balancer/command`` and ``balancer/estimate`` after ``time_s``."""
    return [f"{name}_{part}" for name in excitations for part in ("re", "im")]


def harmonic_force_labels(actuator_axes: Sequence[tuple[str, str]]) -> list[str]:
    """``harmonic/forces`` after ``time_s``: one per ``(actuator id, axis)``."""
    return [f"{actuator}_f{axis}" for actuator, axis in actuator_axes]


def harmonic_error_labels(harmonics: Sequence[int], sensors: Sequence[str]) -> list[str]:
    """``E<h>_<sensor>``: the error phasor magnitudes of ``harmonic/status``."""
    return [f"E{h}_{s}" for h in harmonics for s in sensors]


def harmonic_phasor_labels(harmonics: Sequence[int], actuators: Sequence[str]) -> list[str]:
    """``U<h>_<actuator>``: the force phasor magnitudes of ``harmonic/status``."""
    return [f"U{h}_{a}" for h in harmonics for a in actuators]


def harmonic_status_labels(harmonics: Sequence[int], sensors: Sequence[str],
                           actuators: Sequence[str]) -> list[str]:
    """``harmonic/status`` after ``time_s``."""
    return (["mode", "updates"] + harmonic_error_labels(harmonics, sensors)
            + harmonic_phasor_labels(harmonics, actuators) + ["fallbacks"])
