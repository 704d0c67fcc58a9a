"""The lockstep account of a run, free of ROS: the answer book counts the samples a fault policy
stood in for and answers that changed (rotor_avc.nodes.lockstep), the ``rotor_avc_lockstep``
record round-trips through a bag (rotor_avc.bag.lockstep), and a bag whose record says the run
was not lockstep fails ``bag check``, is refused by ``compare`` (exit status 6) and fails
``replay --check`` -- each naming the samples."""
import contextlib
import io

import pytest

from rotor_avc.bag import BagReader
from rotor_avc.bag.check import check_bag
from rotor_avc.bag.lockstep import (EXIT_NOT_LOCKSTEP, LOCKSTEP_RECORD, RANGES_KEPT,
                                    LockstepRecord, SampleRanges, merge_reports)
from rotor_avc.bag.writer import BagWriter
from rotor_avc.cli import main
from rotor_avc.nodes.lockstep import AnswerBook


def test_wait_is_the_default_and_never_steps_without_an_answer():
    book = AnswerBook(("DL", "DR"))
    assert book.policy == "wait"
    book.begin(0, 0.0, 0)
    book.receive("DR", 0, 2.0)
    assert book.poll(3600.0)[1] == []           # nobody becomes absent, however long
    assert not book.ready() and book.absent() == []
    assert book.waiting(3600.0) == (["DL"], 3600.0)
    assert book.receive("DL", 0, 1.0) and book.settle() == []
    assert book.substituted.count == 0 and book.changed.count == 0


def test_the_samples_a_policy_stood_in_for_are_counted():
    book = AnswerBook(("DL", "DR"), "hold", timeout_s=1.0)
    for k in range(6):
        book.begin(200 * k, 10.0 * k, k)
        book.receive("DR", 200 * k, 1.0)
        if k in (2, 3, 5):                      # DL silent at samples 2, 3 and 5
            book.poll(10.0 * k + 1.5)
        else:
            book.receive("DL", 200 * k, 0.5)
        assert book.ready()
        assert book.settle() == (["DL"] if k in (2, 3, 5) else [])
    assert book.substituted.count == 3 and book.substituted.text == "2-3, 5"
    assert book.responders["DL"].substituted == 3 and book.responders["DR"].substituted == 0


def test_an_answer_that_changes_is_counted_and_the_first_stands():
    book = AnswerBook(("DL",))
    book.begin(0, 0.0, 0)
    book.receive("DL", 0, 1.0)
    book.receive("DL", 0, 1.0)                  # a resend answered alike: not a change
    assert book.changed.count == 0
    assert not book.receive("DL", 0, 2.0) and book.value("DL", 0.0) == 1.0
    assert book.changed.text == "0"
    book.settle()
    book.begin(200, 1.0, 1)
    assert not book.receive("DL", 0, 1.0)       # the stepped sample answered alike again
    assert not book.receive("DL", 0, 3.0)       # ... and differently
    assert book.changed.count == 1 and book.responders["DL"].changed == 2


def test_sample_ranges_keep_the_first_ranges_and_count_every_sample():
    r = SampleRanges()
    for k in [1, 2, 3, 3, 7] + list(range(10, 10 + 2 * (RANGES_KEPT + 5), 2)):
        r.add(k)
    assert r.count == 4 + RANGES_KEPT + 5
    assert r.text.startswith("1-3, 7, 10, 12") and r.text.endswith("and 7 more range(s)")
    assert len(r.ranges) == RANGES_KEPT


def record(**changes) -> LockstepRecord:
    base = dict(plant="plant_simulator", mode="lockstep", fault_policy="wait", samples=4000)
    return LockstepRecord(**{**base, **changes})


def test_the_record_round_trips_and_says_what_broke_lockstep():
    ok = record()
    assert ok.ok and "every sample stepped" in ok.verdict()
    bad = record(fault_policy="hold", substituted=1669, substituted_at="1234-2902",
                 changed=1, changed_at="77", absent={"foot_controller_DL (DL)": "left the graph"})
    assert LockstepRecord.decode(bad.encode(), "x") == bad
    text = bad.verdict()
    for part in ("NOT LOCKSTEP", "'hold'", "1669 sample(s): 1234-2902", "77",
                 "foot_controller_DL (DL) left the graph"):
        assert part in text
    with pytest.raises(Exception, match="lockstep record is unreadable"):
        LockstepRecord.decode({"plant": "p"}, "bag.mcap")


def test_several_plants_reporting_is_not_lockstep():
    merged = merge_reports({"plant_a": record(samples=10).encode(),
                            "plant_b": record(plant="plant_b", samples=4000).encode()})
    assert merged.plant == "plant_b" and merged.other_plants == "plant_a" and not merged.ok
    assert merge_reports({}) is None


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    path = tmp_path_factory.mktemp("sim") / "sim.mcap"
    sc = tmp_path_factory.mktemp("sc") / "short.yaml"
    from rotor_avc.config import find_config
    sc.write_text(f"include: {find_config('scenario_case3_steady')}\n"
                  "simulation: {duration_s: 0.2}\n")
    assert main(["simulate", str(sc), "--out", str(path)]) == 0
    return path


def with_record(src, dst, rec: LockstepRecord):
    """``src``'s messages and configuration in a new bag ``dst`` carrying ``rec``."""
    with BagReader(src) as r:
        config = {k: v for k, v in r.config.items() if k not in ("format", "package_version")}
        with BagWriter(dst, config) as w:
            for topic, info in r.topics.items():
                w.add_topic(topic, info.msg_type)
            for msg in r.raw_messages():
                w.write_raw(msg.topic, msg.data, msg.time_ns)
            w.close(records={LOCKSTEP_RECORD: rec.encode()})
    return dst


def cli(*args):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([str(a) for a in args])
    return status, out.getvalue(), err.getvalue()


def test_a_lockstep_bag_passes_and_says_so(simulated, tmp_path):
    bag = with_record(simulated, tmp_path / "ok.mcap", record(samples=1000))
    lines = check_bag(bag)
    assert all(line.ok for line in lines), [str(x) for x in lines if not x.ok]
    assert any(line.name == "lockstep" for line in lines)
    assert not any(line.name == "lockstep" for line in check_bag(simulated))   # no record
    with BagReader(bag) as r:
        assert r.lockstep == record(samples=1000)


def test_a_bag_that_is_not_lockstep_is_said_so_by_every_command(simulated, tmp_path):
    bad = record(fault_policy="hold", substituted=1669, substituted_at="234-1902",
                 absent={"foot_controller_DL (DL)": "was absent 1 time(s)"})
    bag = with_record(simulated, tmp_path / "hold.mcap", bad)
    status, out, _ = cli("bag", "check", bag)
    assert status != 0 and "PROBLEM  lockstep" in out and "234-1902" in out
    status, out, err = cli("compare", bag, "--out", tmp_path / "cmp")
    assert status == EXIT_NOT_LOCKSTEP and "not a lockstep run" in err and "234-1902" in err
    assert "foot_controller_DL (DL)" in err and "PASS" not in out
    status, out, _ = cli("replay", bag, "--fast", "--check", "1e-12")
    assert status == 1 and "check: FAIL" in out and "234-1902" in out
