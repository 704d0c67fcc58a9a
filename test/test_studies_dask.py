"""A real Dask cluster on 127.0.0.1 -- a ``dask scheduler`` and two ``dask worker`` processes
started and ended by the test: a study gives the same bytes as the serial run, a worker
killed mid-study loses no point and computes none twice, and a scheduler that stops answering
or a cluster that loses every worker mid-study is reported in one line within the stated time."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rotor_avc.analysis.robustness import robustness_point
from rotor_avc.config import load_config
from rotor_avc.studies.backends import BackendError, DaskBackend, SerialBackend
from rotor_avc.studies.engine import StudySpec, run_study
from rotor_avc.studies.points import Sample, parse_sample

distributed = pytest.importorskip("distributed")

ROOT = Path(__file__).resolve().parents[1]
START_TIMEOUT_S = 60.0


def _spawn(args, log: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.Popen([sys.executable, "-m"] + args, env=env, stdout=log.open("w"),
                            stderr=subprocess.STDOUT, start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


@pytest.fixture
def cluster(tmp_path):
    """``(address, {name: worker process}, scheduler process)``: a scheduler and two single-threaded workers
    without nannies (a killed worker stays dead), all on 127.0.0.1, ready when returned."""
    info = tmp_path / "scheduler.json"
    procs = [_spawn(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
                     "--no-dashboard", "--scheduler-file", str(info)], tmp_path / "scheduler.log")]
    workers = {}
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while not info.exists() and time.monotonic() < deadline and procs[0].poll() is None:
            time.sleep(0.05)            # the scheduler writes the file once it listens
        assert info.exists(), (tmp_path / "scheduler.log").read_text()
        for name in ("w1", "w2"):
            workers[name] = _spawn(["distributed.cli.dask_worker", "--scheduler-file", str(info),
                                    "--host", "127.0.0.1", "--nthreads", "1", "--no-nanny",
                                    "--no-dashboard", "--name", name], tmp_path / f"{name}.log")
            procs.append(workers[name])
        with distributed.Client(scheduler_file=str(info), timeout=START_TIMEOUT_S) as client:
            client.wait_for_workers(2, timeout=START_TIMEOUT_S)
            address = client.scheduler.address
        yield address, workers, procs[0]
    finally:
        for proc in reversed(procs):
            _stop(proc)


def spec(n: int) -> StudySpec:
    cfg = load_config("foot_mount_case3")
    sample = Sample([parse_sample("foundation.stiffness_n_per_m.z*=normal(1, 0.15)"),
                     parse_sample("machine.stator_mass_kg*=uniform(0.9, 1.1)")], n, 5, cfg)
    return StudySpec(sample, robustness_point(cfg, [float(f) for f in range(1, 251)]))


def _same_files(a: Path, b: Path) -> None:
    for name in ("points.csv", "points.npz"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.timeout(180)
def test_a_dask_cluster_gives_the_serial_bytes(cluster, tmp_path):
    address, _, _ = cluster
    study = spec(16)
    run_study(study, SerialBackend(), out=tmp_path / "serial", progress=False)
    backend = DaskBackend(address)
    try:
        assert backend.workers == 2
        run = run_study(study, backend, out=tmp_path / "dask", batch_size=2, progress=False)
        who = backend.client.run(lambda: __import__("os").getpid())
    finally:
        backend.close()
    assert run.computed == 16 and not run.failed
    assert len(set(who.values())) == 2
    _same_files(tmp_path / "serial", tmp_path / "dask")


@pytest.mark.timeout(180)
def test_a_worker_killed_mid_study_loses_no_point(cluster, tmp_path):
    address, workers, _ = cluster
    study = spec(40)
    run_study(study, SerialBackend(), out=tmp_path / "serial", progress=False)
    arrived, killed_with = [], []
    backend = DaskBackend(address)

    def kill_w1_while_it_works(outcome):
        arrived.append(outcome.index)
        if len(arrived) >= 6 and not killed_with:         # every point runs on the cluster
            w1 = next(a for a, w in backend.client.scheduler_info()["workers"].items()
                      if w["name"] == "w1")
            in_flight = backend.client.processing()[w1]
            if in_flight:
                os.killpg(workers["w1"].pid, signal.SIGKILL)
                killed_with.append(len(in_flight))

    try:
        run = run_study(study, backend, out=tmp_path / "dask", batch_size=1, progress=False,
                        on_outcome=kill_w1_while_it_works)
        left = backend.workers
    finally:
        backend.close()
    assert killed_with and len(arrived) == 40
    assert workers["w1"].wait(10) == -signal.SIGKILL and left == 1
    assert sorted(arrived) == list(range(40)) and not run.failed
    journal = (tmp_path / "dask" / "journal.csv").read_text().splitlines()[2:]
    assert sorted(int(line.split(",")[0]) for line in journal) == list(range(40))
    _same_files(tmp_path / "serial", tmp_path / "dask")


@pytest.mark.timeout(180)
def test_a_scheduler_that_stops_answering_is_reported(cluster, tmp_path):
    """The scheduler stopped (SIGSTOP) mid-study: no result for ``probe_s``, then no answer
    within ``timeout_s`` -- one BackendError with the resume hint (was: a wait for good); the
    journal keeps the points that arrived."""
    address, _, scheduler = cluster
    backend = DaskBackend(address, timeout_s=2.0, probe_s=1.0)
    arrived = []

    def stop_the_scheduler(outcome):
        arrived.append(outcome.index)
        if len(arrived) == 3:
            os.kill(scheduler.pid, signal.SIGSTOP)

    try:
        with pytest.raises(BackendError) as err:
            run_study(spec(40), backend, out=tmp_path, batch_size=1, progress=False,
                      on_outcome=stop_the_scheduler)
    finally:
        os.kill(scheduler.pid, signal.SIGCONT)
        backend.close()
    assert f"the Dask scheduler at {address} stopped answering" in str(err.value)
    assert "gave no Dask answer within 2 s" in str(err.value) and "resume" in str(err.value)
    journal = (tmp_path / "journal.csv").read_text().splitlines()[2:]
    assert 3 <= len(journal) == len(arrived) < 40


@pytest.mark.timeout(180)
def test_a_cluster_left_without_workers_is_reported(cluster, tmp_path):
    """Both workers killed mid-study: the study's data are lost with them and the study ends
    with the resume hint."""
    address, workers, _ = cluster
    backend = DaskBackend(address, timeout_s=2.0, probe_s=1.0)
    arrived = []

    def kill_the_workers(outcome):
        arrived.append(outcome.index)
        if len(arrived) == 3:
            for proc in workers.values():
                os.killpg(proc.pid, signal.SIGKILL)

    try:
        with pytest.raises(BackendError, match="cancelled a task.*workers lost.*resume"):
            run_study(spec(40), backend, out=tmp_path, batch_size=1, progress=False,
                      on_outcome=kill_the_workers)
    finally:
        backend.close()
    journal = (tmp_path / "journal.csv").read_text().splitlines()[2:]
    assert 3 <= len(journal) == len(arrived) < 40
