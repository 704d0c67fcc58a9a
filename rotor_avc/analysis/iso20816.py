"""ISO 20816-3 evaluation zones of the broadband vibration velocity of bearing housings.

ISO 20816-3:2022 (Mechanical vibration -- Measurement and evaluation of machine vibration --
Part 3: Industrial machines with a power rating above 15 kW and operating speeds between
120 r/min and 30 000 r/min), Annex A, Tables A.1 and A.2; the velocity boundaries are those of
ISO 10816-3:2009, Annex A, Tables A.1 and A.2. Zone boundaries, r.m.s. velocity in mm/s:

================================================  =======  ===  ===  =====
group (Table)                                      support  A/B  B/C  C/D
================================================  =======  ===  ===  =====
1: large machines, 300 kW .. 50 MW, shaft          rigid    2.3  4.5  7.1
height H >= 315 mm (Table A.1)                     flexible 3.5  7.1  11.0
2: medium machines, 15 kW .. 300 kW,               rigid    1.4  2.8  4.5
160 mm <= H < 315 mm (Table A.2)                   flexible 2.3  4.5  7.1
================================================  =======  ===  ===  =====

Evaluation zones (the standards' clause of that title): A newly commissioned machines;
B unrestricted long-term operation; C not for long-term continuous operation; D severe enough to
cause damage. Each boundary is the upper limit of the zone below it: a value equal to a boundary
lies in the lower zone (:func:`zone`).

Support (the standards' machine support classification): rigid in a measuring direction when
the lowest natural frequency of the combined machine and support in that direction is at least
25 % above the main excitation frequency (in most cases the rotational frequency), flexible
otherwise -- declared in the configuration (``analysis.iso20816.support``).

Measured quantity (the standards' measurement equipment clause): the broadband r.m.s.
velocity over 10 .. 1000 Hz for machines running above 600 r/min, 2 .. 1000 Hz for 120 ..
600 r/min (:func:`band_hz`). :func:`band_rms` band-passes in the frequency domain (Parseval over
the bins of the band of one record) and turns a displacement or an acceleration into velocity
there: ``V = (j w)^(1 - k) Y`` for the ``k``-th derivative ``Y`` (``V = A / (j w)`` for an
acceleration); :class:`WindowMax` is the largest such r.m.s. over windows of a record read in
pieces.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError

#: zone boundaries (A/B, B/C, C/D) in mm/s r.m.s. by (group, support): Tables A.1 and A.2
ZONE_BOUNDARIES_MM_S = {(1, "rigid"): (2.3, 4.5, 7.1), (1, "flexible"): (3.5, 7.1, 11.0),
                        (2, "rigid"): (1.4, 2.8, 4.5), (2, "flexible"): (2.3, 4.5, 7.1)}
ZONES = ("A", "B", "C", "D")
#: upper edge of the measurement band [Hz]
BAND_TOP_HZ = 1000.0
#: at and below this speed [r/min] the band starts at 2 Hz, above it at 10 Hz
SLOW_MACHINE_RPM = 600.0
#: a piece shorter than one window counts whole from this many samples on
MIN_PIECE_SAMPLES = 16


def zone(rms_mm_s: float, group: int, support: str) -> str:
    """The zone ``A`` .. ``D`` of an r.m.s. velocity in mm/s (boundary values: the lower zone)."""
    try:
        bounds = ZONE_BOUNDARIES_MM_S[(group, support)]
    except KeyError:
        raise ModelError(f"ISO 20816-3 has no zones for group {group!r}, support {support!r}: "
                         "group 1 or 2, support rigid or flexible") from None
    return ZONES[int(np.searchsorted(bounds, rms_mm_s, side="left"))]


def band_hz(max_speed_hz: float, sample_rate_hz: float) -> tuple[float, float]:
    """The measurement band of a machine running up to ``max_speed_hz``: from 2 Hz (at most
    600 r/min) or 10 Hz to 1000 Hz, the top lowered to the Nyquist frequency of a slower rate."""
    low = 2.0 if max_speed_hz * 60.0 <= SLOW_MACHINE_RPM else 10.0
    return low, min(BAND_TOP_HZ, 0.5 * sample_rate_hz)


def band_rms(values, sample_period_s: float, order: int, band: tuple[float, float]) -> float:
    """R.m.s. velocity within ``band`` [Hz] of one record of the ``order``-th time derivative
    of a displacement (0 displacement, 1 velocity, 2 acceleration; SI units -> m/s), by the
    frequency-domain band-pass and conversion of the module docstring."""
    values = np.asarray(values, dtype=float)
    n = values.size
    freq = np.fft.rfftfreq(n, sample_period_s)
    spectrum = np.fft.rfft(values)
    sel = (freq >= band[0]) & (freq <= band[1]) & (freq > 0)
    velocity = spectrum[sel] * (2j * np.pi * freq[sel]) ** (1 - order)
    weight = np.where(2 * np.flatnonzero(sel) == n, 1.0, 2.0)       # the Nyquist bin once
    return float(np.sqrt(np.sum(weight * np.abs(velocity) ** 2)) / n)


class WindowMax:
    """The largest :func:`band_rms` over windows of ``window_samples`` (hop half a window) of a
    record given in consecutive pieces (:meth:`add`); :meth:`end` closes a contiguous stretch
    (a dwell), which, shorter than one window, counts as one window of its length."""

    def __init__(self, window_samples: int, sample_period_s: float, order: int,
                 band: tuple[float, float]):
        self.n, self.T, self.order, self.band = window_samples, sample_period_s, order, band
        self.max_rms = 0.0
        self.windows = 0
        self._buffer = np.zeros(0)
        self._in_stretch = 0

    def _take(self, values) -> None:
        self.max_rms = max(self.max_rms, band_rms(values, self.T, self.order, self.band))
        self.windows += 1
        self._in_stretch += 1

    def add(self, values) -> None:
        buf = np.concatenate([self._buffer, np.asarray(values, dtype=float)])
        start = 0
        while start + self.n <= buf.size:
            self._take(buf[start:start + self.n])
            start += self.n // 2
        self._buffer = buf[start:]

    def end(self) -> None:
        if not self._in_stretch and self._buffer.size >= MIN_PIECE_SAMPLES:
            self._take(self._buffer)
        self._buffer, self._in_stretch = np.zeros(0), 0
