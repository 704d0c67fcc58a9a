"""Typed, frozen settings of a config's ``analysis:``, ``control:`` and ``simulation:`` sections.

Each section is a frozen dataclass whose fields declare, once, their type, default, bounds, unit
and meaning (:func:`setting`). :func:`read_settings` validates a YAML section into one in a
single step: unknown keys are refused, and every error names the file, the field and the fix
(:class:`rotor_avc.config.Section`). :func:`reference_markdown` renders the declarations as the
configuration reference of the README (a test checks that the two agree)::

    python -c "from rotor_avc.settings import reference_markdown; print(reference_markdown())"
"""
from __future__ import annotations

import dataclasses
import math
import types
import typing
from dataclasses import dataclass, field

from .section import Section

DEFAULT_SAMPLE_RATE_HZ = 5000.0
POLE_METHODS = ("worst_case", "whirl_iteration")
DISCRETIZATION_METHODS = ("tustin", "zoh", "foh")
STABILITY_CONTROLLERS = ("continuous", "sampled")
DAMPING_RULES = ("speed", "whirl")
INITIAL_STATES = ("rest", "steady_state")
FEEDFORWARD_METHODS = ("paper", "exact")
TEST_SIGNAL_KINDS = ("white", "chirp")
ISO_SUPPORTS = ("rigid", "flexible")
#: relative accuracy of the variable-speed plant (rotor_avc.sim.propagator)
DEFAULT_GRID_TOL = 1e-5


def setting(default=dataclasses.MISSING, doc: str = "", *, unit: str = "",
            positive: bool = False, nonnegative: bool = False, minimum=None, maximum=None,
            choices: tuple = (), min_length: int = 0):
    """A settings field: its default (a settings class for a sub-section), meaning and bounds."""
    meta = dict(doc=doc, unit=unit, positive=positive, nonnegative=nonnegative, minimum=minimum,
                maximum=maximum, choices=choices, min_length=min_length)
    if isinstance(default, type) and dataclasses.is_dataclass(default):
        return field(default_factory=default, metadata=meta)
    return field(default=default, metadata=meta)


# -- the declarations --------------------------------------------------------------------------
@dataclass(frozen=True)
class SpeedRange:
    """``{start, stop, n}``: ``n`` evenly spaced speeds from ``start`` to ``stop``."""

    start: float = setting(doc="first speed", positive=True)
    stop: float = setting(doc="last speed (>= start)", positive=True)
    n: int = setting(doc="number of speeds", minimum=2)

    def check(self, sec: Section) -> None:
        if self.stop < self.start:
            raise sec.error("stop", f"must be >= start {self.start:g} (got {self.stop:g})",
                            fix="give stop above start")


@dataclass(frozen=True)
class WorstCaseSettings:
    """Werner 2021 Figure 4: every mode damped at the ``n_modes``-th mode's whirl frequency."""

    n_modes: int = setting(6, "relevant modes (also the sample-rate check of a scenario)",
                           minimum=1)
    rel_change_tol: float = setting(0.05, "relative change of w_F that ends the iteration",
                                    positive=True, maximum=1.0)
    max_iter: int = setting(20, "iterations before giving up", minimum=1)


@dataclass(frozen=True)
class WhirlIterationSettings:
    """Werner 2019 Sec. 3.3: every mode damped at its own whirl frequency."""

    rel_tol: float = setting(1e-6, "relative tolerance of each mode's w_F", positive=True,
                             maximum=0.01)


@dataclass(frozen=True)
class ThresholdSettings:
    """Werner 2017 Sec. 3, Fig. 4: the threshold-of-stability procedure."""

    w_F_start: float | str = setting("model", "first damping frequency: `model` (the model's "
                                     "estimate, Werner 2017 eq. 14) or a number", unit="rad/s",
                                     positive=True, choices=("model",))
    rel_tol: float = setting(1e-6, "relative change of w_F that ends the iteration",
                             positive=True, maximum=0.1)
    max_iter: int = setting(50, "iterations before giving up", minimum=1)
    speed_min_rpm: float = setting(10.0, "lowest speed of the scan", unit="rpm", positive=True)
    speed_max_rpm: float = setting(5e5, "highest speed of the scan (beyond: no threshold)",
                                   unit="rpm", positive=True)
    n_grid: int = setting(200, "log-spaced scan points before the root search", minimum=3)
    campbell_max_rad_s: float = setting(1000.0, "Campbell plot: modes below this frequency",
                                        unit="rad/s", positive=True)
    controller: str = setting("continuous", "`continuous` G_c(s) or `sampled` (the digital "
                              "controllers)", choices=STABILITY_CONTROLLERS)

    def check(self, sec: Section) -> None:
        if self.speed_max_rpm < self.speed_min_rpm * (1 + 1e-9):
            raise sec.error("speed_max_rpm", f"must be above speed_min_rpm "
                            f"{self.speed_min_rpm:g} rpm (got {self.speed_max_rpm:g})",
                            fix="give a scan range with speed_max_rpm > speed_min_rpm")


