"""What a page holds of a figure's data: smooth curves thinned to a stated drawing tolerance,
numbers to :data:`DIGITS` significant digits, and distinct colours for more traces than the
palette has (the CSV and JSON files beside a page hold the data in full).

Thinning keeps, of a line trace, few points such that the straight segments between them stay
within the tolerance at every point left out (greedy segments, each as long as the tolerance
allows): over a strictly increasing x, a magnitude within :data:`MAGNITUDE_TOL_DB` in dB and
:data:`MAGNITUDE_TOL_REL` relative in SI units (the page draws either), any other quantity
within :data:`RANGE_TOL` of the trace's range; along any other curve (a polar plot, an orbit),
x and y each within :data:`RANGE_TOL` of their range. The other per-point values of a trace
(hover text, colours) keep the points kept. Markers are never thinned.
"""
from __future__ import annotations

import numpy as np

#: significant digits of the numbers in a page (the hover shows 4 or 5)
DIGITS = 6
#: a thinned magnitude curve stays this close to the computed one, in dB ...
MAGNITUDE_TOL_DB = 0.02
#: ... and relative in SI units (below a pixel of a 400-pixel plot whose axis reaches the value)
MAGNITUDE_TOL_REL = 2e-3
#: any other thinned curve: this fraction of its range
RANGE_TOL = 1e-3
#: shorter curves are kept whole
MIN_THINNED = 50
#: plotly's palette: more traces without a colour than this get colours along :data:`SEQUENTIAL`
PALETTE_SIZE = 10
#: (colorscale, first, last) of the sequential colours (the light end of Viridis left out)
SEQUENTIAL = ("Viridis", 0.0, 0.88)


def _segment_fits(x, columns, i: int, j: int) -> bool:
    """Whether the chord from point i to point j stays within each column's tolerance."""
    xs = x[i:j + 1]
    frac = (xs - xs[0]) / (xs[-1] - xs[0])
    for values, tol in columns:
        ys = values[i:j + 1]
        if np.any(np.abs(ys[0] + (ys[-1] - ys[0]) * frac - ys) > tol[i:j + 1]):
            return False
    return True


def thin_indices(x, columns) -> np.ndarray:
    """Indices of the points kept of a curve over strictly increasing ``x``: ``columns`` are
    ``(values, tolerance per point)``; between consecutive kept points the straight line of
    every column is within its tolerance at each point left out."""
    n, keep, i = len(x), [0], 0
    while i < n - 1:
        good, step = i + 1, 1                     # a neighbour always fits
        while good + step <= n - 1 and _segment_fits(x, columns, i, good + step):
            good, step = good + step, step * 2
        bad = min(good + step, n)
        while bad - good > 1:                     # the longest fitting end between good and bad
            mid = (good + bad) // 2
            good, bad = (mid, bad) if _segment_fits(x, columns, i, mid) else (good, mid)
        keep.append(good)
        i = good
    return np.asarray(keep)


def _take(trace: dict, keep: np.ndarray, n: int) -> dict:
    """``trace`` with every per-point array (x, y, text, customdata, marker colours, ...)
    reduced to the points ``keep``."""
    def take(d):
        return {k: (np.asarray(v)[keep] if isinstance(v, (list, np.ndarray)) and len(v) == n
                    else take(v) if isinstance(v, dict) else v) for k, v in d.items()}
    return take(trace)


def thinned(trace: dict, magnitude: bool) -> dict:
    """``trace`` with its curve thinned (see the module docstring) when it is a line of finite
    values: over x when x increases strictly, else along the curve (a polar plot, an orbit:
    x and y each within :data:`RANGE_TOL` of their range); else unchanged."""
    if trace.get("type", "scatter") != "scatter" or trace.get("mode") != "lines":
        return trace
    try:
        x, y = np.asarray(trace.get("x"), float), np.asarray(trace.get("y"), float)
    except (TypeError, ValueError):
        return trace
    if (x.ndim != 1 or x.shape != y.shape or x.size < MIN_THINNED
            or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y)))):
        return trace

    def within_range(v):
        return v, np.full(v.size, RANGE_TOL * max(float(np.ptp(v)), 1e-300))

    if not np.all(np.diff(x) > 0):
        return _take(trace, thin_indices(np.arange(x.size, dtype=float),
                                         [within_range(x), within_range(y)]), x.size)
    if magnitude and np.all(y > 0):
        columns = [(20 * np.log10(y), np.full(y.size, MAGNITUDE_TOL_DB)),
                   (y, MAGNITUDE_TOL_REL * y)]
    else:
        columns = [within_range(y)]
    return _take(trace, thin_indices(x, columns), x.size)


def rounded(value, digits: int = DIGITS):
    """JSON-ready ``value`` (lists, dicts, numbers) with every float to ``digits`` significant
    digits."""
    if isinstance(value, float):
        return float(f"{value:.{digits}g}")
    if isinstance(value, list):
        return [rounded(v, digits) for v in value]
    if isinstance(value, dict):
        return {k: rounded(v, digits) for k, v in value.items()}
    return value


def _has_colour(trace: dict) -> bool:
    return any(isinstance(trace.get(part), dict) and "color" in trace[part]
               for part in ("line", "marker"))


def colour_scale(name: str) -> list:
    """The ``plotly`` package's colour scale ``name`` (e.g. ``"Magma"``, as matplotlib's) as the
    list of ``[position, colour]`` plotly.js takes: plotly.js itself knows fewer names."""
    from plotly.colors import get_colorscale
    return get_colorscale(name)


def sequential_colours(n: int) -> list[str]:
    """``n`` distinct colours in order along :data:`SEQUENTIAL`."""
    from plotly.colors import sample_colorscale
    scale, first, last = SEQUENTIAL
    return sample_colorscale(scale, list(np.linspace(first, last, n)))


def coloured(traces: list[dict]) -> list[dict]:
    """``traces`` with, when more than :data:`PALETTE_SIZE` of them have no colour of their own,
    each of those a distinct colour along :data:`SEQUENTIAL` (in order), instead of plotly's
    repeating palette."""
    free = [k for k, t in enumerate(traces) if t.get("type", "scatter") in ("scatter", "bar")
            and not _has_colour(t)]
    if len(free) <= PALETTE_SIZE:
        return traces
    out = list(traces)
    for k, colour in zip(free, sequential_colours(len(free))):
        t = out[k]
        out[k] = {**t, "marker": {**t.get("marker", {}), "color": colour}}
        if t.get("type", "scatter") == "scatter":
            out[k]["line"] = {**t.get("line", {}), "color": colour}
    return out
