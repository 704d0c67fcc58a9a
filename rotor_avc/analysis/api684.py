"""API 684-style unbalance-response checks of the critical speeds in a response over speed.

For each resonance peak of a synchronous response amplitude ``A(N)`` over rotor speed ``N``
(from the model's unbalance response or a measured run-up's 1x order track), following
API RP 684 (2nd ed., 2005, section 2.8 / SP6.8.2 of API 617 8th ed.):

* critical speed ``N_c1``: the speed of the peak; peak response ``A(N_c1)``;
* amplification factor by the half-power method: ``AF = N_c1 / (N_2 - N_1)``, with ``N_1 < N_c1 <
  N_2`` the speeds where the amplitude has fallen to ``A(N_c1) / sqrt(2)`` (0.707 x peak; linear
  interpolation between samples). ``AF`` is undetermined where the response does not fall that
  far on both sides within the record (critically damped all the same when even the band from
  the one point found to the record's end gives ``AF < 2.5``);
* separation margin to the operating speed range ``[N_min, N_mc]`` (minimum and maximum
  continuous speed), in percent of the nearer limit: ``SM = 100 (N_min - N_c1) / N_min`` for a
  critical below the range, ``SM = 100 (N_c1 - N_mc) / N_mc`` above it;
* required separation margin (API 617 8th ed. 6.8.2.10, API 684 SP6.8.2.10):

  - ``AF < 2.5``: the response is critically damped; no separation margin is required;
  - below the range: ``SM_req = min(16, 17 (1 - 1 / (AF - 1.5)))`` %;
  - above the range: ``SM_req = min(26, 10 + 17 (1 - 1 / (AF - 1.5)))`` %;
  - a critical speed with ``AF >= 2.5`` inside the operating range fails.

For a single-degree-of-freedom oscillator ``AF`` is close to ``1 / (2 zeta)`` (API 684 Fig. 2-6).

The overall verdict (:func:`overall_verdict`) counts every row with a verdict as one requirement:
met when it passes or is critically damped, not met when it fails; an undetermined row (the
half-power points beyond the record) is listed apart, not counted.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import scipy.signal

from ..errors import ModelError

HALF_POWER = 1.0 / np.sqrt(2.0)
#: critical speeds with an amplification factor below this need no separation margin
CRITICALLY_DAMPED_AF = 2.5


@dataclass(frozen=True)
class CriticalSpeedCheck:
    """One critical speed's API 684 figures (speeds in Hz, amplitude in the response's unit)."""

    speed_hz: float
    peak: float
    n1_hz: float | None
    n2_hz: float | None
    amplification_factor: float | None
    position: str                       # "below", "within" or "above" the operating range
    separation_margin_pct: float | None   # actual (None inside the range)
    required_margin_pct: float | None     # None: AF undetermined
    verdict: str                        # "pass", "fail", "critically damped", "undetermined"

    def row(self) -> dict:
        return asdict(self)


def half_power_points(speed, amplitude, i_peak: int) -> tuple[float | None, float | None]:
    """``(N_1, N_2)``: the nearest speeds either side of sample ``i_peak`` where the amplitude
    falls to ``peak / sqrt(2)`` (interpolated), ``None`` where it does not within the record."""
    level = HALF_POWER * amplitude[i_peak]

    def crossing(indices):
        prev = i_peak
        for i in indices:
            if amplitude[i] <= level:
                a, b = amplitude[prev], amplitude[i]
                return float(speed[prev] + (speed[i] - speed[prev]) * (a - level) / (a - b))
            prev = i
        return None

    return crossing(range(i_peak - 1, -1, -1)), crossing(range(i_peak + 1, len(amplitude)))


def required_margin_pct(af: float, position: str) -> float:
    """Required separation margin in % (module docstring); 0 below ``AF = 2.5``."""
    if af < CRITICALLY_DAMPED_AF:
        return 0.0
    base = 17.0 * (1.0 - 1.0 / (af - 1.5))
    return min(16.0, base) if position == "below" else min(26.0, 10.0 + base)


def _af_bound(speed, nc: float, n1, n2) -> float:
    """Upper bound of ``AF`` where a half-power point lies beyond the record: the band is at
    least as wide as from the found point to the record's end."""
    if n1 is None and n2 is None:
        return np.inf
    lo = speed[0] if n1 is None else n1
    hi = speed[-1] if n2 is None else n2
    return nc / (hi - lo)


def check_critical(speed, amplitude, i_peak: int, operating_hz) -> CriticalSpeedCheck:
    """The API 684 figures of the peak at sample ``i_peak`` against ``operating_hz = (min, max)``."""
    n_min, n_max = operating_hz
    nc = float(speed[i_peak])
    n1, n2 = half_power_points(speed, amplitude, i_peak)
    af = nc / (n2 - n1) if n1 is not None and n2 is not None else None
    if nc < n_min:
        position, margin = "below", 100.0 * (n_min - nc) / n_min
    elif nc > n_max:
        position, margin = "above", 100.0 * (nc - n_max) / n_max
    else:
        position, margin = "within", None
    if af is None and _af_bound(speed, nc, n1, n2) < CRITICALLY_DAMPED_AF:
        required, verdict = 0.0, "critically damped"
    elif af is None:
        required, verdict = None, "undetermined"
    elif af < CRITICALLY_DAMPED_AF:
        required, verdict = 0.0, "critically damped"
    else:
        required = required_margin_pct(af, position)
        verdict = "pass" if margin is not None and margin >= required else "fail"
    return CriticalSpeedCheck(nc, float(amplitude[i_peak]), n1, n2, af, position, margin,
                              required, verdict)


