"""`rotor-avc compare` rates the complex response: a small lockstep bag of Werner 2021 case 3
(2 kHz) passes, and the same bag rewritten message by message with the faults a commissioning
check must catch fails (sign flips, a one-sample delay, dead channels) or gets no verdict
(exit status 5: all signals zero, the channels missing, every point unsettled); a gap is an
incomplete recording (exit 3) and a run cut short carries the "incomplete run" note. A run with
the adaptive harmonic controller passes only with its recorded forces driving the model (without
them, or with their sign flipped, it fails).

The delay cases check the phase against the analytic value of a pure delay: one sample late
is a phase of ``-360 f T`` degrees on the 1x of that channel (and ``+360 f T`` on an H1 whose
input is the late one)."""
import dataclasses
import json

import numpy as np
import pytest

from rotor_avc.bag import BagReader, BagWriter
from rotor_avc.bag.sequence import EXIT_INCOMPLETE
from rotor_avc.cli import main
from rotor_avc.compare.checks import (EXIT_NO_VERDICT, TOL_BAND_PHASE_RMS_DEG,
                                      TOL_PHASE_OFF_RESONANCE_DEG)
from rotor_avc.compare.comparison import compare_bag, compare_run
from rotor_avc.compare.recorded_run import read_run
from rotor_avc.config import find_config, load_yaml
from rotor_avc.recording import write_run_bag
from rotor_avc.scenario import scenario_from_config

RATE_HZ = 2000.0
SPEEDS_HZ = [30.0, 104.0]
FORCE = "/avc/foot/NL/actuator_force"
OBS = "/avc/plant/observables"
TEST = "/avc/plant/test_signal"


def case3(simulation: dict):
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"sample_rate_hz": RATE_HZ, "initial_state": "steady_state",
                          "unbalance": {"static": {"magnitude": 1.0e-2, "phase_deg": 0.0}},
                          **simulation}
    return scenario_from_config(data, "test")


@pytest.fixture(scope="module")
def stepped(tmp_path_factory):
    sc = case3({"speed": {"type": "stepped", "speeds_hz": SPEEDS_HZ, "dwell_s": 0.5,
                          "transition_s": 0.1}})
    return write_run_bag(tmp_path_factory.mktemp("verdicts") / "stepped.mcap", sc,
                         sc.run(progress=False))


@pytest.fixture(scope="module")
def broadband(tmp_path_factory):
    sc = case3({"speed": {"type": "constant", "speed_hz": 20.0}, "duration_s": 1.5,
                "test_signal": {"actuator": "DL", "kind": "white", "rms_n": 100.0,
                                "band_hz": [2.0, 400.0], "seed": 1}})
    return write_run_bag(tmp_path_factory.mktemp("verdicts") / "broadband.mcap", sc,
                         sc.run(progress=False))


def rewrite(src, dst, edit=lambda topic, msg, previous: msg, keep=lambda topic, t_s: True,
            topics=lambda topic: True):
    """Copy a bag message by message: ``edit(topic, message, previous message of the topic)``
    returns the message to write; ``keep(topic, t_s)`` False leaves it out; ``topics(topic)``
    False leaves the whole topic out (an empty recorded topic has lost its samples)."""
    with BagReader(src) as r, BagWriter(dst, {k: v for k, v in r.config.items()
                                             if k not in ("format", "package_version")}) as w:
        for name, info in r.topics.items():
            if topics(name):
                w.add_topic(name, info.msg_type)
        previous = {}
        for msg in r.messages():
            before = previous.setdefault(msg.topic, msg.data)
            if topics(msg.topic) and keep(msg.topic, msg.time_ns * 1e-9):
                w.write(msg.topic, edit(msg.topic, msg.data, before), msg.time_ns)
            previous[msg.topic] = msg.data
    return dst


def labels(msg) -> list[str]:
    return msg["layout"]["dim"][0]["label"].split(",")


def scaled(msg, factor, columns=lambda label: label != "time_s"):
    """A labelled array with the selected columns multiplied by ``factor``."""
    data = np.array(msg["data"], float)
    for i, label in enumerate(labels(msg)):
        if columns(label):
            data[i] *= factor
    return {**msg, "data": data}


