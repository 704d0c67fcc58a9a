"""What a vibration engineer looks at after a run-up, computed from a recorded run.

* **waterfall** (cascade): amplitude spectra of a channel over consecutive Hann windows
  (50 % overlap), each at the window's mean rotor speed; amplitude-corrected so that a sinusoid
  of amplitude ``a`` shows as ``a`` (``2 |X| / sum w``). Orders ``k`` lie on ``f = k n``;
* **1x Bode and polar plots**: the order-tracked 1x phasors (:mod:`.order_tracking`, the
  comparison's windows) with the continuous model's superposed response at the same speeds;
* **orbits** of the bearing housing at chosen speeds: the displacement in the (y, z) plane over
  the whole revolutions of the order-tracking window nearest to the speed -- raw (the recorded
  velocities integrated, trend removed) and 1x filtered (``Re{V / (j Omega) e^{j theta}}``);
* **API 684 checks** (:mod:`.api684`) of each channel's 1x amplitude, measured and modelled.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.integrate
import scipy.signal

from ..errors import ModelError
from .api684 import check_response
from .closed_loop import ClosedLoop
from .comparison import _unbalance_models, _with_foot_accelerations, measured_one_x
from .recorded_run import RecordedRun


@dataclass
class Waterfall:
    channel: str
    speed_hz: np.ndarray          # (W,) mean speed per window
    freq_hz: np.ndarray           # (F,)
    amplitude: np.ndarray         # (W, F), channel unit


def waterfall(channel: str, values, speed_rad_s, sample_period_s: float,
              window_s: float = 1.0) -> Waterfall:
    """Amplitude spectra of one channel's samples (see the module docstring)."""
    values = np.asarray(values, dtype=float)
    n = int(2 ** np.round(np.log2(max(window_s / sample_period_s, 16))))
    if n > values.size:
        raise ModelError(f"the record ({values.size} samples) is shorter than one waterfall "
                         f"window ({n} samples) -- lower the window length")
    win = scipy.signal.get_window("hann", n)
    starts = np.arange(0, values.size - n + 1, n // 2)
    segments = np.stack([values[i:i + n] - values[i:i + n].mean() for i in starts])
    amp = 2.0 * np.abs(np.fft.rfft(segments * win, axis=1)) / win.sum()
    speed = np.array([np.mean(speed_rad_s[i:i + n]) for i in starts]) / (2 * np.pi)
    return Waterfall(channel, speed, np.fft.rfftfreq(n, sample_period_s), amp)


def run_waterfall(run: RecordedRun, channel: str, window_s: float = 1.0) -> Waterfall:
    """:func:`waterfall` of a channel of a recorded run."""
    if channel not in run.channels:
        raise ModelError(f"no channel {channel!r} in the run; channels: {', '.join(run.channels)}")
    return waterfall(channel, run.channels[channel], run.speed_rad_s, run.sample_period_s, window_s)


@dataclass
class OneXTrack:
    """Measured 1x phasors per order-tracking window and the modelled ones on a dense grid over
    the same speeds (absolute: the run's superposed excitations)."""

    speed_hz: np.ndarray
    measured: dict[str, np.ndarray]
    model_speed_hz: np.ndarray
    model: dict[str, np.ndarray]
    units: dict[str, str]
    method: str
    windows: list[tuple[float, float]]     # (start, end) time of each window


def one_x_track(run: RecordedRun, channels: list[str], n_model: int = 2000) -> OneXTrack:
    """1x of ``channels`` over the run, with the continuous model over the same speed range."""
    track, method, _ = measured_one_x(run, 1.0)
    missing = [c for c in channels if c not in track.phasors]
    if missing:
        raise ModelError(f"no 1x track of {', '.join(missing)}; channels: {', '.join(track.phasors)}")
    machine = run.machine
    loop = ClosedLoop(_with_foot_accelerations(machine.plant), machine.controllers)
    dense = np.linspace(track.speed_hz.min(), track.speed_hz.max(), n_model)
    model = _unbalance_models(run, {"continuous": loop}, 2 * np.pi * dense, 1.0, channels)
    half = track.samples * run.sample_period_s / 2
    return OneXTrack(track.speed_hz, {c: track.phasors[c] for c in channels}, dense,
                     model["continuous"], {c: channel_unit(run, c) for c in channels}, method,
                     list(zip(track.time_s - half, track.time_s + half)))


def channel_unit(run: RecordedRun, channel: str) -> str:
    plant = _with_foot_accelerations(run.machine.plant)
    for out in plant.outputs:
        if out.name == channel:
            return out.unit
    return "N" if channel.startswith("actuator_") else ""


def orbit_pairs(channels) -> list[tuple[str, str, str]]:
    """``(point, y channel, z channel)`` of every bearing housing with both velocities."""
    names = set(channels)
    return [(c[:-3], c[:-1] + "y", c) for c in sorted(names)
            if c.startswith("bearing_") and c.endswith("_vz") and c[:-1] + "y" in names]


@dataclass
class Orbit:
    point: str
    speed_hz: float
    raw_m: np.ndarray          # (K, 2) displacement y, z over the window
    one_x_m: np.ndarray        # (360, 2) 1x-filtered ellipse
    key_m: np.ndarray          # (2,) 1x position at shaft angle 0 (the key phasor mark)


def orbits(run: RecordedRun, track: OneXTrack, speeds_hz) -> list[Orbit]:
    """Housing orbits at the track windows nearest to ``speeds_hz`` (module docstring)."""
    out = []
    theta = np.linspace(0.0, 2 * np.pi, 360)
    for point, ch_y, ch_z in orbit_pairs(track.measured):
        for f in speeds_hz:
            i = int(np.argmin(np.abs(track.speed_hz - f)))
            t0, t1 = track.windows[i]
            sel = (run.time_s >= t0) & (run.time_s < t1)
            if np.count_nonzero(sel) < 4:
                continue
            t = run.time_s[sel]
            raw = np.column_stack([
                scipy.signal.detrend(scipy.integrate.cumulative_trapezoid(run.channels[c][sel], t,
                                                                          initial=0.0))
                for c in (ch_y, ch_z)])
            w = 2 * np.pi * track.speed_hz[i]
            disp = np.array([track.measured[ch_y][i], track.measured[ch_z][i]]) / (1j * w)
            ellipse = np.real(disp[None, :] * np.exp(1j * theta)[:, None])
            out.append(Orbit(point, float(track.speed_hz[i]), raw, ellipse, disp.real))
    return out


def api684_tables(track: OneXTrack, operating_hz) -> dict:
    """Per channel, the API 684 checks of the measured 1x and of the model over the run's speeds
    -> ``{channel: {"measured": [...], "model": [...]}}``."""
    order = np.argsort(track.speed_hz)
    speeds = track.speed_hz[order]
    keep = np.concatenate([[True], np.diff(speeds) > 0])
    return {c: {"measured": check_response(speeds[keep], np.abs(track.measured[c][order])[keep],
                                           operating_hz),
                "model": check_response(track.model_speed_hz, np.abs(track.model[c]), operating_hz)}
            for c in track.measured}
