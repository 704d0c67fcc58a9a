"""Werner 2017 parameter studies: the maxima of the paper's Figs. 7-11 (Sec. 4.9), the digest's
isotropic-foundation and foot velocity-feedback studies (7.3, 9), the study mechanics (variants,
``--vary`` grammar) and the ``rotor-avc stability`` command."""
import json

import numpy as np
import pytest

from rotor_avc.analysis.stability_study import (Vary, machine_threshold, parse_vary, run_study,
                                                study_from_config, with_overrides, with_variants)
from rotor_avc.cli import main
from rotor_avc.config import find_config, load_config
from rotor_avc.errors import ConfigError

from browser_check import check_report

F, B, H = "foundation.stiffness_n_per_m", "bearings.stiffness_n_per_m", "housings.stiffness_n_per_m"


@pytest.fixture(scope="module")
def base():
    return load_config("roller_bearing_stability")


def threshold_rpm(cfg, variants=(), **paths):
    overrides = {k.replace("__", "."): v for k, v in paths.items()}
    return machine_threshold(with_overrides(with_variants(cfg, variants), overrides, "t"))[1].threshold_rpm


# -- the paper's figures (Sec. 4.9) ---------------------------------------------------------------
@pytest.mark.parametrize("variants, section, z, y, stated", [
    ([], F, 5.14e8, 7.5e8, 143000),             # Fig. 7
    ([], B, 3.0e8, 1.0e8, 65200),               # Fig. 8
    ([], H, 1.05e9, 3.5e8, 37800),              # Fig. 9
])
def test_soft_foundation_maxima_at_the_stated_points(base, variants, section, z, y, stated):
    n = threshold_rpm(base, variants, **{section.replace(".", "__"): {"z": z, "y": y}})
    assert n == pytest.approx(stated, rel=0.05)
    assert n == pytest.approx(stated, rel=0.01)          # the digest reproduces them to 0.3 %


@pytest.mark.parametrize("section, lo, hi, stated", [
    (B, 1.0e8, 3.0e8, 29000),                   # Fig. 10 (rigid foundation)
    (H, 3.5e8, 1.05e9, 9900),                   # Fig. 11 (rigid foundation)
])
def test_rigid_foundation_maxima_at_orthotropic_corners(base, section, lo, hi, stated):
    """Figs. 10/11: maxima at an orthotropic corner; with a rigid foundation z <-> y is a
    symmetry, the isotropic corners are far lower."""
    key = section.replace(".", "__")
    corner = {(z, y): threshold_rpm(base, ["d"], **{key: {"z": z, "y": y}})
              for z in (lo, hi) for y in (lo, hi)}
    assert max(corner.values()) == pytest.approx(stated, rel=0.05)
    assert corner[(lo, hi)] == pytest.approx(corner[(hi, lo)], rel=1e-6)
    assert corner[(lo, lo)] < 0.5 * stated and corner[(hi, hi)] < 0.5 * stated


def test_soft_foundation_breaks_the_z_y_symmetry(base):
    """Digest 7.2: on the soft foundation the swapped corners of Figs. 8/9 are far lower
    (11.6 and 16.5 krpm against 65.2 and 37.8 krpm)."""
    n_b = threshold_rpm(base, **{B.replace(".", "__"): {"z": 1e8, "y": 3e8}})
    n_h = threshold_rpm(base, **{H.replace(".", "__"): {"z": 3.5e8, "y": 1.05e9}})
    assert n_b == pytest.approx(11.6e3, rel=0.02) and n_h == pytest.approx(16.5e3, rel=0.02)


@pytest.mark.parametrize("study, stated, corner", [
    ("fig8", 65200, (3.0e8, 1.0e8)), ("fig9", 37800, (1.05e9, 3.5e8)),
    ("fig10", 29000, None), ("fig11", 9900, None)])
def test_figure_maps_reach_the_stated_maxima(base, full, study, stated, corner):
    """The grid maximum of each map is the paper's maximum (5 %) at the paper's corner."""
    cfg, varies = study_from_config(base, study)
    if not full:                                  # short form: a 3 x 3 grid over the same range
        varies = [Vary(v.paths, np.linspace(v.values[0], v.values[-1], 3)) for v in varies]
    result = run_study(cfg, varies)
    best = result.maximum()
    assert best["threshold_rpm"] == pytest.approx(stated, rel=0.05)
    assert all(s == "threshold" for s in result.status.ravel())
    if corner is not None:
        assert (best[varies[0].label], best[varies[1].label]) == pytest.approx(corner)


def test_fig7_rises_to_about_143000_before_the_cliff(base, full):
    """Along c_fy = 7.5e8 the threshold rises with c_fz to ~143-145 krpm near 5.14-5.2e8 and
    then falls off a cliff (digest 7.2: ~104 krpm at 5.20e8, 69.7 krpm at 6e8)."""
    c_fz = np.linspace(4.6e8, 5.3e8, 36 if full else 8)
    n = np.array([threshold_rpm(base, **{F.replace(".", "__"): {"z": z, "y": 7.5e8}}) for z in c_fz])
    assert n.max() == pytest.approx(143000, rel=0.05)
    assert c_fz[np.argmax(n)] == pytest.approx(5.14e8, rel=0.02)
    n_6 = threshold_rpm(base, **{F.replace(".", "__"): {"z": 6e8, "y": 7.5e8}})
    assert n_6 == pytest.approx(69.7e3, rel=0.01)


# -- the digest's extensions -----------------------------------------------------------------------
ISOTROPIC = {2e7: 4426, 5e7: 5419, 1e8: 33224, 1.5e8: 22941, 2e8: 28901, 3e8: 53299, 4e8: 89975,
             5e8: 127305, 6e8: 75871, 7.5e8: 33190}


