"""ISO 20816-3 zones of bearing-housing vibration: the zone boundaries against the standard's
Annex A tables (typed in here from the table), the band-limited r.m.s. against the hand value
of sinusoids (``sqrt(sum a_i^2 / 2)``) from velocity, acceleration and displacement records,
the sliding-window maximum fed whole and in pieces, and ``compare`` / ``runup`` on shipped
configurations (entries whose zone follows from their r.m.s., the exit status of a run-up whose
API 684 separation margin fails)."""
import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from rotor_avc.analysis.iso20816 import WindowMax, band_hz, band_rms, zone
from rotor_avc.cli import main
from rotor_avc.compare.iso_zones import iso_channels
from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.machine import load_machine

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"

#: ISO 20816-3:2022 Annex A = ISO 10816-3:2009 Tables A.1 (group 1) and A.2 (group 2):
#: (group, support) -> boundaries A/B, B/C, C/D in mm/s r.m.s.
TABLE = {(1, "rigid"): (2.3, 4.5, 7.1), (1, "flexible"): (3.5, 7.1, 11.0),
         (2, "rigid"): (1.4, 2.8, 4.5), (2, "flexible"): (2.3, 4.5, 7.1)}


def _zone_by_hand(rms_mm_s, group, support):
    ab, bc, cd = TABLE[(group, support)]
    return "A" if rms_mm_s <= ab else "B" if rms_mm_s <= bc else "C" if rms_mm_s <= cd else "D"


@pytest.mark.parametrize("group,support", sorted(TABLE))
def test_zones_change_at_the_tables_boundaries(group, support):
    assert zone(0.0, group, support) == "A"
    for boundary, below, above in zip(TABLE[(group, support)], "ABC", "BCD"):
        assert zone(boundary, group, support) == below          # a boundary: the lower zone
        assert zone(math.nextafter(boundary, 0.0), group, support) == below
        assert zone(math.nextafter(boundary, math.inf), group, support) == above
    assert zone(100.0, group, support) == "D"


def test_unknown_group_or_support_is_refused():
    for group, support in ((3, "rigid"), (1, "soft")):
        with pytest.raises(ModelError, match="group 1 or 2"):
            zone(1.0, group, support)


def test_band_follows_the_speed_and_the_sample_rate():
    assert band_hz(10.0, 5000.0) == (2.0, 1000.0)            # 600 r/min: 2 .. 1000 Hz
    assert band_hz(10.01, 5000.0) == (10.0, 1000.0)
    assert band_hz(50.0, 1000.0) == (10.0, 500.0)            # Nyquist below 1000 Hz


# two tones inside 10 .. 1000 Hz and two outside (5 Hz, 1500 Hz), whole cycles in 2 s at 5 kHz
FS, DURATION = 5000.0, 2.0
TONES = [(3e-3, 25.0, 0.4), (1.5e-3, 310.0, -1.1)]            # (m/s, Hz, rad)
OUTSIDE = [(4e-3, 5.0, 0.2), (2e-3, 1500.0, 0.7)]
BY_HAND = math.sqrt(sum(a ** 2 / 2 for a, _, _ in TONES))


def _signal(order):
    """The tones' velocity as displacement (0), velocity (1) or acceleration (2), analytically."""
    t = np.arange(int(FS * DURATION)) / FS
    y = np.zeros(t.size)
    for a, f, phi in TONES + OUTSIDE:
        w = 2 * np.pi * f
        # v = a cos(w t + phi); its (order - 1)-th derivative: a w^(k) cos(w t + phi + k pi/2)
        k = order - 1
        y += a * w ** k * np.cos(w * t + phi + k * np.pi / 2)
    return y


@pytest.mark.parametrize("order", [1, 2, 0], ids=["velocity", "acceleration", "displacement"])
def test_band_rms_is_the_tones_rms_by_hand(order):
    assert band_rms(_signal(order), 1 / FS, order, (10.0, 1000.0)) == pytest.approx(BY_HAND,
                                                                                    rel=1e-9)


def test_band_rms_counts_a_tone_at_the_nyquist_bin_once():
    n, T = 64, 1.0 / 64
    v = 2.0 * np.cos(np.pi * np.arange(n))                     # amplitude 2 at 32 Hz: rms 2
    assert band_rms(v, T, 1, (1.0, 32.0)) == pytest.approx(2.0, rel=1e-12)


def test_window_maximum_is_the_loudest_window_fed_whole_or_in_pieces():
    T, f = 1.0 / 1000.0, 50.0
    t = np.arange(4000) * T
    v = np.where(t < 2.0, 1.0, 3.0) * np.cos(2 * np.pi * f * t)   # amplitude 1, then 3
    whole, pieces = (WindowMax(1000, T, 1, (10.0, 500.0)) for _ in range(2))
    whole.add(v)
    whole.end()
    for piece in np.array_split(v, 7):
        pieces.add(piece)
    pieces.end()
    assert whole.max_rms == pytest.approx(3 / math.sqrt(2), rel=1e-12)
    assert pieces.max_rms == whole.max_rms and pieces.windows == whole.windows == 7
    short = WindowMax(1000, T, 1, (10.0, 500.0))                # a dwell shorter than a window
    short.add(v[:500])
    short.end()
    assert short.windows == 1 and short.max_rms == pytest.approx(1 / math.sqrt(2), rel=1e-12)


def _config(tmp_path, text: str) -> Path:
    path = tmp_path / "machine.yaml"
    path.write_text(f"include: {CONFIG / 'foot_mount_case3.yaml'}\n{text}")
    return path


