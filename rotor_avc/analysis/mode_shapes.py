"""Mode shapes and whirl direction of a machine's modes from their eigenvectors.

A mode ``q(t) = Re(v e^{lambda t})`` (``Im lambda > 0``) moves each pair of lateral rotor
coordinates ``(a, b)`` on an ellipse ``q_a = Re(v_a e^{j w t})``, ``q_b = Re(v_b e^{j w t})``.
Written as the complex coordinate ``r = q_a + j q_b`` it is the sum of two circles (Genta,
*Dynamics of Rotating Systems*, 2005, Sec. 3.6; Friswell et al., *Dynamics of Rotating
Machines*, 2010, Sec. 3.6.2)::

    r = r_f e^{j w t} + conj(r_b) e^{-j w t},   r_f = (v_a + j v_b) / 2,   r_b = (v_a - j v_b) / 2

``r_f`` turns from ``+a`` towards ``+b``. Each model's pairs are declared with the spin turning
from ``a`` to ``b`` (:data:`ROTOR_PAIRS`, from the models' documented spin direction; the
gyroscopic matrix then has ``G1[a, b] > 0``, the rotating damping ``N_eta[a, b] > 0`` and the
unbalance force ``p2[b] = -j p2[a]``), so ``|r_f| > |r_b|`` is **forward** whirl. The
ellipticity ``e = (|r_f| - |r_b|) / (|r_f| + |r_b|)`` is +1 for a circular forward orbit, -1 for
a circular backward one and 0 for a straight line; the pair with the largest orbit
(``|r_f| + |r_b|``) decides, and ``|e| <`` :data:`PLANAR_ELLIPTICITY` or rotor motion below
:data:`SHAPE_THRESHOLD` of the largest coordinate is ``"none"``.

Where two poles coincide (an isotropic rotor, every gyroscopic pair at rest) any combination
of the two eigenvectors is one; the pair is then resolved into its forward and backward
circular modes (the extremes of ``|r_f|^2 / (|r_f|^2 + |r_b|^2)`` over the two-dimensional
eigenspace, a 2 x 2 Hermitian eigenproblem), so the labels do not depend on the solver's basis.

Shapes are the generalised coordinates in their own units (m, rad), normalised to the largest
magnitude, phases relative to it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import ModelError

#: ``|e|`` below this: a planar (straight-line) orbit, whirl ``"none"``
PLANAR_ELLIPTICITY = 0.05
#: coordinates moving less than this fraction of the largest one are left out of a shape
SHAPE_THRESHOLD = 0.05
#: coordinates moving at least this fraction of the largest one are the mode's dominant ones
DOMINANT_THRESHOLD = 0.5
#: two poles closer than this (relative to their magnitude) are one repeated pole
REPEATED_POLE_RTOL = 1e-7

#: ``model:`` -> the rotor's lateral coordinate pairs ``(a, b)``, the spin turning from ``+a``
#: towards ``+b`` (models/*.py docstrings): Werner 2021 the rigid machine's centre and tilts
#: (``G[phi_sz, phi_sy] = +Omega theta_rx``); Werner 2017/2019 the rotor mass and journals
#: (spin from +z towards +y); Sci. Rep. 2023 the rotor centre and tilts (right-handed spin
#: about +z); Zhou & Shi 2001 centre and tilts (spin from +Z towards +X)
ROTOR_PAIRS = {
    "foot_mount_3d": (("z_s", "y_s"), ("phi_sz", "phi_sy")),
    "roller_bearing_rotor": (("z_w", "y_w"), ("z_v", "y_v")),
    "sleeve_bearing_motor": (("z_w", "y_w"), ("z_v", "y_v")),
    "active_bearing": (("eps_r_x", "eps_r_y"), ("theta_x", "theta_y")),
    "rigid_rotor": (("R_Z", "R_X"), ("psi", "theta")),
}

#: coordinate-name stems of the plane models (Werner 2017/2019: ``<direction>_<stem>``)
_PLANE_PARTS = {"s": "stator", "w": "rotor", "v": "journal", "b": "housing",
                "fL": "foundation L", "fR": "foundation R"}


def part_of(coordinate: str, model: str | None) -> tuple[str, str]:
    """``(part, direction)`` of a coordinate of a shipped model (models/*.py docstrings), e.g.
    ``z_w -> ("rotor", "z")``, ``eps_bh_y_1 -> ("housing 1", "y")``, ``y_fNL ->
    ("foundation NL", "y")``; any other name is its own part."""
    head, _, rest = coordinate.partition("_")
    if model == "foot_mount_3d":                                      # Werner 2021 eq. (10)
        if head in ("z", "y", "x"):
            return ("machine", head) if rest == "s" else (f"foundation {rest[1:]}", head)
        if head == "phi":
            return "machine tilt", rest[-1]
    if model in ("roller_bearing_rotor", "sleeve_bearing_motor"):
        if head in ("z", "y") and rest in _PLANE_PARTS:
            return _PLANE_PARTS[rest], head
        if coordinate == "phi_s":
            return "stator roll", ""
    if model == "active_bearing":                                     # Sci. Rep. 2023 eqs. 6-7
        if head == "theta":
            return "rotor tilt", rest
        kind, _, tail = rest.partition("_")
        direction, _, side = tail.partition("_")
        name = {"r": "rotor", "bh": "housing", "ac": "actuator"}[kind]
        return f"{name} {side}".strip(), direction
    if model == "rigid_rotor":                                        # Zhou & Shi 2001 eq. (1)
        return ("rotor", rest) if head == "R" else ("rotor tilt", coordinate)
    return coordinate, ""


@dataclass(frozen=True)
class RotorGeometry:
    """A plant's coordinates, the ``(part, direction)`` of each, and the index pairs ``(a, b)``
    of the rotor's lateral coordinates (spin from ``a`` towards ``b``)."""

    coords: tuple[str, ...]
    parts: tuple[tuple[str, str], ...]
    pairs: tuple[tuple[int, int], ...]

    @classmethod
    def named(cls, coords, pair_names, model: str | None = None) -> "RotorGeometry":
        """The pairs of coordinate names ``pair_names`` among ``coords`` (pairs that are not in
        the plant dropped); ``model`` names the parts (:func:`part_of`)."""
        index = {c: i for i, c in enumerate(coords)}
        for a, b in pair_names:
            if (a in index) != (b in index):
                raise ModelError(f"rotor pair ({a}, {b}): the plant has one coordinate of it; "
                                 f"its coordinates: {', '.join(coords)}")
        return cls(tuple(coords), tuple(part_of(c, model) for c in coords),
                   tuple((index[a], index[b]) for a, b in pair_names
                         if a in index and b in index))

    @classmethod
    def of_machine(cls, machine) -> "RotorGeometry":
        """The declared pairs and parts of the machine's ``model:`` (:data:`ROTOR_PAIRS`)."""
        model = machine.config.raw("model", None)
        return cls.named(machine.plant.coords, ROTOR_PAIRS.get(model, ()), model)

    def circles(self, shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(|r_f|, |r_b|)`` of every pair: shape ``(pairs,) + shapes.shape[1:]``."""
        a = shapes[[p[0] for p in self.pairs]]
        b = shapes[[p[1] for p in self.pairs]]
        return np.abs(a + 1j * b) / 2, np.abs(a - 1j * b) / 2

    def ellipticity(self, shapes: np.ndarray, poles: np.ndarray) -> np.ndarray:
        """``e`` of the largest rotor orbit of each mode (columns of ``shapes``, coordinates in
        rows; ``nan`` without rotor motion or oscillation): see the module docstring."""
        e = np.full(poles.shape, np.nan)
        if not self.pairs:
            return e
        f, b = self.circles(shapes)
        size = f + b
        top = np.argmax(size, axis=0)
        cols = np.arange(poles.size)
        f, b, size = f[top, cols], b[top, cols], size[top, cols]
        moving = (size >= SHAPE_THRESHOLD * np.abs(shapes).max(axis=0)) & (poles.imag != 0)
        e[moving] = np.sign(poles.imag[moving]) * (f - b)[moving] / size[moving]
        return e

    def circular_basis(self, shapes: np.ndarray, poles: np.ndarray,
                       reference: np.ndarray | None = None) -> np.ndarray:
        """``shapes`` with each repeated pole pair's two vectors replaced by its forward and
        backward circular combinations (module docstring), each to the column whose
        ``reference`` vector (default: ``shapes``; a neighbouring speed's) it resembles more."""
        out = shapes.copy()
        if not self.pairs:
            return out
        reference = shapes if reference is None else reference
        ia, ib = [p[0] for p in self.pairs], [p[1] for p in self.pairs]
        for i, j in _repeated_pairs(poles):
            v = shapes[:, [i, j]]
            fw, bw = (v[ia] + 1j * v[ib]) / 2, (v[ia] - 1j * v[ib]) / 2
            F, B = fw.conj().T @ fw, bw.conj().T @ bw
            if np.linalg.cond(F + B) > 1e8:                          # no rotor motion to split
                continue
            w = v @ scipy.linalg.eigh(F, F + B)[1]
            w /= np.linalg.norm(w, axis=0)
            r = reference[:, [i, j]]
            mac = np.abs(r.conj().T @ w) ** 2 / np.linalg.norm(r, axis=0)[:, None] ** 2
            if mac[0, 0] + mac[1, 1] < mac[0, 1] + mac[1, 0]:
                w = w[:, ::-1]
            out[:, i], out[:, j] = w[:, 0], w[:, 1]
        return out


def _repeated_pairs(poles: np.ndarray) -> list[tuple[int, int]]:
    """Index pairs of (nearly) equal oscillating poles."""
    scale = np.maximum(np.abs(poles), 1.0)
    pairs, used = [], set()
    for i in range(poles.size):
        for j in range(i + 1, poles.size):
            if i in used or j in used or poles[i].imag == 0:
                continue
            if abs(poles[i] - poles[j]) <= REPEATED_POLE_RTOL * scale[i]:
                pairs.append((i, j))
                used |= {i, j}
    return pairs


def whirl_name(e: float) -> str:
    """``"forward"``, ``"backward"`` or ``"none"`` of an ellipticity (``nan``: none)."""
    if not np.isfinite(e) or abs(e) < PLANAR_ELLIPTICITY:
        return "none"
    return "forward" if e > 0 else "backward"


def shape_rows(vector: np.ndarray, coords, threshold: float = SHAPE_THRESHOLD) -> list[dict]:
    """``[{"coordinate", "magnitude", "phase_deg"}]`` of one mode: magnitudes normalised to the
    largest (1), phases relative to it in (-180, 180], coordinates below ``threshold`` left out;
    ordered as the plant's coordinates."""
    mag = np.abs(vector)
    k = int(np.argmax(mag))
    if mag[k] == 0:
        return []
    rel = vector / vector[k]
    rel[k] = 1.0                                                      # exactly, not to rounding
    return [{"coordinate": c, "magnitude": float(abs(r)),
             "phase_deg": float(np.degrees(np.angle(r))) + 0.0}
            for c, r in zip(coords, rel) if abs(r) >= threshold]


def dominant_parts(vector: np.ndarray, geometry: RotorGeometry,
                   threshold: float = DOMINANT_THRESHOLD, max_parts: int = 3) -> str:
    """The (at most ``max_parts``) parts moving at least ``threshold`` of the largest
    coordinate, largest first, with their directions: e.g. ``"rotor z/y, journal z/y"``."""
    mag = np.abs(vector)
    if mag.max() == 0:
        return "-"
    parts: dict[str, list[str]] = {}
    for i in np.argsort(-mag, kind="stable"):
        if mag[i] < threshold * mag.max():
            break
        part, direction = geometry.parts[i]
        if part not in parts and len(parts) == max_parts:
            continue
        directions = parts.setdefault(part, [])
        if direction and direction not in directions:
            directions.append(direction)
    return ", ".join(f"{p} {'/'.join(d)}".strip() for p, d in parts.items())
