"""Test-suite settings: ROS traffic stays on loopback in a private domain; plots off-screen.

``--full`` runs the long physics sweeps in full (CI runs them in their short form)."""
import os
import subprocess
import sys

import pytest

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ["ROS_DOMAIN_ID"] = str(100 + os.getpid() % 100)
os.environ.setdefault("MPLBACKEND", "Agg")
# small dense matrices: threaded BLAS only adds contention on a 2-core machine (5-30x slower)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def pytest_addoption(parser):
    parser.addoption("--full", action="store_true", default=False,
                     help="run the long physics sweeps in full instead of their short form")


def pytest_configure(config):
    config.addinivalue_line("markers", "sweep: long physics sweep; short form unless --full")
    config.addinivalue_line("markers", "ros: needs rclpy (ROS 2 Jazzy from PyPI)")


@pytest.fixture
def full(request) -> bool:
    """True when the long sweeps should run in full."""
    return request.config.getoption("--full")


#: CPU-bound competitors end by themselves after this long, should a test run forget them
COMPETITOR_MAX_S = 600


@pytest.fixture
def competitors():
    """Two CPU-bound processes competing for the 2 cores while the test runs (bounded in time,
    ended by the fixture): the graph must then still record every sample."""
    code = f"import time\nt = time.monotonic() + {COMPETITOR_MAX_S}\nwhile time.monotonic() < t: pass"
    procs = [subprocess.Popen([sys.executable, "-c", code]) for _ in range(2)]
    yield procs
    for p in procs:
        p.kill()
        p.wait()