def force(msg, factor):
    w = msg["wrench"]
    return {**msg, "wrench": {**w, "force": {**w["force"], "z": factor * w["force"]["z"]}}}


def run_cli(path, tmp_path, capsys):
    status = main(["compare", str(path), "--out", str(tmp_path / "report")])
    out = capsys.readouterr()
    assert "Traceback" not in out.err
    return status, out.out, json.loads((tmp_path / "report" / "metrics.json").read_text())


def checks_of(data) -> dict:
    return {c["name"]: c for c in data["checks"]}


def test_the_unchanged_bag_passes_on_magnitude_and_phase(stepped, tmp_path, capsys):
    status, out, data = run_cli(stepped, tmp_path, capsys)
    assert status == 0 and data["verdict"] == "PASS", out
    checks = checks_of(data)
    for name in ("1x phase error away from resonances", "1x phase error at resonances"):
        assert checks[name]["passed"] is True and checks[name]["value"] < 1.0
    assert "dead channels" not in checks


def test_a_sign_flip_on_one_channel_fails_on_phase_alone(stepped, tmp_path, capsys):
    bad = rewrite(stepped, tmp_path / "flip_one.mcap", lambda t, m, _: scaled(
        m, -1.0, lambda label: label == "bearing_D_vz") if t == OBS else m)
    status, out, data = run_cli(bad, tmp_path, capsys)
    assert status == 1 and "-> FAIL" in out
    checks = checks_of(data)
    assert checks["1x magnitude error away from resonances"]["passed"] is True
    phase = [c for n, c in checks.items() if n.startswith("1x phase error")]
    failed = [c for c in phase if c["passed"] is False]
    assert failed and all("bearing_D_vz" in c["detail"] for c in failed)
    assert max(c["value"] for c in failed) == pytest.approx(180.0, abs=1.0)


def test_every_measured_signal_sign_flipped_fails(stepped, tmp_path, capsys):
    bad = rewrite(stepped, tmp_path / "flip_all.mcap", lambda t, m, _: (
        scaled(m, -1.0) if t == OBS else force(m, -1.0) if t.endswith("actuator_force") else m))
    status, _, data = run_cli(bad, tmp_path, capsys)
    assert status == 1 and data["verdict"] == "FAIL"
    channels = data["one_x"]["channels"]
    for ch, per_model in channels.items():
        s = per_model["sampled"]
        if s.get("checked_points"):
            assert s["max_abs_phase_error_deg"] == pytest.approx(180.0, abs=1.0), ch


def test_a_force_one_sample_late_fails_with_the_phase_of_that_delay(stepped, tmp_path, capsys):
    bad = rewrite(stepped, tmp_path / "late.mcap",
                  lambda t, m, prev: ({**m, "wrench": prev["wrench"]} if t == FORCE else m))
    comp = compare_bag(bad)
    assert comp.verdict == "FAIL"
    one = comp.one_x
    f_hz = one.speed_rad_s / (2 * np.pi)
    phase = one.channels["sampled"]["actuator_NL_fz"]["phase_error_deg"]
    ok = np.isfinite(phase)
    assert ok.sum() >= 1
    np.testing.assert_allclose(phase[ok], -360.0 * f_hz[ok] / RATE_HZ, atol=0.5)
    assert np.abs(phase[ok]).max() > TOL_PHASE_OFF_RESONANCE_DEG
    others = [c for ch, c in one.channels["sampled"].items() if ch != "actuator_NL_fz"
              and c.get("checked_points")]
    assert others and all(np.nanmax(np.abs(c["phase_error_deg"])) < 1.0 for c in others)


def test_a_test_force_one_sample_late_fails_the_broadband_phase(broadband, tmp_path):
    good = compare_bag(broadband)
    assert good.verdict == "PASS"
    late = compare_bag(rewrite(broadband, tmp_path / "late_test.mcap",
                               lambda t, m, prev: prev if t == TEST else m))
    assert late.verdict == "FAIL"
    names = {c.name: c for c in late.checks}
    [phase] = [c for n, c in names.items() if n.startswith("broadband H1 phase RMS")]
    [mag] = [c for n, c in names.items() if n.startswith("broadband H1 band RMS")]
    assert phase.passed is False and phase.value > TOL_BAND_PHASE_RMS_DEG
    assert mag.passed is True               # a delay keeps the magnitude: only the phase sees it
    [bb] = late.broadband
    est, model = bb.estimate, bb.models["sampled"]
    lo, hi = bb.band_hz
    sel = (est.freq_hz >= max(lo, est.resolution_hz)) & (est.freq_hz <= hi)
    col = bb.outputs.index("foot_DL_az")
    coherent = est.coherence[sel, col] >= 0.98
    err = np.degrees(np.angle(est.h1[sel, col] / model.responses["foot_DL_az"]))[coherent]
    np.testing.assert_allclose(err, 360.0 * est.freq_hz[sel][coherent] / RATE_HZ, atol=2.0)


