"""What a vibration engineer looks at after a run-up, computed from a recorded run.

* **waterfall** (cascade): amplitude spectra of a channel over consecutive Hann windows
  (50 % overlap), each at the window's mean rotor speed; amplitude-corrected so that a sinusoid
  of amplitude ``a`` shows as ``a`` (``2 |X| / sum w``). Orders ``k`` lie on ``f = k n``;
* **1x Bode and polar plots**: the order-tracked 1x phasors
  (:mod:`rotor_avc.analysis.order_tracking`, the comparison's windows) with the continuous
  model's superposed response at the same speeds;
* **orbits** of the bearing housings (or any point with two transverse outputs) at chosen
  speeds: the displacement in their plane over the whole revolutions of the order-tracking window
  nearest to the speed -- raw (the recorded velocities or accelerations integrated, trend removed
  after each step) and 1x filtered (``Re{V / (j Omega)^k e^{j theta}}`` for a k-th derivative);
* **API 684 checks** (:mod:`rotor_avc.analysis.api684`) of each channel's 1x amplitude,
  measured and modelled.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.integrate
import scipy.signal

from ..errors import ModelError
from ..analysis.api684 import check_response
from ..closed_loop.loop import ClosedLoop
from .comparison import unbalance_models, _with_foot_accelerations, measured_one_x
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
    model = unbalance_models(run.scenario, {"continuous": loop}, 2 * np.pi * dense, 1.0, channels)
    half = np.pi * track.revolutions / track.speed_rad_s        # half a window's duration
    return OneXTrack(track.speed_hz, {c: track.phasors[c] for c in channels}, dense,
                     model["continuous"], {c: channel_unit(run, c) for c in channels}, method,
                     list(zip(track.time_s - half, track.time_s + half)))


def _outputs(run: RecordedRun) -> dict:
    return {o.name: o for o in _with_foot_accelerations(run.machine.plant).outputs}


def channel_unit(run: RecordedRun, channel: str) -> str:
    out = _outputs(run).get(channel)
    return out.unit if out is not None else ("N" if channel.startswith("actuator_") else "")


def housing_channels(run) -> list[str]:
    """The bearing-housing outputs of the run's plant (``bearing...``/``housing...``), else every
    plant output."""
    names = [o.name for o in run.machine.plant.outputs if o.name in run.channel_names]
    housing = [n for n in names if n.startswith(("bearing", "housing"))]
    return housing or names


#: transverse axes of an orbit, by the axes a point has: (horizontal, vertical) of the plot
ORBIT_AXES = (("y", "z"), ("x", "z"), ("x", "y"))


def orbit_pairs(run: RecordedRun, channels) -> list[tuple[str, str, str, int]]:
    """``(point, first channel, second channel, derivative order)`` of every point with two
    transverse outputs of the same kind among ``channels``: names ``<point>_<k><axis>`` or
    ``<point>_<axis>`` (``k`` = d, v, a), the axes per :data:`ORBIT_AXES` (for three axes,
    y and z)."""
    outs = _outputs(run)
    groups: dict[tuple[str, str, int], dict[str, str]] = {}
    for name in channels:
        out = outs.get(name)
        point, _, tag = name.rpartition("_")
        if out is None or not point or tag[-1:] not in "xyz" or len(tag) > 2:
            continue
        groups.setdefault((point, tag[:-1], out.order), {})[tag[-1]] = name
    pairs = []
    for (point, _, order), axes in sorted(groups.items()):
        for a, b in ORBIT_AXES:
            if a in axes and b in axes:
                pairs.append((point, axes[a], axes[b], order))
                break
    return pairs


@dataclass
class Orbit:
    point: str
    axes: tuple[str, str]      # channel names of the two plotted directions
    speed_hz: float
    raw_m: np.ndarray          # (K, 2) displacement over the window
    one_x_m: np.ndarray        # (360, 2) 1x-filtered ellipse
    key_m: np.ndarray          # (2,) 1x position at shaft angle 0 (the key phasor mark)


def _displacement(values, t, order: int) -> np.ndarray:
    """Integrate ``order`` times over the window, removing the trend after each step."""
    for _ in range(order):
        values = scipy.signal.detrend(scipy.integrate.cumulative_trapezoid(values, t, initial=0.0))
    return scipy.signal.detrend(values, type="constant") if order == 0 else values


def orbits(run: RecordedRun, track: OneXTrack, speeds_hz) -> list[Orbit]:
    """Housing orbits at the track windows nearest to ``speeds_hz`` (module docstring)."""
    out = []
    theta = np.linspace(0.0, 2 * np.pi, 360)
    for point, ch_a, ch_b, order in orbit_pairs(run, track.measured):
        for f in speeds_hz:
            i = int(np.argmin(np.abs(track.speed_hz - f)))
            t0, t1 = track.windows[i]
            sel = (run.time_s >= t0) & (run.time_s < t1)
            if np.count_nonzero(sel) < 4:
                continue
            t = run.time_s[sel]
            raw = np.column_stack([_displacement(run.channels[c][sel], t, order) for c in (ch_a, ch_b)])
            w = 2 * np.pi * track.speed_hz[i]
            disp = np.array([track.measured[ch_a][i], track.measured[ch_b][i]]) / (1j * w) ** order
            ellipse = np.real(disp[None, :] * np.exp(1j * theta)[:, None])
            out.append(Orbit(point, (ch_a, ch_b), float(track.speed_hz[i]), raw, ellipse, disp.real))
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
