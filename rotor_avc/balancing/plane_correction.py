"""Optimal one-plane correction per speed on a LinearPlant machine (Zhou & Shi 2001 eqs. 7-13, generalised).

With the objective channels' influence coefficients ``G(Omega)`` (columns static, moment; e.g.
the bearing-housing velocities) and a plane whose correction ``c`` adds ``h_p c`` to the
amplitudes (``h_p = [1, j a]``, :mod:`.plane`), the steady 1x response at ``Omega`` is::

    y(c) = G (u + h_p c) = y0 + h c,     y0 = G u,  h = G h_p

Strategies (the ``mode`` label the balancer block switches on):

* ``none`` -- ``c = 0``;
* ``static`` / ``moment`` -- single-mode balancing: cancel the static (``c = -u_e``) or the moment
  unbalance (``c = -u_a / (j a)``), paper eqs. (4)/(5);
* ``bang_bang`` -- the paper's law: at each speed the one of the two single-mode corrections with
  the smaller response ``|y|`` (eq. 13 picks a kink of a piecewise-linear cost; where the modes
  separate, one unbalance type dominates each resonance and this is the paper's switch);
* ``least_squares`` -- its generalisation where the modes couple (each mode excited by both
  unbalance types, as on Werner 2021): ``c* = -h^H y0 / h^H h`` minimises ``|y|^2`` over every
  correction, so ``|y(c*)| <= |y(c)|`` for ``c`` = 0 and both single-mode corrections. Near a
  resonance it cancels the dominant mode's modal force. It moves with the speed (``continuous``),
  the actuator limiting its rate.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .influence import InfluenceTable
from .plane import MachinePlane

CORRECTION_STRATEGIES = ("none", "static", "moment", "bang_bang", "least_squares")


def optimal_corrections(G: np.ndarray, u: np.ndarray, plane: MachinePlane,
                        strategy: str) -> tuple[np.ndarray, np.ndarray]:
    """Corrections ``c`` (N,) and mode labels (N,) for responses ``G`` (N, C, 2) and the
    unbalance ``u = [u_e, u_a]``; vectorised over speeds."""
    if strategy not in CORRECTION_STRATEGIES:
        raise ModelError(f"unknown correction strategy {strategy!r}; use one of "
                         + ", ".join(CORRECTION_STRATEGIES))
    G = np.asarray(G, complex)
    N = G.shape[0]
    y0 = G @ np.asarray(u, complex)                        # (N, C)
    h = G @ plane.influence                                # (N, C)
    c_static = np.full(N, plane.cancelling("static", u[0]))
    c_moment = np.full(N, plane.cancelling("moment", u[1]))
    if strategy == "none":
        return np.zeros(N, complex), np.full(N, "none")
    if strategy in ("static", "moment"):
        return (c_static if strategy == "static" else c_moment), np.full(N, strategy)
    if strategy == "bang_bang":
        r_s = np.linalg.norm(y0 + h * c_static[:, None], axis=1)
        r_m = np.linalg.norm(y0 + h * c_moment[:, None], axis=1)
        pick = r_m < r_s
        return np.where(pick, c_moment, c_static), np.where(pick, "moment", "static")
    hh = np.einsum("nc,nc->n", h.conj(), h).real
    c = np.where(hh > 0, -np.einsum("nc,nc->n", h.conj(), y0) / np.where(hh > 0, hh, 1), 0)
    return c, np.full(N, "least_squares")


def residual_response(G: np.ndarray, u: np.ndarray, plane: MachinePlane,
                      c: np.ndarray) -> np.ndarray:
    """``y = G (u + h_p c)``: (N, C) responses with the corrections applied."""
    amps = np.asarray(u, complex)[None, :] + np.asarray(c, complex)[:, None] * plane.influence
    return np.einsum("nce,ne->nc", np.asarray(G, complex), amps)


class PlaneCorrectionLaw:
    """Law interface of :class:`.block.BalancerBlock`: the correction for the current speed from
    the current estimate (steady-state responses of the objective channels)."""

    def __init__(self, objective: InfluenceTable, plane: MachinePlane, strategy: str):
        if strategy not in CORRECTION_STRATEGIES:
            raise ModelError(f"unknown correction strategy {strategy!r}; use one of "
                             + ", ".join(CORRECTION_STRATEGIES))
        self.objective = objective
        self.plane = plane
        self.strategy = strategy
        self.continuous = strategy == "least_squares"

    def decide(self, t: float, speed: float, amplitudes: dict[str, complex]):
        u = np.array([amplitudes["static"], amplitudes["moment"]])
        if not self.objective.covers(speed):
            return "hold", None
        c, mode = optimal_corrections(self.objective.at(speed)[None], u, self.plane,
                                      self.strategy)
        return str(mode[0]), complex(c[0])

    def corrections(self, position: complex) -> dict[str, complex]:
        return self.plane.corrections(position)