@dataclass(frozen=True)
class StudyGains:
    """Gains per feedback kind of a gain study (SI units of the P controller)."""

    displacement: tuple[float, ...] | None = setting(None, "gains", unit="N/m", min_length=1)
    velocity: tuple[float, ...] | None = setting(None, "gains", unit="N s/m", min_length=1)
    acceleration: tuple[float, ...] | None = setting(None, "gains", unit="N s^2/m",
                                                      min_length=1)


@dataclass(frozen=True)
class GainStudySettings:
    """Werner 2019 Sec. 4 gain studies (`rotor-avc study`)."""

    excitation: str | None = setting(None, "the plant's excitation (or --excitation)")
    speed_rpm: SpeedRange | None = setting(None, "speeds of the responses", unit="rpm")
    window_rpm: float = setting(200.0, "reduction: controlled max within +-window vs the "
                                "open-loop peak", unit="rpm", positive=True)
    peak_fraction: float = setting(0.25, "resonances: peaks above this fraction of the largest",
                                   positive=True, maximum=1.0)
    gains: StudyGains = setting(StudyGains, "gains per feedback kind")
    resonances_of: tuple[str, ...] | None = setting(None, "responses whose resonances are tracked")

    def check(self, sec: Section) -> None:
        if self.speed_rpm is not None and self.speed_rpm.n < 5:
            raise sec.section("speed_rpm").error("n", f"must be >= 5 (got {self.speed_rpm.n})")


@dataclass(frozen=True)
class Iso20816Settings:
    """ISO 20816-3:2022 Annex A (Tables A.1, A.2): the evaluation zones of `compare` and `runup`."""

    group: int = setting(2, "1: large machines (300 kW .. 50 MW, shaft height >= 315 mm), 2: "
                         "medium (15 .. 300 kW, 160 .. 315 mm)", minimum=1, maximum=2)
    support: str = setting("rigid", "`rigid`: lowest natural frequency of machine and support in "
                           "the measuring direction >= 1.25 x running speed, else `flexible`",
                           choices=ISO_SUPPORTS)
    channels: tuple[str, ...] | None = setting(None, "bearing-housing outputs (velocity, "
                                               "acceleration or displacement; default: the "
                                               "plant's `bearing*`/`housing*` outputs)")


@dataclass(frozen=True)
class AnalysisSettings:
    """``analysis:`` of a machine config: the linear analyses' settings."""

    pole_method: str = setting("worst_case", "damping procedure of `rotor-avc poles`",
                               choices=POLE_METHODS)
    pole_speeds_hz: tuple[float, ...] = setting((0.0,), "speeds of the pole tables", unit="Hz",
                                                min_length=1)
    damping_floor_hz: float = setting(1.0, "w_F = max(Omega, floor) of forced response",
                                      unit="Hz", positive=True)
    frf_speed_hz: SpeedRange | None = setting(None, "speeds of `rotor-avc frf`; its stop bounds "
                                              "a scenario's speeds", unit="Hz")
    il_speed_hz: SpeedRange | None = setting(None, "Sci. Rep. 2023: speeds of the insertion loss",
                                             unit="Hz")
    cases_rpm: tuple[float, ...] | None = setting(None, "Sci. Rep. 2023: speeds of the force table",
                                                  unit="rpm", min_length=1)
    worst_case: WorstCaseSettings = setting(WorstCaseSettings, "pole_method worst_case")
    whirl_iteration: WhirlIterationSettings = setting(WhirlIterationSettings,
                                                      "pole_method whirl_iteration")
    stability: ThresholdSettings = setting(ThresholdSettings, "threshold of stability")
    study: GainStudySettings = setting(GainStudySettings, "gain studies")
    iso20816: Iso20816Settings = setting(Iso20816Settings, "ISO 20816-3 zones of the housings")

    def check(self, sec: Section) -> None:
        if self.cases_rpm is not None and min(self.cases_rpm) <= 0:
            raise sec.error("cases_rpm", "speeds must be > 0", fix="give positive speeds in rpm")


