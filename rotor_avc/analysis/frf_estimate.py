"""Broadband FRF estimation from input/output records: H1, H2 and coherence (Welch averaging).

With averaged (Welch) auto and cross spectra ``Gxx = E[X* X]``, ``Gyy = E[Y* Y]`` and
``Gxy = E[X* Y]`` (``scipy.signal.csd(x, y)`` computes ``conj(X) Y``)::

    H1 = Gxy / Gxx            (unbiased by noise on the output y)
    H2 = Gyy / Gyx = Gyy / conj(Gxy)   (unbiased by noise on the input x)
    gamma^2 = |Gxy|^2 / (Gxx Gyy) = H1 / H2,   0 <= gamma^2 <= 1

The sign convention is that of ``scipy.signal.freqz``: a system ``y = h * x`` has
``H(f) = sum_k h[k] e^{-j 2 pi f k / fs}`` (a pure delay of d samples has phase
``-2 pi f d / fs``), which the tests check against ``scipy.signal.lfilter``. Where the coherence
is near 1 both estimates agree with the true FRF; where it drops (noise, nonlinearity, leakage at
sharp resonances within one frequency bin) H1 reads low and H2 high. The result states what it
was computed with: window, segment length, overlap, number of averages, resolution.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

from ..errors import ModelError


@dataclass
class FrfEstimate:
    """H1/H2 estimates (``(F,)`` or ``(F, m)`` for m outputs) and the settings behind them."""

    freq_hz: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    coherence: np.ndarray
    fs_hz: float
    window: str
    nperseg: int
    noverlap: int
    averages: int
    detrend: str

    @property
    def resolution_hz(self) -> float:
        return self.fs_hz / self.nperseg

    def settings(self) -> dict:
        """What a report states next to the estimate."""
        return {"window": self.window, "segment_length": self.nperseg,
                "overlap": self.noverlap, "averages": self.averages, "fs_hz": self.fs_hz,
                "resolution_hz": self.resolution_hz, "detrend": self.detrend}


def estimate_frf(x, y, fs_hz: float, *, nperseg: int | None = None,
                 noverlap: int | None = None, window: str = "hann",
                 detrend: str = "constant") -> FrfEstimate:
    """H1, H2 and coherence from input ``x`` (N,) to outputs ``y`` (N,) or (N, m).

    ``nperseg`` defaults to the power of two giving about 16 averages at 50 % overlap (at least
    256 samples); ``noverlap`` to ``nperseg // 2``.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.ndim != 1 or y.shape[:1] != x.shape or y.ndim > 2:
        raise ModelError(f"FRF estimate: x must be (N,) and y (N,) or (N, m); got {x.shape}, "
                         f"{y.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ModelError("FRF estimate: the records contain NaN or inf")
    if not np.isfinite(fs_hz) or fs_hz <= 0:
        raise ModelError(f"FRF estimate: sample rate must be > 0 Hz, got {fs_hz}")
    n = x.size
    if nperseg is None:
        nperseg = max(256, 2 ** int(np.floor(np.log2(max(n / 8.5, 1)))))
    if noverlap is None:
        noverlap = nperseg // 2
    if not 8 <= nperseg <= n or not 0 <= noverlap < nperseg:
        raise ModelError(f"FRF estimate: need 8 <= segment length <= {n} samples and "
                         f"0 <= overlap < segment length (got {nperseg}, {noverlap})")
    if not np.any(x - x.mean()):
        raise ModelError("FRF estimate: the input record is constant (no excitation)")
    f, gxx, gyy, gxy = _spectra(x, y, fs_hz, nperseg, noverlap, window, detrend)
    averages = (n - noverlap) // (nperseg - noverlap)
    return _estimate(f, gxx, gyy, gxy, fs_hz, window, nperseg, noverlap, averages, detrend)


def _spectra(x, y, fs_hz, nperseg, noverlap, window, detrend):
    """``(f, Gxx, Gyy, Gxy)`` by Welch averaging (``Gxx`` shaped to broadcast against y's)."""
    opts = dict(fs=fs_hz, window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend,
                axis=0)
    xx = x[:, None] if y.ndim == 2 else x
    f, gxx = scipy.signal.welch(x, **opts)
    _, gyy = scipy.signal.welch(y, **opts)
    _, gxy = scipy.signal.csd(xx, y, **opts)
    return f, (gxx[:, None] if y.ndim == 2 else gxx), gyy, gxy


def _estimate(f, gxx, gyy, gxy, fs_hz, window, nperseg, noverlap, averages,
              detrend) -> FrfEstimate:
    with np.errstate(divide="ignore", invalid="ignore"):
        h1 = gxy / gxx
        h2 = gyy / np.conj(gxy)
        coherence = np.abs(gxy) ** 2 / (gxx * gyy)
    return FrfEstimate(f, h1, h2, np.nan_to_num(coherence), float(fs_hz), str(window),
                       int(nperseg), int(noverlap), int(averages), str(detrend))


def h1_random_error(coherence, averages: int) -> np.ndarray:
    """Normalised random error of the H1 magnitude (Bendat & Piersol, Random Data, eq. 9.73):
    ``eps = sqrt(1 - g^2) / (|g| sqrt(2 n_d))`` with ``g^2`` the coherence and ``n_d`` the
    number of averages; the +-1 sigma band is ``|H1| (1 +- eps)``. Infinite where the coherence
    is 0."""
    g2 = np.clip(np.asarray(coherence, dtype=float), 0.0, 1.0)
    if averages < 1:
        raise ModelError(f"FRF random error: averages must be >= 1 (got {averages})")
    with np.errstate(divide="ignore"):
        return np.sqrt(1.0 - g2) / (np.sqrt(g2) * np.sqrt(2.0 * averages))


#: the shortest Welch segment of a gapped record (samples) and the fewest averages over it
MIN_SEGMENT, MIN_AVERAGES = 256, 2
#: averages a gapped record's segment length aims at (as :func:`estimate_frf`'s default)
TARGET_AVERAGES = 16


def contiguous_runs(time_s, period_s: float) -> list[tuple[int, int]]:
    """``[a, b)`` ranges of samples ``period_s`` apart (a longer step is a gap)."""
    t = np.asarray(time_s, dtype=float)
    cuts = np.flatnonzero(np.diff(t) > 1.5 * period_s) + 1
    edges = np.concatenate([[0], cuts, [t.size]])
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def welch_averages(lengths, nperseg: int) -> int:
    """Welch segments (50 % overlap) that fit in runs of the given lengths."""
    step = nperseg - nperseg // 2
    return int(sum((n - nperseg) // step + 1 for n in lengths if n >= nperseg))


def gapped_segment_length(lengths) -> int | None:
    """The power-of-two segment length for runs of these lengths: the one giving about
    :data:`TARGET_AVERAGES` averages over all of them, shortened while fewer than half of that
    fit into the runs, not below :data:`MIN_SEGMENT`; None when even that gives fewer than
    :data:`MIN_AVERAGES`."""
    total = sum(lengths)
    nperseg = max(MIN_SEGMENT, 2 ** int(np.floor(np.log2(max(total / 8.5, 1)))))
    while nperseg > MIN_SEGMENT and welch_averages(lengths, nperseg) < TARGET_AVERAGES // 2:
        nperseg //= 2
    return nperseg if welch_averages(lengths, nperseg) >= MIN_AVERAGES else None


def estimate_frf_gapped(x, y, fs_hz: float, runs, nperseg: int) -> FrfEstimate:
    """H1, H2 and coherence of a record with gaps: Welch averaging over the segments that lie
    wholly inside the contiguous ``runs`` (``[a, b)`` sample ranges), each run's spectra weighted
    by its number of segments, so that no segment spans a gap (where the spectra of the
    interpolated or missing samples would bias the estimate). ``averages`` counts the segments
    of all runs (the random error's ``n_d``)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    used = [(a, b) for a, b in runs if b - a >= nperseg]
    counts = [welch_averages([b - a], nperseg) for a, b in used]
    if sum(counts) < MIN_AVERAGES:
        raise ModelError(f"FRF estimate: {sum(counts)} Welch segments of {nperseg} samples fit "
                         f"between the record's gaps; at least {MIN_AVERAGES} are needed")
    noverlap = nperseg // 2
    sums = None
    for (a, b), count in zip(used, counts):
        f, *spectra = _spectra(x[a:b], y[a:b], fs_hz, nperseg, noverlap, "hann", "constant")
        sums = ([count * s for s in spectra] if sums is None
                else [acc + count * s for acc, s in zip(sums, spectra)])
    gxx, gyy, gxy = (s / sum(counts) for s in sums)
    return _estimate(f, gxx, gyy, gxy, fs_hz, "hann", nperseg, noverlap, sum(counts), "constant")