def test_a_dead_channel_fails(stepped, tmp_path, capsys):
    bad = rewrite(stepped, tmp_path / "dead.mcap", lambda t, m, _: scaled(
        m, 0.0, lambda label: label == "bearing_D_vz") if t == OBS else m)
    status, out, data = run_cli(bad, tmp_path, capsys)
    assert status == 1
    dead = checks_of(data)["dead channels"]
    assert dead["passed"] is False and dead["value"] == 1 and "bearing_D_vz" in dead["detail"]


def test_every_bearing_and_foundation_channel_zeroed_fails(stepped, tmp_path, capsys):
    zeroed = lambda label: label.startswith(("bearing_", "foundation_"))
    bad = rewrite(stepped, tmp_path / "dead_plant.mcap",
                  lambda t, m, _: scaled(m, 0.0, zeroed) if t == OBS else m)
    status, _, data = run_cli(bad, tmp_path, capsys)
    assert status == 1
    dead = checks_of(data)["dead channels"]
    with BagReader(stepped) as r:
        plant_channels = [label for label in r.series(OBS).labels if zeroed(label)]
    assert dead["passed"] is False and dead["value"] >= len(plant_channels) - 2
    assert all(ch in dead["detail"] for ch in ("bearing_D_vz", "foundation_NR_vz"))


def test_all_signals_zero_is_no_verdict(stepped, tmp_path, capsys):
    bad = rewrite(stepped, tmp_path / "zero.mcap", lambda t, m, _: (
        scaled(m, 0.0) if t == OBS else force(m, 0.0) if t.endswith("actuator_force") else m))
    status, out, data = run_cli(bad, tmp_path, capsys)
    assert status == EXIT_NO_VERDICT and data["verdict"] == "NO VERDICT"
    assert "every channel with a response is dead" in data["no_verdict_reason"]
    assert f"-> NO VERDICT ({data['no_verdict_reason']})" in out
    assert all(c["passed"] is None for c in data["checks"])


def test_missing_channels_is_no_verdict(stepped, tmp_path, capsys):
    def only_time(t, m, _):
        return {**m, "layout": {"dim": [{**m["layout"]["dim"][0], "label": "time_s",
                                         "size": 1, "stride": 1}]},
                "data": np.array(m["data"][:1])} if t == OBS else m
    bad = rewrite(stepped, tmp_path / "nochannels.mcap", only_time,
                  topics=lambda t: not t.endswith("actuator_force"))
    status, _, data = run_cli(bad, tmp_path, capsys)
    assert status == EXIT_NO_VERDICT
    assert "no channel the models describe" in " ".join(data["notes"])
    assert data["no_verdict_reason"].startswith("nothing to compare")


def test_a_gap_is_an_incomplete_recording(stepped, tmp_path, capsys):
    bad = rewrite(stepped, tmp_path / "gap.mcap", keep=lambda t, t_s: not (
        t == OBS and 0.3 <= t_s < 0.31))
    assert main(["compare", str(bad), "--out", str(tmp_path / "r")]) == EXIT_INCOMPLETE
    assert f"{OBS}: 20 sample(s) missing" in capsys.readouterr().err


def test_a_run_cut_at_53_percent_carries_the_incomplete_run_note(stepped, tmp_path, capsys):
    with BagReader(stepped) as r:
        end_s = r.time_range_ns[1] * 1e-9
    bad = rewrite(stepped, tmp_path / "cut.mcap", keep=lambda t, t_s: t_s < 0.53 * end_s)
    status, out, data = run_cli(bad, tmp_path, capsys)
    notes = [n for n in data["notes"] if n.startswith("incomplete run")]
    assert notes and "note: incomplete run" in out
    assert f"of the scenario's {round(end_s * RATE_HZ) + 1} samples" in notes[0]
    # what was recorded (the first dwell) is still rated, and agrees
    assert status == 0 and data["one_x"]["speeds_hz"] == [pytest.approx(SPEEDS_HZ[0], rel=1e-3)]