@dataclass(frozen=True)
class ControlSettings:
    """``control:`` of a machine config: how the controllers are sampled (DESIGN.md 3)."""

    sample_rate_hz: float | None = setting(None, "controller rate (default: "
                                           "simulation.sample_rate_hz, else "
                                           f"{DEFAULT_SAMPLE_RATE_HZ:g})", unit="Hz",
                                           positive=True)
    method: str = setting("tustin", "discretisation of G_c(s)", choices=DISCRETIZATION_METHODS)
    prewarp_hz: float | None = setting(None, "tustin pre-warping frequency (below Nyquist)",
                                       unit="Hz", positive=True)
    allow_unstable: bool = setting(False, "run a design the checks refuse as unstable "
                                   "(deliberate instability studies), with a warning "
                                   "(`rotor_avc/analysis/design_check.py`)")

    def check(self, sec: Section) -> None:
        if self.prewarp_hz is not None and self.method != "tustin":
            raise sec.error("prewarp_hz", f"applies to method tustin only (method is "
                            f"{self.method})", fix="drop prewarp_hz or set method: tustin")


@dataclass(frozen=True)
class FeedforwardRun:
    """``simulation.feedforward``: Sci. Rep. 2023's 1x force generator in the loop."""

    type: str = setting(doc="`synchronous` (the only kind)", choices=("synchronous",))
    method: str | None = setting(None, "`paper` or `exact` (default: the machine's "
                                 "`feedforward.method`)", choices=FEEDFORWARD_METHODS)


@dataclass(frozen=True)
class UnbalanceEntry:
    """``simulation.unbalance.<excitation>``: the complex amplitude ``magnitude e^(j phase)`` of
    one excitation of the plant, in that excitation's unit: kg m for a static unbalance u_e and
    kg m^2 for a moment unbalance u_alpha (Werner 2021 eqs. 13, 14), m for the mass and magnetic
    eccentricities and the bent rotor (Werner 2019 eqs. 8-10)."""

    magnitude: float = setting(doc="magnitude of u in the excitation's unit (kg m, kg m^2 or "
                               "m)", nonnegative=True)
    phase_deg: float = setting(0.0, "phase of u", unit="deg")

    @property
    def amplitude(self) -> complex:
        """``magnitude e^(j phase)``."""
        phase = math.radians(self.phase_deg)
        return self.magnitude * complex(math.cos(phase), math.sin(phase))


@dataclass(frozen=True)
class TestSignalSettings:
    """``simulation.test_signal``: a broadband force added to one actuator's commanded force for
    measured FRFs (`rotor_avc/sim/broadband.py`). The actuator and the band's Nyquist limit are
    checked against the plant and the sample rate when the scenario is built."""

    actuator: str = setting(doc="an actuator of the plant")
    kind: str = setting(doc="`white` (band-limited Gaussian noise) or `chirp` (repeated linear "
                        "sweep)", choices=TEST_SIGNAL_KINDS)
    rms_n: float = setting(doc="RMS force (white: the expected value)", unit="N", positive=True)
    band_hz: tuple[float, ...] = setting(doc="[low, high]: white: the band-pass edges (low 0: "
                                         "low-pass); chirp: each sweep's start and stop",
                                         unit="Hz", min_length=2)
    seed: int = setting(0, "white: the random sequence", minimum=0)
    sweep_s: float = setting(1.0, "chirp: duration of one sweep, repeated", unit="s",
                             positive=True)

    def check(self, sec: Section) -> None:
        if len(self.band_hz) != 2:
            raise sec.error("band_hz", f"must have 2 entries (got {len(self.band_hz)})",
                            fix="give [low, high] in Hz")
        if self.kind == "white" and sec.has("sweep_s"):
            raise sec.error("sweep_s", "only used with kind: chirp", fix="drop sweep_s")
        if self.kind == "chirp" and sec.has("seed"):
            raise sec.error("seed", "only used with kind: white", fix="drop seed")


