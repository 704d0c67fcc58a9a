"""A symmetric-logarithmic axis for plotly, which has none (matplotlib's ``symlog`` scale,
``matplotlib.scale.SymmetricalLogScale``, in the smooth form of Webber 2013, "A bi-symmetric
log transformation for wide-range data", Meas. Sci. Technol. 24 027001):

    u = sign(x) log10(1 + |x| / x0)

linear within about ``x0`` of zero, logarithmic beyond, so that values from ``x0`` to many
decades away share one axis (the real parts of a machine's poles: structural modes at -0.1 to
-10 1/s beside controller poles at -1000 1/s). The plot draws ``u``; the ticks are labelled with
the real values at 0 and at +-x0 10^k.
"""
from __future__ import annotations

import math

import numpy as np


def symlog(values, x0: float) -> np.ndarray:
    """``sign(x) log10(1 + |x| / x0)`` of ``values`` (x0 > 0)."""
    x = np.asarray(values, float)
    return np.sign(x) * np.log10(1.0 + np.abs(x) / x0)


def symlog_axis(values, x0: float, title: str) -> dict:
    """A plotly axis (layout ``xaxis``/``yaxis``) for :func:`symlog` of ``values``: ticks at 0
    and at every ``x0 10^k`` up to the largest ``|x|`` on the side(s) the values reach, labelled
    with those real values; ``title`` with ``x0`` appended."""
    x = np.asarray(values, float)
    x = x[np.isfinite(x)]
    top = max(float(np.abs(x).max()) if x.size else x0, x0)
    decades = [x0 * 10.0 ** k for k in range(int(math.ceil(math.log10(top / x0))) + 1)]
    ticks = [0.0] + decades
    if x.size and x.min() < 0:
        ticks = [-d for d in reversed(decades)] + ticks
    if x.size and x.max() <= 0:
        ticks = [t for t in ticks if t <= 0]
    return {"tickmode": "array", "tickvals": symlog(ticks, x0).tolist(),
            "ticktext": [f"{t:g}" for t in ticks], "zeroline": True,
            "title": {"text": f"{title} (symmetric log axis: sign(x) log10(1 + |x|/x0), "
                              f"x0 = {x0:g})"}}
