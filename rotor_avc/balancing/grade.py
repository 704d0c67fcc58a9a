"""ISO 21940-11:2016 balance quality grade of a rotor's unbalance (rotors with rigid behaviour).

* Grade (clause 6.2, Table 1): ``G = e Omega`` in mm/s, with the specific unbalance ``e = U / m``
  (``U`` the residual unbalance [kg m], ``m`` the rotor mass [kg]; ``e`` in m, x 1000 for mm)
  and ``Omega`` the maximum service angular velocity [rad/s]. Here ``Omega`` is the highest
  speed of the balancer's run-up (its end), the service speed the configs declare.
* Grade classes (Table 1): G 0.4, 1, 2.5, 6.3, 16, 40, 100, 250, 630, 1600, 4000, each 2.5
  times the previous (rounded); a value's class is the smallest grade >= it.
* Reference planes (clause 4.5.1: the bearing planes) and allocation (clause 7, two-plane
  tolerances of an inboard rotor): the permissible ``U_per = G_per m / Omega`` is split in
  proportion to the distance of the other bearing from the centre of mass,
  ``U_per,A = U_per L_B / L``, ``U_per,B = U_per L_A / L`` (``L = L_A + L_B``), each share kept
  between 0.3 and 0.7. The model's unbalance is a resultant (static) unbalance ``U_s`` and a
  moment unbalance ``U_m`` about the centre of mass; resolved into the bearing planes at axial
  positions ``z_A < 0 < z_B`` (from the centre of mass): ``U_A + U_B = U_s`` and
  ``z_A U_A + z_B U_B = U_m / lever``, where ``lever`` is the model's factor between a point
  mass's moment and its axial position times its static amplitude (Zhou & Shi 2001 rotor: 1,
  Werner 2021 machine: ``j``). The grade of plane ``P`` is ``|U_P| Omega / (m share_P)``, the
  grade it meets against its share; the rotor's grade is the larger of the two.
* The resultant (static) unbalance alone gives ``|U_s| Omega / m``, reported beside it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ModelError

#: ISO 21940-11:2016 Table 1 balance quality grades [mm/s]
GRADES_MM_S = (0.4, 1.0, 2.5, 6.3, 16.0, 40.0, 100.0, 250.0, 630.0, 1600.0, 4000.0)
#: clause 7: the smaller share of a two-plane allocation is at least this
MIN_SHARE = 0.3


def grade_mm_s(unbalance_kg_m: float, mass_kg: float, speed_rad_s: float) -> float:
    """``G = (U / m) Omega`` in mm/s (e in m -> mm)."""
    if not (mass_kg > 0 and speed_rad_s > 0 and unbalance_kg_m >= 0):
        raise ModelError(f"balance grade needs U >= 0, m > 0 and Omega > 0 (got U = "
                         f"{unbalance_kg_m:g} kg m, m = {mass_kg:g} kg, Omega = "
                         f"{speed_rad_s:g} rad/s)")
    return 1e3 * unbalance_kg_m / mass_kg * speed_rad_s


def grade_class(g_mm_s: float) -> float | None:
    """The smallest Table 1 grade >= ``g_mm_s`` (None above G 4000)."""
    for grade in GRADES_MM_S:
        if g_mm_s <= grade * (1 + 1e-12):
            return grade
    return None


def plane_shares(z_a_m: float, z_b_m: float) -> tuple[float, float]:
    """Clause 7 allocation ``(L_B / L, L_A / L)`` of bearings at ``z_a < 0 < z_b`` from the
    centre of mass, each share between 0.3 and 0.7."""
    if not z_a_m < 0 < z_b_m:
        raise ModelError(f"the centre of mass must lie between the bearings (z = {z_a_m:g} and "
                         f"{z_b_m:g} m from it)")
    length = z_b_m - z_a_m
    return (min(max(z_b_m / length, MIN_SHARE), 1 - MIN_SHARE),
            min(max(-z_a_m / length, MIN_SHARE), 1 - MIN_SHARE))


@dataclass(frozen=True)
class RotorGrade:
    """What a rotor's grade needs: its mass, its two bearing planes (name, axial position from
    the centre of mass), the model's moment ``lever`` (module docstring), the maximum service
    speed and the permissible grade."""

    mass_kg: float
    planes: tuple[tuple[str, float], tuple[str, float]]
    lever: complex
    speed_rad_s: float
    permissible_mm_s: float

    def plane_unbalance(self, static_kg_m: complex, moment_kg_m2: complex) -> list[complex]:
        """``[U_A, U_B]`` [kg m]: the unbalance resolved into the bearing planes."""
        (_, z_a), (_, z_b) = self.planes
        u_b = (moment_kg_m2 / self.lever - z_a * static_kg_m) / (z_b - z_a)
        return [static_kg_m - u_b, u_b]

    def assess(self, static_kg_m: complex, moment_kg_m2: complex) -> dict:
        """The grade of an unbalance: per bearing plane against its share, the rotor's (the
        larger), its class, the resultant static unbalance's, and whether it is within the
        permissible grade."""
        shares = plane_shares(self.planes[0][1], self.planes[1][1])
        planes = {}
        for (name, z), share, u in zip(self.planes, shares,
                                       self.plane_unbalance(static_kg_m, moment_kg_m2)):
            planes[name] = {"axial_m": z, "unbalance_kg_m": abs(u), "share": share,
                            "grade_mm_s": grade_mm_s(abs(u), self.mass_kg * share,
                                                     self.speed_rad_s)}
        g = max(p["grade_mm_s"] for p in planes.values())
        return {"grade_mm_s": g, "grade_class": grade_class(g),
                "permissible_grade_mm_s": self.permissible_mm_s,
                "within_permissible": bool(g <= self.permissible_mm_s),
                "static_grade_mm_s": grade_mm_s(abs(static_kg_m), self.mass_kg,
                                                self.speed_rad_s),
                "speed_rad_s": self.speed_rad_s, "planes": planes}


    def balancer_grades(self, true: dict, estimate: dict, correction: dict) -> dict:
        """Grades of the true unbalance, of the balancer's estimate of it and of the residual
        after the correction (true + the correction's amplitudes; each a ``{"static": kg m,
        "moment": kg m^2}`` mapping in the model's convention)."""
        residual = {k: true[k] + correction[k] for k in ("static", "moment")}
        return {name: self.assess(u["static"], u["moment"]) for name, u in
                (("true", true), ("estimate", estimate), ("residual", residual))}


def grade_text(result: dict) -> str:
    """``G x.x (within G 2.5: yes/no)`` with its class and the per-plane grades."""
    cls = result["grade_class"]
    planes = ", ".join(f"{n} G {p['grade_mm_s']:.3g}" for n, p in result["planes"].items())
    return (f"G {result['grade_mm_s']:.3g} (within G {result['permissible_grade_mm_s']:g}: "
            f"{'yes' if result['within_permissible'] else 'no'}; class "
            f"{'above G 4000' if cls is None else f'G {cls:g}'}; bearing planes {planes}; "
            f"resultant static G {result['static_grade_mm_s']:.3g})")


def service_speed_note(speed_rad_s: float) -> str:
    """How the grade's ``Omega`` was chosen."""
    return (f"Omega = {speed_rad_s:.4g} rad/s ({speed_rad_s / (2 * math.pi):.4g} Hz), the "
            "run-up's highest speed taken as the maximum service speed (ISO 21940-11:2016 6.2)")