@dataclass(frozen=True, kw_only=True)
class SimulationSettings:
    """``simulation:`` of a scenario: the in-process loop's (and the ROS graph's) run."""

    sample_rate_hz: float | None = setting(None, "plant and controllers in lockstep (default: "
                                           "control.sample_rate_hz)", unit="Hz", positive=True)
    duration_s: float | None = setting(None, "run length (default: the speed profile's)",
                                       unit="s", positive=True)
    speed: dict = setting(doc="speed profile: one settings class per `type` "
                          "(`rotor_avc.sim.speed_profile.PROFILE_SETTINGS`)")
    unbalance: dict[str, UnbalanceEntry] | None = setting(None, "complex amplitude per "
                                                          "excitation of the plant")
    damping_at: str = setting("speed", "w_F = max(Omega, floor) (`speed`) or frozen at "
                              "whirl_rad_s (`whirl`)", choices=DAMPING_RULES)
    whirl_rad_s: float | None = setting(None, "the frozen w_F of `damping_at: whirl`",
                                        unit="rad/s", positive=True)
    initial_state: str = setting("rest", "`rest`, or `steady_state`: the sampled loop's periodic "
                                 "solution", choices=INITIAL_STATES)
    speed_grid_tol: float = setting(DEFAULT_GRID_TOL, "accuracy of the variable-speed plant",
                                    positive=True, maximum=0.1)
    balancer: bool = setting(False, "run the config's `balancer:` in the loop")
    harmonic: bool = setting(False, "run the config's `harmonic:` (adaptive harmonic control) in "
                             "the loop")
    feedforward: FeedforwardRun | None = setting(None, "Sci. Rep. 2023's 1x feed-forward")
    test_signal: TestSignalSettings | None = setting(None, "broadband test force of one "
                                                     "actuator (`rotor_avc/sim/broadband.py`)")

    def check(self, sec: Section) -> None:
        if self.damping_at == "whirl" and self.whirl_rad_s is None:
            sec.raw("whirl_rad_s")                               # raises "missing" with the fix
        if self.damping_at != "whirl" and self.whirl_rad_s is not None:
            raise sec.error("whirl_rad_s", "only used with `damping_at: whirl`",
                            fix="drop whirl_rad_s or set damping_at: whirl")


#: the sections declared here, in the order of the reference
SECTIONS = {"analysis": AnalysisSettings, "control": ControlSettings,
            "simulation": SimulationSettings}


def analysis_settings(cfg: Section) -> AnalysisSettings:
    return read_settings(AnalysisSettings, cfg.section("analysis", {}))


def control_settings(cfg: Section) -> ControlSettings:
    return read_settings(ControlSettings, cfg.section("control", {}))


def sample_rate_hz(cfg: Section) -> float:
    """The rate of the controllers and of every analysis of a config, as declared:
    ``control.sample_rate_hz``, else ``simulation.sample_rate_hz`` (the run's), else
    :data:`DEFAULT_SAMPLE_RATE_HZ`."""
    rate = control_settings(cfg).sample_rate_hz
    if rate is None and cfg.has("simulation"):
        sim = cfg.section("simulation")
        if sim.has("sample_rate_hz"):
            rate = sim.number("sample_rate_hz", positive=True, unit="Hz")
    return DEFAULT_SAMPLE_RATE_HZ if rate is None else rate


def damping_floor_rad_s(cfg: Section) -> float:
    """``w_F`` floor of forced response (``analysis.damping_floor_hz``) in rad/s."""
    return 2 * math.pi * analysis_settings(cfg).damping_floor_hz


# -- reading -----------------------------------------------------------------------------------
def _settings_class(tp) -> type | None:
    return tp if isinstance(tp, type) and dataclasses.is_dataclass(tp) else None


def _options(tp) -> tuple:
    """The alternatives of a union type (``X | None`` -> ``(X, NoneType)``), else ``(tp,)``."""
    if isinstance(tp, types.UnionType) or typing.get_origin(tp) is typing.Union:
        return typing.get_args(tp)
    return (tp,)


