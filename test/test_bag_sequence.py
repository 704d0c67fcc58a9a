"""Bags know what they should hold: a bag with missing samples on any sampled topic, or with
fewer messages recorded than published, gets one verdict naming the topic, the number of missing
samples and the time ranges, with its own exit status (3) from `rotor-avc compare` and `replay`,
before anything else; a complete bag passes the check, and a complete but shortened run is a
note."""
from pathlib import Path

import pytest

from rotor_avc.bag import BagReader, BagWriter
from rotor_avc.bag.sequence import EXIT_INCOMPLETE, check_sequence
from rotor_avc.cli import main
from rotor_avc.recording import write_run_bag
from rotor_avc.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
RATE_HZ = 5000.0


@pytest.fixture(scope="module")
def run_bag(tmp_path_factory):
    """A short in-process case-3 run (0.1 s at 5 kHz) as a bag, and its scenario."""
    folder = tmp_path_factory.mktemp("sequence")
    cfg = folder / "short.yaml"
    cfg.write_text(f"include: {ROOT / 'config' / 'scenario_case3_steady.yaml'}\n"
                   "simulation: {duration_s: 0.1}\n")
    sc = load_scenario(str(cfg))
    path = write_run_bag(folder / "run.mcap", sc, sc.run())
    return path, sc


def rewrite(src: Path, dst: Path, drop=lambda topic, k: False, published=None) -> Path:
    """Copy a bag message by message, leaving out the samples ``drop(topic, k)`` selects."""
    with BagReader(src) as r:
        config = {k: v for k, v in r.config.items() if k not in ("format", "package_version")}
        with BagWriter(dst, config) as w:
            for name, info in r.topics.items():
                w.add_topic(name, info.msg_type)
            for msg in r.raw_messages():
                if not drop(msg.topic, round(msg.time_ns * RATE_HZ * 1e-9)):
                    w.write_raw(msg.topic, msg.data, msg.time_ns)
            if published is not None:
                counts = w.recorded_counts
                w.close({t: published.get(t, n) for t, n in counts.items()})
    return dst


def test_a_complete_bag_passes_with_its_counts(run_bag):
    path, sc = run_bag
    with BagReader(path) as r:
        report = check_sequence(r, sc.n_steps)
        counts = r.counts
    assert report.ok and report.samples == sc.n_steps == 500 and not report.notes
    assert counts and all(c["published"] == c["recorded"] == 500 and c["lost"] == 0
                          for c in counts.values())


@pytest.mark.parametrize("command", ["compare", "replay"])
def test_missing_samples_get_one_verdict(run_bag, tmp_path, capsys, command):
    path, _ = run_bag
    force = "/avc/foot/NL/actuator_force"
    gapped = rewrite(path, tmp_path / "gapped.mcap",
                     drop=lambda t, k: t == force and (100 <= k < 150 or k == 321))
    args = [command, str(gapped)] + (["--out", str(tmp_path / "rep")] if command == "compare"
                                     else ["--fast"])
    status = main(args)
    err = capsys.readouterr().err
    assert status == EXIT_INCOMPLETE, err
    assert "Traceback" not in err and "incomplete" in err
    assert f"{force}: 51 sample(s) missing at 0.0200-0.0298 s, 0.0642 s" in err
    assert "/avc/foot/DL/actuator_force" not in err          # only the topic with gaps
    assert not (tmp_path / "rep").exists()


def test_published_but_not_recorded_is_named(run_bag, tmp_path, capsys):
    path, _ = run_bag
    short = rewrite(path, tmp_path / "short.mcap", published={"/clock": 507})
    with BagReader(short) as r:
        report = check_sequence(r)
    assert not report.ok and report.unrecorded == {"/clock": (507, 500)}
    assert main(["compare", str(short), "--out", str(tmp_path / "rep")]) == EXIT_INCOMPLETE
    assert "/clock: 500 of 507 published messages recorded (7 missing)" in capsys.readouterr().err


def test_every_topic_cut_at_the_same_sample_is_a_shortened_run(run_bag, tmp_path):
    path, sc = run_bag
    cut = rewrite(path, tmp_path / "cut.mcap", drop=lambda t, k: k >= 265)
    with BagReader(cut) as r:
        report = check_sequence(r, sc.n_steps)
    assert report.ok and report.samples == 265
    assert report.notes == ["incomplete run: 265 of the scenario's 500 samples (0.053 of 0.1 s) "
                            "were recorded"]
