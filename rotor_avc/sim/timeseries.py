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

import io
import json
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np

from ..errors import ModelError
from ..output_files import writing

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
        """Write the ``.npz`` format of the module docstring (complete or not at all,
        :func:`rotor_avc.output_files.writing`); returns the path."""
        path = _npz_path(path)
        arrays = self._arrays()
        arrays["metadata_json"] = self._metadata_json()
        with writing(path) as tmp:
            np.savez_compressed(tmp, **arrays)
        return path

    def _arrays(self) -> dict[str, np.ndarray]:
        arrays = {k: getattr(self, k) for k in AXES}
        arrays.update({f"ch:{k}": v for k, v in self.channels.items()})
        return arrays

    def _metadata_json(self) -> np.ndarray:
        return np.array(json.dumps(dict(self.metadata, units=self.units, format=FORMAT),
                                   default=_jsonable))

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


def save_blocks(path, blocks: Iterable[TimeSeries], n_samples: int) -> Iterator[TimeSeries]:
    """Write consecutive blocks of one run of ``n_samples`` samples to the ``.npz`` format as
    they come, passing each block on: memory independent of the run's length. Each array is
    appended to its own ``.npy`` file (length declared up front) next to ``path``, and the files
    are deflated into ``path`` one by one when all ``n_samples`` have come; a run that ends
    early writes nothing."""
    path = _npz_path(path)
    written, last = 0, None
    with tempfile.TemporaryDirectory(dir=path.parent, prefix=f".{path.stem}.") as tmp:
        files: dict[str, object] = {}
        try:
            for ts in blocks:
                for key, values in ts._arrays().items():
                    if key not in files:
                        files[key] = open(Path(tmp) / f"{len(files)}.npy", "wb")
                        np.lib.format.write_array_header_1_0(files[key], {
                            "descr": "<f8", "fortran_order": False, "shape": (n_samples,)})
                    files[key].write(np.ascontiguousarray(values, "<f8").tobytes())
                written, last = written + len(ts), ts
                yield ts
        finally:
            for f in files.values():
                f.close()
        if written != n_samples:
            return
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
            for key, f in files.items():
                zf.write(f.name, f"{key}.npy")
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, last._metadata_json())
            zf.writestr("metadata_json.npy", buffer.getvalue())


def _npz_path(path) -> Path:
    path = Path(path)
    if path.suffix != ".npz":
        raise ModelError(f"time series files end in .npz (got {path.name})")
    return path


def _jsonable(value):
    if isinstance(value, complex):
        return [value.real, value.imag]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