def _read_value(sec: Section, key: str, tp, meta: dict):
    value = sec.raw(key)
    kinds = [t for t in _options(tp) if t is not type(None)]
    if value is None and len(kinds) < len(_options(tp)):
        return None
    kind = kinds[0]
    if str in kinds and float in kinds:                # a number or one of the named choices
        kind = str if isinstance(value, str) else float
    cls = _settings_class(kind)
    if cls is not None:
        return read_settings(cls, sec.section(key))
    if typing.get_origin(kind) is dict:                 # named entries: name -> value
        sub, item = sec.section(key), typing.get_args(kind)[1]
        return {name: _read_value(sub, name, item, meta) for name in sub.keys()}
    if kind is float:
        return sec.number(key, positive=meta["positive"], nonnegative=meta["nonnegative"],
                          minimum=meta["minimum"], maximum=meta["maximum"], unit=meta["unit"])
    if kind is int:
        return sec.integer(key, minimum=meta["minimum"], maximum=meta["maximum"])
    if kind is dict:
        return sec.section(key).data
    if kind is bool:
        if not isinstance(value, bool):
            raise sec.error(key, f"must be true or false (got {value!r})")
        return value
    if kind is str:
        return sec.choice(key, meta["choices"]) if meta["choices"] else sec.string(key)
    item = typing.get_args(kind)[0]
    if _settings_class(item) is not None:             # a list of entries, each as key[i]
        if not isinstance(value, list) or len(value) < meta["min_length"]:
            raise sec.error(key, f"must be a list of at least {max(meta['min_length'], 0)} "
                            f"mapping(s) (got {value!r})", fix=f"write {key}: [{{...}}, ...]")
        entries = Section({f"{key}[{i}]": v for i, v in enumerate(value)}, sec.path, sec.source)
        return tuple(read_settings(item, entries.section(k)) for k in entries.keys())
    if item is float:
        return tuple(sec.number_list(key, min_length=meta["min_length"]))
    if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
        raise sec.error(key, f"must be a list of names (got {value!r})", fix="write [a, b, ...]")
    return tuple(value)


def read_settings(cls, sec: Section):
    """Validate a config section into a frozen ``cls`` (unknown keys refused, defaults filled)."""
    hints = typing.get_type_hints(cls)
    fields = dataclasses.fields(cls)
    sec.check_keys(f.name for f in fields)
    values = {}
    for f in fields:
        if sec.has(f.name):
            values[f.name] = _read_value(sec, f.name, hints[f.name], f.metadata)
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            sec.raw(f.name)                                  # raises "missing" with the fix
    out = cls(**values)
    if hasattr(out, "check"):
        out.check(sec)
    return out


def read_part(cls, sec: Section):
    """:func:`read_settings` of the keys of ``sec`` that ``cls`` declares (a model family's
    top-level keys, next to the sections every config shares)."""
    return read_settings(cls, sec.only(f.name for f in dataclasses.fields(cls)))


# -- the reference -----------------------------------------------------------------------------
def _type_name(tp, meta: dict) -> str:
    names = []
    for t in _options(tp):
        if t is type(None):
            continue
        if t is str and meta["choices"]:
            names.append(" \\| ".join(f"`{c}`" for c in meta["choices"]))
        elif typing.get_origin(t) is tuple:
            names.append(f"list of {typing.get_args(t)[0].__name__}")
        elif t is dict or _settings_class(t) is not None:
            names.append("mapping")
        elif typing.get_origin(t) is dict:
            names.append("mapping of names")
        else:
            names.append(t.__name__)
    unit = f" [{meta['unit']}]" if meta["unit"] else ""
    return " or ".join(names) + unit


def _rows(cls, prefix: str):
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        path = f"{prefix}.{f.name}"
        kinds = [t for t in _options(hints[f.name]) if t is not type(None)]
        sub = _settings_class(kinds[0])
        origin = typing.get_origin(kinds[0])
        named = (_settings_class(typing.get_args(kinds[0])[1]) if origin is dict else None)
        listed = _settings_class(typing.get_args(kinds[0])[0]) if origin is tuple else None
        if listed is not None:
            yield path, "list of mappings", "", f.metadata["doc"]
            yield from _rows(listed, f"{path}[i]")
            continue
        if sub is not None or named is not None:
            yield path, "mapping" if sub else "mapping of names", "", f.metadata["doc"]
            yield from _rows(sub or named, path if sub else f"{path}.<name>")
            continue
        default = f.default
        if default is dataclasses.MISSING:
            default = "required"
        elif default is None:
            default = "none"
        elif isinstance(default, bool):
            default = f"`{str(default).lower()}`"
        else:
            default = f"`{list(default) if isinstance(default, tuple) else default}`"
        yield path, _type_name(hints[f.name], f.metadata), default, f.metadata["doc"]


def reference_markdown() -> str:
    """The declared sections as a markdown table (the README's configuration reference)."""
    lines = ["| key | type | default | what |", "|---|---|---|---|"]
    for name, cls in SECTIONS.items():
        lines += [f"| `{p}` | {t} | {d} | {w} |" for p, t, d, w in _rows(cls, name)]
    return "\n".join(lines)
