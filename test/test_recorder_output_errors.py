"""The recorder node on a disk that refuses its writes (full, read-only, file-size limit): one
error line, the run ended with exit status 74, the bag kept as far as it got and closing it raises
nothing; a node whose close() fails that way is reported in one line by run_node's shutdown."""
import errno
import os

import pytest

from ros_helpers import params, rclpy  # noqa: F401

from rotor_avc.bag import BagError, BagReader
from rotor_avc.config import find_config
from rotor_avc.nodes.recorder import Recorder
from rotor_avc.nodes.runtime import close_node
from rotor_avc.output_files import EXIT_OUTPUT, OutputError

from test_output_errors import _RefusingFile

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module", autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


@pytest.mark.parametrize("err", [errno.ENOSPC, errno.EFBIG])
def test_a_refused_write_ends_the_recording(tmp_path, err):
    path = tmp_path / "run.mcap"
    rec = Recorder("recorder_refused", parameter_overrides=params(
        scenario=str(find_config("scenario_case3_steady")), path=str(path),
        chunk_size_bytes=4096))
    try:
        ch = rec._channel("/clock", ["rosgraph_msgs/msg/Clock"])
        rec.flush()
        written = path.stat().st_size
        rec.writer._sink._file = _RefusingFile(rec.writer._sink._file, err)
        ch.queue.extend(b"\0\0\0\0" + k.to_bytes(8, "little") for k in range(1000))
        rec.flush()                                # the first full chunk is refused
        assert isinstance(rec.write_error, OutputError)
        assert str(rec.write_error).startswith(f"{path}: cannot write: ")
        assert rec.exit_requested and rec.exit_status == EXIT_OUTPUT
        ch.queue.append(b"\0" * 12)
        rec.flush()                                # nothing more is tried
        assert ch.queue
    finally:
        assert close_node(rec) == 0                # the bag was closed when the write failed
    assert path.stat().st_size == written
    with pytest.raises(BagError, match="bag recover"):     # no summary: recover finishes it
        BagReader(path).close()


class _Closing:
    """A node stand-in whose close() hits a full disk."""

    destroyed = False

    def close(self):
        raise OutputError("bags/run.mcap", OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)))

    def destroy_node(self):
        self.destroyed = True


def test_a_close_refused_by_the_disk_is_one_line_and_its_status(capsys):
    node = _Closing()
    assert close_node(node) == EXIT_OUTPUT and node.destroyed
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["error: bags/run.mcap: cannot write: disk full -- fix: free space on that "
                   "disk, or write to another folder (--out) on a disk with room"]