class Recording:
    """The harmonic controller block, keeping every force it answers with."""

    def __init__(self, block):
        self.block, self.forces = block, []

    def __getattr__(self, name):
        return getattr(self.block, name)

    def reset(self):
        self.forces = []
        self.block.reset()

    def step(self, *args):
        out = self.block.step(*args)
        self.forces.append(list(out))
        return out


@pytest.fixture(scope="module")
def harmonic(tmp_path_factory):
    """Case 3 plus adaptive harmonic control at 14 Hz, recorded as the ROS graph records it:
    the harmonic forces on harmonic/forces, the foot controllers' own on actuator_force."""
    data = load_yaml(find_config("scenario_harmonic_case3_steady"))
    data["simulation"].update(sample_rate_hz=RATE_HZ, duration_s=4.0)
    data["harmonic"]["start_s"] = 0.3
    sc = scenario_from_config(data, "test")
    block = Recording(sc.harmonic())
    ts = sc.run(progress=False, harmonic=block)
    forces = np.array(block.forces)
    for i, act in enumerate(block.actuator_ids):
        name = f"{act}_f{sc.machine.plant.actuator(act).axis}"
        ts.channels[f"harmonic_{name}"] = forces[:, i]
        ts.channels[f"actuator_{name}"] = ts.channels[f"actuator_{name}"] - forces[:, i]
    return write_run_bag(tmp_path_factory.mktemp("harmonic") / "harmonic.mcap", sc, ts)


def test_the_harmonic_controllers_forces_drive_the_model(harmonic):
    comp = compare_bag(harmonic)
    assert comp.verdict == "PASS"
    one = comp.one_x
    inputs = [ch for ch in one.measured if ch.startswith("harmonic_")]
    assert inputs == ["harmonic_DL_fz", "harmonic_DR_fz", "harmonic_NL_fz"]
    assert all("skipped" in one.channels["sampled"][ch] for ch in inputs)  # reported, not rated
    assert all(np.abs(one.measured[ch]).min() > 0 for ch in inputs)
    checked = {ch: c for ch, c in one.channels["sampled"].items() if c.get("checked_points")}
    assert len(checked) >= 8 and {"bearing_D_vy", "foundation_DL_vz"} <= set(checked)
    # without the harmonic forces the same run is not described by the feedback loop alone,
    # nor with their sign flipped
    run = read_run(harmonic)
    bare = {ch: v for ch, v in run.channels.items() if ch not in inputs}
    assert compare_run(dataclasses.replace(run, channels=bare)).verdict == "FAIL"
    flipped = {**run.channels, **{ch: -run.channels[ch] for ch in inputs}}
    assert compare_run(dataclasses.replace(run, channels=flipped)).verdict == "FAIL"


def test_every_point_unsettled_is_no_verdict(stepped):
    """Signals still growing at the end of every dwell: nothing is in steady state to rate."""
    run = read_run(stepped)
    growth = (run.time_s / run.time_s[-1]) ** 4
    growing = {ch: v * growth for ch, v in run.channels.items()}
    comp = compare_run(dataclasses.replace(run, channels=growing))
    assert comp.verdict == "NO VERDICT"
    assert comp.no_verdict_reason.startswith("every 1x point is left out")
    assert "not in steady state" in comp.no_verdict_reason


def test_a_dead_output_of_the_broadband_estimate_fails(broadband):
    run = read_run(broadband)
    channels = {**run.channels, "foot_DR_az": np.zeros_like(run.channels["foot_DR_az"])}
    comp = compare_run(dataclasses.replace(run, channels=channels))
    dead = next(c for c in comp.checks if c.name == "dead channels")
    assert comp.verdict == "FAIL" and dead.passed is False and "foot_DR_az" in dead.detail
    assert comp.broadband[0].channels["sampled"]["foot_DR_az"]["dead"]
