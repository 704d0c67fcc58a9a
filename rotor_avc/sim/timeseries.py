"""The result of a run: sampled signals over time, and their save format.

Row ``k`` is sample ``t_k = k T`` of the sampling contract (DESIGN.md section 3):

* ``time_s``, ``speed_rad_s`` (Omega), ``accel_rad_s2`` (Omega'), ``angle_rad`` (shaft angle
  theta, unwrapped) at ``t_k``;
* channels ``foot_<id>_{d,v,a}<axis>`` -- the measured foot displacement (m), velocity (m/s)
  and acceleration (m/s^2, with the force feed-through of ``u_{k-1}``) at ``t_k``;
* channels named like ``plant.outputs`` (e.g. ``bearing_D_vz``, m/s) at ``t_k``;
* channels ``actuator_<id>_f<axis>`` -- the force (N) the controller answered sample ``k``
  with, held over ``[t_k, t_k+1)``; zero at points without a controller;
* with a balancer: ``balancer_<excitation>_re`` / ``_im``, the correction applied from ``t_k+1``;
* with a test force (``simulation.test_signal``): ``test_signal_<id>_f<axis>``, the force (N)
  added to the actuator's force over ``[t_k, t_k+1)`` (rotor_avc.sim.broadband).

1x phasors (order tracking) come from :mod:`rotor_avc.analysis.order_tracking`.

Save format (``.npz``, read by :meth:`TimeSeries.load` or plain ``numpy.load``): arrays
``time_s``, ``speed_rad_s``, ``accel_rad_s2``, ``angle_rad``, one array ``ch:<channel>`` per
channel, and ``metadata_json``, a JSON string with ``units`` (per channel), ``format``
(``rotor_avc.timeseries/1``) and the run's description (machine, scenario configuration,
sample period, damping rule, initial state, software version).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ModelError

FORMAT = "rotor_avc.timeseries/1"
AXES = ("time_s", "speed_rad_s", "accel_rad_s2", "angle_rad")


@dataclass
class TimeSeries:
    time_s: np.ndarray
    speed_rad_s: np.ndarray
    accel_rad_s2: np.ndarray
    angle_rad: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str]
    metadata: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return self.time_s.size

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise ModelError(f"no channel {name!r}; channels: {', '.join(self.channels)}") from None

    # -- files ---------------------------------------------------------------------------------
    def save(self, path) -> Path:
        """Write the ``.npz`` format of the module docstring; returns the path."""
        path = Path(path)
        if path.suffix != ".npz":
            raise ModelError(f"time series files end in .npz (got {path.name})")
        meta = dict(self.metadata, units=self.units, format=FORMAT)
        arrays = {k: getattr(self, k) for k in AXES}
        arrays.update({f"ch:{k}": v for k, v in self.channels.items()})
        arrays["metadata_json"] = np.array(json.dumps(meta, default=_jsonable))
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(path, **arrays)
        return path

    @classmethod
    def load(cls, path) -> "TimeSeries":
        with np.load(Path(path), allow_pickle=False) as data:
            if "metadata_json" not in data.files:
                raise ModelError(f"{path}: not a rotor_avc time series (no metadata_json)")
            meta = json.loads(str(data["metadata_json"]))
            if meta.get("format") != FORMAT:
                raise ModelError(f"{path}: unknown format {meta.get('format')!r} "
                                 f"(this version reads {FORMAT})")
            channels = {k[3:]: data[k] for k in data.files if k.startswith("ch:")}
            axes = {k: data[k] for k in AXES}
        units = meta.pop("units")
        meta.pop("format")
        return cls(**axes, channels=channels, units=units, metadata=meta)


def _jsonable(value):
    if isinstance(value, complex):
        return [value.real, value.imag]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
