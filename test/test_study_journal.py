"""The journal of a study (rotor_avc.studies.journal) on hand-written files: what it writes
(two header lines, one line per point, every cell spelled as :func:`cell` spells it) and reads
back (cut-off last line dropped from the file, every other line checked, a refusal naming the
file, the line number and the fix), and an append that fails half way cut off again."""
import errno
import os

import numpy as np
import pytest

from rotor_avc.errors import ConfigError
from rotor_avc.output_files import OutputError
from rotor_avc.studies import journal as J
from rotor_avc.studies.points import ValueList
from rotor_avc.studies.spec import Outcome

POINTS = ValueList("g", [0.5, 1.25, 3.0])
COLUMNS = ["index", "g", "y", "big", "n", "error"]
FIELDS = {"y": float, "big": bool, "n": int}
HEAD = f"{J.HEADER}abc123\nindex,g,y,big,n,error\n"


def journal(path):
    return J.Journal(path, COLUMNS, "abc123", ["g"], FIELDS)


@pytest.mark.parametrize("value, text", [(None, ""), (True, "true"), (False, "false"),
                                         (0.1, "0.1"), (1e-300, "1e-300"), (np.float64(2.5), "2.5"),
                                         (np.int64(7), "7"), (np.bool_(True), "true"), (3, "3"),
                                         ("x", "x")])
def test_cells_are_spelled_once_and_read_back_exactly(value, text):
    assert J.cell(value) == text
    kind = {bool: bool, np.bool_: bool, float: float, np.float64: float, int: int,
            np.int64: int, str: str}.get(type(value))
    if kind is not None:
        back = J.parse_cell(text, kind)
        assert back == value and type(back) is kind
    assert J.parse_cell("", float) is None


@pytest.mark.parametrize("text, kind", [("1e0", float), ("0.10", float), ("True", bool),
                                        ("1", bool), ("07", int), (" 3", int)])
def test_another_spelling_of_a_cell_is_refused(text, kind):
    with pytest.raises(ValueError):
        J.parse_cell(text, kind)


def test_a_journal_is_written_and_read_back(tmp_path):
    path = tmp_path / "journal.csv"
    j = journal(path)
    assert j.read(POINTS) == {}                          # no file yet
    j.open()
    j.append([["2", "3.0", "0.25", "true", "4", ""]])
    j.append([["0", "0.5", "", "", "", "ValueError: no, really"]])
    j.close()
    assert path.read_text() == HEAD + "2,3.0,0.25,true,4,\n0,0.5,,,,\"ValueError: no, really\"\n"
    done = journal(path).read(POINTS)
    assert sorted(done) == [0, 2]
    assert done[2][1] == Outcome(2, {"y": 0.25, "big": True, "n": 4}, None)
    assert done[0][1] == Outcome(0, None, "ValueError: no, really")
    assert done[2][0] == ["2", "3.0", "0.25", "true", "4", ""]


def test_an_empty_journal_file_is_started_with_its_header(tmp_path):
    path = tmp_path / "journal.csv"
    path.write_bytes(b"")
    assert journal(path).read(POINTS) == {}
    j = journal(path)
    j.open()
    j.append([["1", "1.25", "1.5", "false", "0", ""]])
    j.close()
    assert path.read_text() == HEAD + "1,1.25,1.5,false,0,\n"


def test_a_journal_of_its_two_header_lines_holds_no_point(tmp_path):
    path = tmp_path / "journal.csv"
    path.write_text(HEAD)                            # created, stopped before the first point
    assert journal(path).read(POINTS) == {} and path.read_text() == HEAD


def test_a_cut_off_last_line_is_dropped_from_the_file(tmp_path):
    path = tmp_path / "journal.csv"
    path.write_text(HEAD + "1,1.25,1.5,false,0,\n2,3.0,0.2")
    done = journal(path).read(POINTS)
    assert sorted(done) == [1]
    assert path.read_text() == HEAD + "1,1.25,1.5,false,0,\n"      # the cut line is gone
    path.write_text(HEAD[:20])                                    # not even one whole line
    assert journal(path).read(POINTS) == {} and path.read_bytes() == b""


