"""The study engine: point sets (grids, seeded samples checked against scipy.stats), identical
results across backends and batch sizes, recorded failures, resuming, and the robustness study
against a direct evaluation of the sampled machine."""
import io
import json
import os
import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest
import scipy.stats

from rotor_avc.analysis.poles import machine_poles
from rotor_avc.analysis.robustness import robustness_point, wilson_interval
from rotor_avc.cli import main
from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.config import find_config, load_config
from rotor_avc.errors import ConfigError
from rotor_avc.machine import load_machine
from rotor_avc.studies.backends import BackendError, ProcessBackend, SerialBackend
from rotor_avc.studies.engine import StudySpec, run_study
from rotor_avc.studies.points import Grid, Sample, parse_sample, parse_vary
from rotor_avc.studies.progress import Progress

KZ = "foundation.stiffness_n_per_m.z"
MASS = "machine.stator_mass_kg"
SPEEDS_HZ = np.linspace(1.0, 250.0, 150)


@pytest.fixture(scope="module")
def case3():
    return load_config("foot_mount_case3")


def robustness_spec(cfg, n=12, seed=7, samples=(f"{KZ}*=normal(1, 0.15)",
                                                 f"{MASS}*=uniform(0.9, 1.1)")):
    sample = Sample([parse_sample(s) for s in samples], n, seed, cfg)
    return StudySpec(sample, robustness_point(cfg, SPEEDS_HZ))


@pytest.mark.parametrize("text, dist", [
    ("a.b=normal(3.0, 0.5)", scipy.stats.norm(3.0, 0.5)),
    ("a.b=uniform(-1, 4)", scipy.stats.uniform(-1, 5)),
    ("a.b=lognormal(0.2, 0.3)", scipy.stats.lognorm(0.3, scale=np.exp(0.2))),
])
def test_sampled_values_follow_the_distribution(text, dist):
    """2,000 points of one axis pass a Kolmogorov-Smirnov test against scipy.stats' law."""
    cfg = load_config("foot_mount_case3")
    axis = parse_sample(text.replace("a.b", KZ))
    sample = Sample([axis], 2000, 11, cfg)
    values = np.array([sample.point(i).values[axis.label] for i in range(len(sample))])
    assert scipy.stats.kstest(values, dist.cdf).pvalue > 1e-3
    assert np.all(values == [sample.point(i).overrides[KZ] for i in range(len(sample))])


def test_a_point_depends_on_seed_and_index_only(case3):
    sample = Sample([parse_sample(f"{KZ}*=normal(1, 0.1)"), parse_sample(f"{MASS}=uniform(7e3, 8e3)")],
                    50, 3, case3)
    forward = [sample.point(i).values for i in range(50)]
    assert [sample.point(i).values for i in reversed(range(50))] == forward[::-1]
    assert sample.point(17).overrides[KZ] == pytest.approx(1.44e9 * forward[17][f"{KZ} (factor)"])
    other = Sample(sample.axes, 50, 4, case3)
    assert other.point(17).values != forward[17]
    assert len({tuple(v.values()) for v in forward}) == 50


def test_the_seed_derivation_is_the_documented_one(case3):
    """Point ``i`` draws, in axis order, from ``default_rng(SeedSequence(seed, spawn_key=(i,)))``
    (the module's stated derivation: a study's points can be reproduced without rotor_avc)."""
    sample = Sample([parse_sample(f"{KZ}*=normal(1, 0.1)"), parse_sample(f"{MASS}=uniform(7e3, 8e3)"),
                     parse_sample("foundation.tan_delta=lognormal(-3.2, 0.2)")], 5, 2026, case3)
    for i in (0, 1, 4):
        rng = np.random.default_rng(np.random.SeedSequence(2026, spawn_key=(i,)))
        expected = [rng.normal(1.0, 0.1), rng.uniform(7e3, 8e3), rng.lognormal(-3.2, 0.2)]
        assert list(sample.point(i).values.values()) == expected, i


def test_grid_numbers_points_like_ndindex(case3):
    grid = Grid([parse_vary(f"{KZ}*=0.5:1.5:3"), parse_vary(f"{MASS}=[7000, 7500]")], case3)
    expected = [(0.5 * 1.44e9 * (1 + k), m) for k in range(3) for m in (7000.0, 7500.0)]
    got = [(grid.point(i).overrides[KZ], grid.point(i).overrides[MASS]) for i in range(6)]
    assert np.allclose(got, expected, rtol=1e-15)
    assert [tuple(grid.point(i).values.values()) for i in range(6)] == [
        (x, m) for x in (0.5, 1.0, 1.5) for m in (7e3, 7.5e3)]