def check_response(speed_hz, amplitude, operating_hz, min_prominence: float = 0.05
                   ) -> list[CriticalSpeedCheck]:
    """Checks of every resonance peak of ``amplitude`` over ``speed_hz``: local maxima inside the
    record whose prominence is at least ``min_prominence`` x the largest amplitude."""
    speed = np.asarray(speed_hz, dtype=float)
    amp = np.abs(np.asarray(amplitude))
    if speed.ndim != 1 or speed.shape != amp.shape or speed.size < 3:
        raise ModelError("API 684 check: speed and amplitude must be 1-D arrays of equal length >= 3")
    if np.any(np.diff(speed) <= 0):
        raise ModelError("API 684 check: the speeds must increase (sort a run-down first)")
    n_min, n_max = (float(v) for v in operating_hz)
    if not 0 < n_min <= n_max:
        raise ModelError(f"API 684 check: the operating speed range needs 0 < min <= max "
                         f"(got {n_min:g} .. {n_max:g} Hz)")
    peaks, _ = scipy.signal.find_peaks(amp, prominence=min_prominence * amp.max())
    return [check_critical(speed, amp, int(i), (n_min, n_max)) for i in peaks]


def failure_reason(c: CriticalSpeedCheck) -> str:
    """Why a failing row fails: inside the operating range, or its margin below the required."""
    if c.separation_margin_pct is None:
        return "inside the operating range"
    return f"SM {c.separation_margin_pct:.3g} % < required {c.required_margin_pct:.3g} %"


def overall_verdict(checks: dict[str, list[CriticalSpeedCheck]]) -> dict:
    """``{"verdict": "PASS" | "FAIL", "requirements", "met", "failed": [row phrases],
    "undetermined": [row phrases]}`` over the rows of every response (module docstring)."""
    failed, undetermined, counted = [], [], 0
    for name, rows in checks.items():
        for c in rows:
            where = f"{name} at {c.speed_hz:.4g} Hz"
            if c.verdict == "undetermined":
                undetermined.append(f"{where}: half-power points beyond the speed range")
                continue
            counted += 1
            if c.verdict == "fail":
                failed.append(f"{where} (AF {c.amplification_factor:.3g}): {failure_reason(c)}")
    return {"verdict": "FAIL" if failed else "PASS", "requirements": counted,
            "met": counted - len(failed), "failed": failed, "undetermined": undetermined}


def verdict_line(verdict: dict) -> str:
    """One line: ``API 684: PASS (n of n requirements met)`` or ``API 684: FAIL: <rows>``."""
    met = f"{verdict['met']} of {verdict['requirements']} requirements met"
    line = (f"API 684: FAIL ({met}): " + "; ".join(verdict["failed"]) if verdict["failed"]
            else f"API 684: PASS ({met})")
    if verdict["undetermined"]:
        line += (f"; {len(verdict['undetermined'])} row(s) undetermined (extend the speed "
                 "range): " + "; ".join(verdict["undetermined"]))
    return line


def damping_rule(floor_hz: float, speed_hz) -> str:
    """The damping of the model's unbalance response these checks read (DESIGN.md 2): forced
    response, loss-factor damping ``d = c tan(delta) / w_F`` at ``w_F = max(Omega, floor)``,
    and where the speed grid lies with respect to the floor."""
    lowest = float(np.min(speed_hz))
    where = ("w_F = Omega at every speed of the grid" if lowest >= floor_hz else
             f"w_F = the floor below {floor_hz:g} Hz, Omega above")
    return (f"forced response: loss-factor damping c tan(delta) / w_F at w_F = max(Omega, "
            f"{floor_hz:g} Hz) (analysis.damping_floor_hz); {where}")


def format_table(checks: list[CriticalSpeedCheck], unit: str, operating_hz) -> str:
    """The checks as a fixed-width text table (speeds in Hz and rpm)."""
    lo, hi = operating_hz
    lines = [f"operating speed range {lo:g} .. {hi:g} Hz ({lo * 60:.0f} .. {hi * 60:.0f} rpm)",
             f"{'N_c [Hz]':>9} {'[rpm]':>8} {'peak [' + unit + ']':>16} {'AF':>7} {'position':>8} "
             f"{'SM [%]':>7} {'SM req [%]':>10}  verdict"]
    for c in checks:
        def num(v, fmt):
            return format(v, fmt) if v is not None else "-"
        lines.append(f"{c.speed_hz:9.3f} {c.speed_hz * 60:8.1f} {c.peak:16.4g} "
                     f"{num(c.amplification_factor, '7.2f'):>7} {c.position:>8} "
                     f"{num(c.separation_margin_pct, '7.1f'):>7} {num(c.required_margin_pct, '10.1f'):>10}"
                     f"  {c.verdict}")
    if not checks:
        lines.append("no resonance peak in the speed range")
    return "\n".join(lines)