@pytest.mark.parametrize("text, line, problem", [
    ("# another program\nindex\n", 1, "is not the journal of a rotor-avc study"),
    (f"{J.HEADER}ffff\nindex,g,y,big,n,error\n", 1, "belongs to another study"),
    (f"{J.HEADER}abc123\n", 2, "has other columns than this study"),
    (f"{J.HEADER}abc123\nindex,g,y,big,error\n", 2, "has other columns than this study"),
    (HEAD + "1,1.25,1.5,false,0\n", 3, "5 cells where the study has 6 columns"),
    (HEAD + "1,1.25,1.5,false,0,\n\n", 4, "0 cells where the study has 6 columns"),
    (HEAD + "-1,3.0,1.5,false,0,\n", 3, "index '-1' is not a point number"),
    (HEAD + "01,1.25,1.5,false,0,\n", 3, "index '01' is not a point number"),
    (HEAD + "3,1.0,1.5,false,0,\n", 3, "index 3 is not a point of this study"),
    (HEAD + "1,1.25,1.5,false,0,\n1,1.25,1.5,false,0,\n", 4, "point 1 is in the journal twice"),
    (HEAD + "1,1.5,1.5,false,0,\n", 3, "g = '1.5', but point 1 of this study has '1.25'"),
    (HEAD + "1,1.25,1.50,false,0,\n", 3, "y: '1.50' is not written as this study writes a float"),
    (HEAD + "1,1.25,1.5,yes,0,\n", 3, "big: 'yes' is not true or false"),
    (HEAD + "1,1.25,1.5,false,0.5,\n", 3, "n: invalid literal"),
    (HEAD + "1,1.25,,,,Err: x\n0,0.5,1.0,true,2,Err: y\n", 4,
     "a failed point with record values"),
])
def test_a_line_this_study_did_not_write_is_refused_with_its_number(tmp_path, text, line,
                                                                    problem):
    path = tmp_path / "journal.csv"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        journal(path).read(POINTS)
    message = str(err.value)
    assert err.value.field == "--out" and f"{path} line {line}: {problem}" in message
    if line > 2:
        assert "delete that line (its point is computed again)" in message


@pytest.mark.parametrize("data, line, problem", [
    (HEAD.encode() + b"1,1.25,\x00\n", 3, "holds NUL bytes"),
    (HEAD.encode() + b"\x00\n", 3, "holds NUL bytes"),              # the line's first byte
    (HEAD.encode() + b"1,1.25,1.5,false,0,\n2,\xff\n", 4, "is not UTF-8 text"),
    (HEAD.encode() + b"1,1.25,1.5,false,0,\n\xff\n", 4, "is not UTF-8 text")])
def test_bytes_that_are_no_text_are_refused_with_their_line(tmp_path, data, line, problem):
    path = tmp_path / "journal.csv"
    path.write_bytes(data)
    with pytest.raises(ConfigError, match=rf"line {line}: {problem}"):
        journal(path).read(POINTS)


def test_an_append_that_fails_half_way_is_cut_off_again(tmp_path, monkeypatch):
    path = tmp_path / "journal.csv"
    j = journal(path)
    j.open()
    j.append([["0", "0.5", "1.0", "true", "1", ""]])
    whole = path.read_bytes()
    real_write = os.write

    def half_then_full(fd, data):
        real_write(fd, bytes(data[:7]))
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(J.os, "write", half_then_full)
    with pytest.raises(OutputError, match="journal.csv"):
        j.append([["1", "1.25", "1.5", "false", "0", ""], ["2", "3.0", "2.5", "true", "9", ""]])
    assert path.read_bytes() == whole                    # the part written is cut off again
    monkeypatch.setattr(J.os, "write", real_write)
    j.append([["2", "3.0", "2.5", "true", "9", ""]])    # and the next append follows whole lines
    j.close()
    assert sorted(journal(path).read(POINTS)) == [0, 2]


def test_writes_of_part_of_the_buffer_are_continued(tmp_path, monkeypatch):
    path = tmp_path / "journal.csv"
    j = journal(path)
    j.open()
    real_write = os.write
    monkeypatch.setattr(J.os, "write", lambda fd, data: real_write(fd, bytes(data[:5])))
    j.append([["1", "1.25", "1.5", "false", "0", ""], ["0", "0.5", "1.0", "true", "1", ""]])
    j.close()
    assert path.read_text() == HEAD + "1,1.25,1.5,false,0,\n0,0.5,1.0,true,1,\n"


def test_each_append_is_synced_to_the_disk_and_close_releases_the_file(tmp_path, monkeypatch):
    path = tmp_path / "journal.csv"
    j = journal(path)
    j.open()
    fd = j._fd
    synced = []
    real_fsync = os.fsync
    monkeypatch.setattr(J.os, "fsync", lambda f: (synced.append(f), real_fsync(f)))
    j.append([["0", "0.5", "1.0", "true", "1", ""]])
    j.append([["1", "1.25", "1.5", "false", "0", ""]])
    assert synced == [fd, fd]
    j.close()
    with pytest.raises(OSError):
        os.fstat(fd)                                     # the descriptor is closed
    j.close()                                            # and closing again is harmless