@pytest.mark.parametrize("text, message", [
    ("x.y=normal(1)", "need finite mean, std"),
    ("x.y=normal(1, -2)", "STD >= 0"),
    ("x.y=uniform(2, 1)", "HIGH > LOW"),
    ("x.y=gauss(0, 1)", "is not one of normal(mean, std)"),
    ("x.y=normal(a, 1)", "not numbers"),
    ("x.y", "has no `="),
])
def test_sample_axis_errors_name_the_option(text, message):
    with pytest.raises(ConfigError, match="--sample") as err:
        parse_sample(text)
    assert message in str(err.value)


def test_sample_refuses_unknown_paths(case3):
    with pytest.raises(ConfigError, match="fundation"):
        Sample([parse_sample("fundation.mass_kg=normal(10, 1)")], 5, 0, case3)


def test_backends_and_batch_sizes_give_the_same_bytes(case3, tmp_path):
    spec = robustness_spec(case3)
    serial = run_study(spec, SerialBackend(), out=tmp_path / "serial", batch_size=12, progress=False)
    pool = run_study(spec, ProcessBackend(2), out=tmp_path / "pool", batch_size=1, progress=False)
    assert serial.outcomes == pool.outcomes and not serial.failed
    for name in ("points.csv", "points.npz"):
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / "pool" / name).read_bytes()
    table = np.load(tmp_path / "pool" / "points.npz")
    assert np.array_equal(table["index"], np.arange(12))
    assert np.array_equal(table["stability_margin_1_per_s"],
                          [o.record["stability_margin_1_per_s"] for o in pool.outcomes])


def test_a_failing_point_is_recorded_and_the_study_goes_on(case3, tmp_path):
    """Foundation stiffnesses drawn around zero: the negative ones fail, the others run."""
    spec = robustness_spec(case3, n=10, samples=(f"{KZ}=uniform(-1.0e+9, 2.0e+9)",))
    run = run_study(spec, ProcessBackend(2), out=tmp_path, batch_size=2, progress=False)
    draws = [spec.points.point(i).overrides[KZ] for i in range(10)]
    assert [o.error is not None for o in run.outcomes] == [k <= 0 for k in draws]
    assert 0 < len(run.failed) < 10
    assert all("stiffness_n_per_m" in o.error for o in run.failed)
    table = np.load(tmp_path / "points.npz")
    failed = table["error"] != ""
    assert np.all(np.isnan(table["max_real_1_per_s"][failed]))
    assert np.all(np.isfinite(table["max_real_1_per_s"][~failed]))


def test_an_interrupted_study_resumes_without_recomputing(case3, tmp_path):
    spec = robustness_spec(case3)
    run_study(spec, SerialBackend(), out=tmp_path, progress=False)
    whole = (tmp_path / "points.csv").read_bytes()
    journal = tmp_path / "journal.csv"
    lines = journal.read_text().splitlines(keepends=True)     # two header lines, then points
    journal.write_text("".join(lines[:7]) + lines[7][:15])      # 5 points and a cut-off line
    (tmp_path / "points.csv").unlink()
    seen = []
    again = run_study(spec, ProcessBackend(2), out=tmp_path, progress=False, on_outcome=seen.append)
    done_before = {int(line.split(",")[0]) for line in lines[2:7]}
    assert again.computed == 12 - 5 and {o.index for o in seen}.isdisjoint(done_before)
    assert (tmp_path / "points.csv").read_bytes() == whole
    rows = journal.read_text().splitlines()[2:]
    assert sorted(int(r.split(",")[0]) for r in rows) == list(range(12))


@dataclass(frozen=True)
class EndsItsWorker:
    """The robustness evaluator, except that point 7 ends its worker process while the file
    ``trigger`` exists (a crash in the middle of a study); same study identity."""

    inner: object
    trigger: str

    @property
    def fields(self):
        return self.inner.fields

    def prepare(self):
        return self.inner.prepare()

    def evaluate(self, context, point):
        if point.index == 7 and os.path.exists(self.trigger):
            os._exit(3)
        return self.inner.evaluate(context, point)

    def describe(self):
        return self.inner.describe()