def test_isotropic_foundation(base, full):
    """Digest 7.3: every isotropic soft foundation beats the rigid one (3840 rpm), non-monotonically."""
    points = ISOTROPIC if full else {k: ISOTROPIC[k] for k in (2e7, 1e8, 5e8)}
    for k, n in points.items():
        assert threshold_rpm(base, **{F.replace(".", "__"): {"z": k, "y": k}}) == pytest.approx(n, rel=2e-3)


@pytest.mark.parametrize("study, expected", [
    ("velocity_feedback", [4426, 4699, 5204, 6680, 9620, 14747]),     # demo foundation (digest 9)
    ("velocity_feedback_rated", [26128, 26395, 27602, 28498, 30480]),  # rated machine (digest 7.3)
])
def test_foot_velocity_feedback_raises_the_threshold(base, study, expected):
    cfg, varies = study_from_config(base, study)
    result = run_study(cfg, varies)
    assert np.allclose(result.threshold_rpm, expected, rtol=1e-3)
    assert np.all(np.diff(result.threshold_rpm) > 0)


# -- mechanics -------------------------------------------------------------------------------------
def test_parse_vary_forms():
    v = parse_vary("a.b,c.d=1:3:3")
    assert v.paths == ("a.b", "c.d") and not v.scale and np.allclose(v.values, [1, 2, 3])
    v = parse_vary("x.y*=0.2:5:3:log")
    assert v.scale and np.allclose(v.values, [0.2, 1.0, 5.0])
    assert np.allclose(parse_vary("x=[0, 1.0e+4, 3e4]").values, [0, 1e4, 3e4])


@pytest.mark.parametrize("text", ["x.y", "x=1:2", "x=1:2:0", "x=a:b:3", "x=1:2:3:lin", "=1:2:3",
                                  "x=-1:2:3:log", "x=[1, a]", "x,=1:2:2"])
def test_parse_vary_errors_name_the_option(text):
    with pytest.raises(ConfigError) as err:
        parse_vary(text)
    assert err.value.field == "--vary" and "START:STOP:N" in err.value.fix


def test_overrides_and_variants_are_checked(base):
    with pytest.raises(ConfigError, match="no section 'fundation'"):
        with_overrides(base, {"fundation.kind": "rigid"}, "--vary")
    with pytest.raises(ConfigError, match="no such variant"):
        with_variants(base, ["f"])
    with pytest.raises(ConfigError, match="no such study"):
        study_from_config(base, "fig12")
    with pytest.raises(ConfigError, match="not a number"):
        Vary(("foundation.kind",), np.array([2.0]), scale=True).overrides(base, 2.0, "--vary")
    # a misspelt leaf is caught by the model's validation
    with pytest.raises(ConfigError, match="unknown key"):
        machine_threshold(with_overrides(base, {"rotor.mass": 900.0}, "--vary"))
    assert base.data["foundation"]["kind"] == "soft"          # overrides never touch the original


def test_factor_scales_the_base_values(base):
    cfg, varies = study_from_config(base, "foundation_factor")
    ov = varies[0].overrides(cfg, 0.2, "t")
    assert ov == {f"{F}.z": pytest.approx(3e7), f"{F}.y": pytest.approx(2e7)}


# -- the command -------------------------------------------------------------------------------------
def test_cli_json_single(capsys):
    assert main(["stability", "roller_bearing_stability", "--variant", "d", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"threshold_rpm", "whirl_rad_s", "critical_mode"}
    assert out["threshold_rpm"] == pytest.approx(3840, rel=2e-3) and out["critical_mode"] == 1


def test_cli_json_null_without_threshold(tmp_path, capsys):
    cfg = tmp_path / "capped.yaml"
    cfg.write_text(f"include: {find_config('roller_bearing_stability')}\n"
                   "analysis: {stability: {speed_max_rpm: 1000.0}}\n")
    assert main(["stability", str(cfg), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == {"threshold_rpm": None, "whirl_rad_s": None,
                                                   "critical_mode": None}


def test_cli_map_and_campbell_files(tmp_path, capsys):
    args = ["stability", "roller_bearing_stability", "--variant", "d", "--vary", f"{B}.z=1.0e+8:3.0e+8:2",
            "--vary", f"{B}.y=1.0e+8:3.0e+8:2", "--out", str(tmp_path / "map")]
    assert main(args) == 0
    assert "maximum" in capsys.readouterr().out
    rows = (tmp_path / "map" / "thresholds.csv").read_text().splitlines()
    assert len(rows) == 5 and "threshold_rpm" in rows[0]
    assert (tmp_path / "map" / "threshold_map.png").stat().st_size > 1000
    assert check_report(tmp_path / "map" / "index.html") == 1
    assert main(["stability", "roller_bearing_stability", "--variant", "demo", "--out",
                 str(tmp_path / "one")]) == 0
    assert "4426" in capsys.readouterr().out
    assert (tmp_path / "one" / "campbell.png").stat().st_size > 1000
    assert json.loads((tmp_path / "one" / "threshold.json").read_text())["status"] == "threshold"


@pytest.mark.parametrize("args, message", [
    (["--study", "fig8", "--vary", "x=1:2:2"], "both given"),
    (["--vary", "bearings.stiffness=1:2"], "--vary"),
    (["--variant", "nope"], "no such variant"),
])
def test_cli_errors_exit_2(capsys, args, message):
    assert main(["stability", "roller_bearing_stability"] + args) == 2
    assert message in capsys.readouterr().err
