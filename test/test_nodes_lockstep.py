"""The plant's side of the lockstep protocol (rotor_avc.nodes.lockstep.AnswerBook), free of ROS:
a sample completes when every present responder answered its stamp; silence beyond the timeout
makes a responder absent, with the fault policy standing in for its answer; in real time the
latest answer holds."""
import pytest

from rotor_avc.nodes.lockstep import AnswerBook


def test_a_sample_completes_when_every_present_responder_answered():
    book = AnswerBook(("DL", "DR"), "hold", timeout_s=1.0, resend_after_s=0.25)
    book.begin(200, now_s=0.0)
    assert not book.receive("DL", 200, 1.5) and not book.ready()
    assert not book.receive("DR", 400, 9.9)              # another stamp does not count
    assert book.receive("DR", 200, -2.0) and book.value("DR", 0.0) == -2.0
    assert book.poll(0.3) == (False, [])                 # complete: nothing to resend


@pytest.mark.parametrize("policy, substitute", [("hold", 1.5), ("zero", 0.0)])
def test_silence_makes_a_responder_absent_with_the_policy(policy, substitute):
    book = AnswerBook(("DL", "DR"), policy, timeout_s=1.0, resend_after_s=0.25)
    book.begin(0, 0.0)
    book.receive("DL", 0, 1.5)
    book.receive("DR", 0, 2.0)
    book.begin(200, 10.0)
    book.receive("DR", 200, 2.5)
    assert book.poll(10.3) == (True, [])                 # resend after resend_after_s
    assert book.poll(11.1) == (False, ["DL"]) and book.absent() == ["DL"]
    assert book.ready() and book.value("DL", 0.0) == substitute
    assert "no answer within 1 s" in book.reason("DL")
    assert not book.receive("DL", 0, 7.0)                # alive again, for the next sample
    assert book.absent() == [] and book.statuses()[0][:2] == ("DL", True)


def test_real_time_holds_the_latest_answer():
    book = AnswerBook(("DL",), "zero", timeout_s=0.5)
    assert book.held("DL", 0.0) == 0.0                   # nothing received yet
    book.latest("DL", 3.0)
    assert not book.expire("DL", 0.4) and book.held("DL", 0.0) == 3.0
    assert book.expire("DL", 0.6) and not book.expire("DL", 5.0)   # absent once, counted once
    assert book.held("DL", 0.0) == 0.0 and book.statuses() == [
        ("DL", False, "silent for more than 0.5 s; policy: zero", 1)]
    book.latest("DL", 4.0)
    assert book.held("DL", 0.0) == 4.0