def test_a_crashed_worker_stops_the_study_and_the_rerun_completes_it(case3, tmp_path):
    spec = robustness_spec(case3)
    run_study(spec, SerialBackend(), out=tmp_path / "serial", progress=False)
    trigger = tmp_path / "crash"
    trigger.touch()
    crashing = StudySpec(spec.points, EndsItsWorker(spec.evaluator, str(trigger)))
    with pytest.raises(BackendError, match="run the same command again to resume"):
        run_study(crashing, ProcessBackend(2), out=tmp_path / "run", batch_size=1, progress=False)
    kept = (tmp_path / "run" / "points.csv").read_text().splitlines()[1:]
    assert 0 < len(kept) < 12 and not any(line.startswith("7,") for line in kept)
    trigger.unlink()
    again = run_study(crashing, ProcessBackend(2), out=tmp_path / "run", batch_size=1,
                      progress=False)
    assert again.computed == 12 - len(kept)
    for name in ("points.csv", "points.npz"):
        assert (tmp_path / "run" / name).read_bytes() == (tmp_path / "serial" / name).read_bytes()


def test_the_tables_are_rewritten_while_the_study_runs(case3, tmp_path, monkeypatch):
    monkeypatch.setattr("rotor_avc.studies.output.SNAPSHOT_S", 0.0)
    seen = []

    def look(outcome):                          # before the point is journaled
        if (tmp_path / "points.npz").exists():
            seen.append(np.load(tmp_path / "points.npz")["index"].tolist())

    run_study(robustness_spec(case3), SerialBackend(), out=tmp_path, batch_size=1,
              progress=False, on_outcome=look)
    assert seen and all(s == list(range(len(s))) and 0 < len(s) < 12 for s in seen)
    assert not list(tmp_path.glob("*.part"))


def test_a_larger_sample_on_the_folder_adds_points(case3, tmp_path):
    run_study(robustness_spec(case3, n=12), SerialBackend(), out=tmp_path / "whole", progress=False)
    run_study(robustness_spec(case3, n=5), SerialBackend(), out=tmp_path / "grown", progress=False)
    grown = run_study(robustness_spec(case3, n=12), ProcessBackend(2), out=tmp_path / "grown",
                      progress=False)
    assert grown.computed == 7
    assert (tmp_path / "grown" / "points.csv").read_bytes() == \
        (tmp_path / "whole" / "points.csv").read_bytes()
    fewer = run_study(robustness_spec(case3, n=3), SerialBackend(), out=tmp_path / "grown",
                      progress=False)
    assert fewer.computed == 0 and [o.index for o in fewer.outcomes] == [0, 1, 2]


def test_a_folder_of_another_study_is_refused(case3, tmp_path):
    run_study(robustness_spec(case3, n=3), SerialBackend(), out=tmp_path, progress=False)
    with pytest.raises(ConfigError, match="different study"):
        run_study(robustness_spec(case3, n=3, seed=8), SerialBackend(), out=tmp_path,
                  progress=False)


def test_robustness_record_matches_the_sampled_machine(case3, tmp_path):
    """A point's record equals the poles and FRF of a config file written with its values."""
    spec = robustness_spec(case3, n=4)
    run = run_study(spec, SerialBackend(), progress=False)
    point = spec.points.point(2)
    yaml_file = tmp_path / "sampled.yaml"
    yaml_file.write_text(f"include: {find_config('foot_mount_case3')}\n"
                         f"foundation: {{stiffness_n_per_m: {{z: {point.overrides[KZ]!r}}}}}\n"
                         f"machine: {{stator_mass_kg: {point.overrides[MASS]!r}}}\n")
    machine = load_machine(str(yaml_file))
    record = run.outcomes[2].record
    max_real = max(machine_poles(machine, 2 * np.pi * f).max_real for f in (0.0, 250.0))
    assert record["max_real_1_per_s"] == pytest.approx(max_real, rel=1e-12)
    assert record["stable"] == (max_real < 0)
    frf = unbalance_frf(machine.loop, 2 * np.pi * SPEEDS_HZ)
    peak = np.abs(frf.responses["bearing_N_vz_moment"])
    assert record["peak_bearing_N_vz_moment"] == pytest.approx(peak.max(), rel=1e-12)
    assert record["peak_speed_hz_bearing_N_vz_moment"] == SPEEDS_HZ[np.argmax(peak)]