@pytest.mark.parametrize("entry,field", [("{group: 3}", "group"), ("{support: soft}", "support"),
                                         ("{grup: 1}", "grup")])
def test_bad_values_are_refused_naming_the_field(tmp_path, entry, field):
    with pytest.raises(ConfigError, match=rf"analysis\.iso20816\.{field}"):
        load_machine(str(_config(tmp_path, f"analysis:\n  iso20816: {entry}\n")))


def test_declared_channels_must_be_outputs_of_the_plant(tmp_path):
    machine = load_machine(str(_config(tmp_path, "analysis:\n  iso20816: {channels: [rotor_x]}\n")))
    run = SimpleNamespace(machine=machine, channel_names=["bearing_D_vz"])
    with pytest.raises(ConfigError, match=r"analysis\.iso20816\.channels: 'rotor_x'"):
        iso_channels(run)
    default = SimpleNamespace(machine=load_machine("foot_mount_case3"),
                              channel_names=["bearing_D_vz", "foundation_DL_vz", "bearing_N_vx"])
    assert iso_channels(default) == ["bearing_D_vz", "bearing_N_vx"]


def test_compare_of_the_reference_bag_rates_the_declared_housings(tmp_path, capsys):
    bag = ROOT / "bags" / "reference" / "case3_stepped.mcap"
    config = _config(tmp_path, "analysis:\n  iso20816: {group: 1, support: flexible, channels: "
                               "[bearing_D_vz, bearing_N_vz]}\n")
    assert main(["compare", str(bag), "--config", str(config), "--out", str(tmp_path / "c")]) == 0
    entries = json.loads((tmp_path / "c" / "metrics.json").read_text())["iso20816"]
    assert [e["channel"] for e in entries] == ["bearing_D_vz", "bearing_N_vz"]
    for e in entries:
        assert (e["group"], e["support"]) == (1, "flexible")
        assert e["band_hz"] == [10.0, 500.0]                   # the bag's 1 kHz: Nyquist
        assert e["rms_mm_s"] > 0 and e["zone"] == _zone_by_hand(e["rms_mm_s"], 1, "flexible")
    text = capsys.readouterr().out
    assert "ISO 20816-3 (group 1, flexible support" in text and "Nyquist frequency 500" in text
    assert "ISO 20816-3 zones" in (tmp_path / "c" / "index.html").read_text()


def _runup_bag(tmp_path, stop_hz: float, duration_s: float) -> Path:
    """Werner 2021 case 2 (loops open) run up from rest at 2 kHz, recorded."""
    scenario = tmp_path / "runup.yaml"
    scenario.write_text(f"include: {CONFIG / 'foot_mount_case2.yaml'}\n"
                        "simulation:\n  sample_rate_hz: 2000.0\n  speed: {type: ramp, "
                        f"start_hz: 0.0, stop_hz: {stop_hz}, duration_s: {duration_s}}}\n"
                        "  unbalance:\n    static: {magnitude: 1.0e-2, phase_deg: 0.0}\n")
    bag = tmp_path / "runup.mcap"
    assert main(["simulate", str(scenario), "--out", str(bag)]) == 0
    return bag


def test_runup_rates_the_housings_and_exits_1_on_a_failing_separation_margin(tmp_path, capsys):
    """Run up to 28 Hz: the 24.8 Hz mode lies 8 % below an operating range of 27 .. 28 Hz, where
    API 684 requires about 16 %."""
    bag = _runup_bag(tmp_path, 28.0, 10.0)
    out = tmp_path / "views"
    args = ["runup", str(bag), "--out", str(out), "--channels", "bearing_D_vz"]
    assert main(args + ["--operating-hz", "27:28"]) == 1
    text = capsys.readouterr().out
    assert "-> API 684: FAIL" in text and "bearing_D_vz (model) at 24.8" in text
    data = json.loads((out / "metrics.json").read_text())
    assert data["api684"]["verdict"] == "FAIL" and data["api684"]["failed"]
    channels = [e["channel"] for e in data["iso20816"]]
    assert channels == [f"bearing_{p}_v{a}" for p in "DN" for a in "zyx"]
    for e in data["iso20816"]:
        assert (e["group"], e["support"], e["band_hz"]) == (2, "rigid", [10.0, 1000.0])
        assert e["zone"] == _zone_by_hand(e["rms_mm_s"], 2, "rigid")
    # the largest 1 s r.m.s. of a 1x sweep: near the largest 1x amplitude / sqrt(2), a little
    # below it where the window averages over the resonance's rise and fall
    api = json.loads((out / "api684.json").read_text())
    peak = max(r["peak"] for r in api["channels"]["bearing_D_vz"]["measured"])
    [d_vz] = [e for e in data["iso20816"] if e["channel"] == "bearing_D_vz"]
    assert 0.5 < d_vz["rms_mm_s"] / (1e3 * peak / math.sqrt(2)) < 1.05
    assert "ISO 20816-3 zones" in (out / "index.html").read_text()


def test_runup_below_every_critical_speed_passes(tmp_path, capsys):
    """Run up to 6 Hz, below the first mode (7.5 Hz): no failing row, exit 0."""
    bag = _runup_bag(tmp_path, 6.0, 12.0)
    out = tmp_path / "views"
    assert main(["runup", str(bag), "--out", str(out), "--channels", "bearing_D_vz"]) == 0
    assert "-> API 684: PASS" in capsys.readouterr().out
    data = json.loads((out / "metrics.json").read_text())
    assert data["api684"]["verdict"] == "PASS" and data["api684"]["failed"] == []
    assert all(e["band_hz"] == [2.0, 1000.0] for e in data["iso20816"])   # 360 r/min at most
