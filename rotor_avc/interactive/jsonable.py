"""Report data as JSON: numpy values to Python, NaN and inf to null, complex to {re, im}."""
from __future__ import annotations

import numpy as np


def jsonable(value):
    """JSON-safe: numpy -> Python, NaN/inf -> None."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, complex):
        return {"re": jsonable(value.real), "im": jsonable(value.imag)}
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value