@pytest.mark.parametrize("k, n", [(0, 20), (7, 20), (20, 20), (973, 1000)])
def test_wilson_interval_matches_scipy(k, n):
    ci = scipy.stats.binomtest(k, n).proportion_ci(0.95, method="wilson")
    assert wilson_interval(k, n) == pytest.approx((ci.low, ci.high), abs=1e-9)


def test_robustness_command_writes_table_plot_and_summary(tmp_path, capsys):
    out = tmp_path / "robust"
    argv = ["study", "robustness", "foot_mount_case3", "--sample", f"{KZ}*=normal(1, 0.2)",
            "--sample", f"{MASS}*=lognormal(0, 0.1)", "--n", "10", "--speed-hz", "1:250:150",
            "--workers", "1", "--out", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "probability" in text and "peak_bearing_D_vz_static" in text
    for name in ("points.csv", "points.npz", "journal.csv", "study.json", "summary.csv",
                 "summary.json", "robustness.png"):
        assert (out / name).is_file()
    summary = json.loads((out / "summary.json").read_text())
    table = np.load(out / "points.npz")
    assert summary["stability_probability"] == np.mean(table["stable"] == 1.0)
    assert summary["metrics"]["stability_margin_1_per_s"]["p50"] == pytest.approx(
        np.median(table["stability_margin_1_per_s"]))
    assert main(argv + ["--no-plots"]) == 0        # all done: nothing recomputed
    assert "(0 computed in this run" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["robustness"], "no machine config"),
    (["robustness", "foot_mount_case3", "--sample", "x.y=normal(1, 0.1)"], "no section 'x'"),
    (["robustness", "foot_mount_case3"], "no distribution given"),
    (["robustness", "foot_mount_case3", "--sample", f"{KZ}*=normal(1, 0.1)", "--n", "0"], "--n"),
    (["robustness", "foot_mount_case3", "--sample", f"{KZ}*=normal(1, 0.1)", "--response",
      "bearing_q"], "choose from"),
    (["sleeve_bearing_motor", "--sample", f"{KZ}*=normal(1, 0.1)"], "--sample does not apply"),
    (["robustness", "foot_mount_case3", "--sample", f"{KZ}*=normal(1, 0.1)", "--gains", "1:2:2"],
     "--gains does not apply"),
])
def test_robustness_command_refusals(tmp_path, capsys, argv, message):
    assert main(["study"] + argv + ["--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err


def test_a_stability_map_resumes_from_its_folder(tmp_path, capsys):
    """Werner 2017's threshold over the bearing stiffness: the second run reads every point back
    and writes the same table."""
    argv = ["stability", "roller_bearing_stability", "--variant", "d", "--vary",
            "bearings.stiffness_n_per_m.z=1.0e+8:3.0e+8:3", "--out", str(tmp_path)]
    assert main(argv) == 0
    first = (tmp_path / "thresholds.csv").read_bytes()
    assert "resuming" not in capsys.readouterr().err
    assert main(argv) == 0
    assert "resuming: 3 of 3 points already done" in capsys.readouterr().err
    assert (tmp_path / "thresholds.csv").read_bytes() == first
    table = np.load(tmp_path / "points" / "points.npz")
    rows = first.decode().splitlines()[1:]
    assert [float(r.split(",")[1]) for r in rows] == table["threshold_rpm"].tolist()


def test_progress_lines_count_points_and_time_left():
    stream = io.StringIO()
    bar = Progress(200, resumed=50, stream=stream)
    for done in range(51, 201):
        bar.update(done)
    bar.close()
    lines = stream.getvalue().splitlines()
    assert lines[0] == "resuming: 50 of 200 points already done"
    assert 2 <= len(lines) <= 12                 # one line per tenth when not on a terminal
    assert "200/200 points" in lines[-1] and "ETA 00:00" in lines[-1]


def test_the_engine_imports_neither_ros_nor_dask():
    code = ("import sys, rotor_avc.studies.backends, rotor_avc.analysis.robustness, "
            "rotor_avc.studies.output; "
            "print(sorted(m for m in ('rclpy', 'distributed', 'dask') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
