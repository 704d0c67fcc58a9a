"""Test-suite settings: ROS traffic stays on loopback in a private domain; plots off-screen;
every test module is of one kind (:data:`KINDS`), marked so that ``pytest -m paper`` etc. selects it.

``--full`` runs the long physics sweeps in full (CI runs them in their short form)."""
import fcntl
import os
import subprocess
import sys
import tempfile

import pytest

#: ROS domains a test session may take when the one it is given is held by another session
FREE_DOMAINS = range(110, 200)
_DOMAIN_LOCK = []


def _take_domain(domain: int) -> bool:
    """Hold ``domain`` for this session (an exclusive lock on a file named after it, released when
    the process ends): True if no other session on this machine holds it."""
    fh = open(os.path.join(tempfile.gettempdir(), f"rotor_avc_ros_domain_{domain}.lock"), "a")
    try:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.close()
        return False
    _DOMAIN_LOCK.append(fh)
    return True


def session_domain() -> int:
    """The ROS domain of this test session: ``ROS_DOMAIN_ID`` as given (the Makefile's and CI's),
    unless another session on this machine holds it; then the first free one of
    :data:`FREE_DOMAINS`. Two sessions never share a domain, so their graphs never meet."""
    given = os.environ.get("ROS_DOMAIN_ID", "")
    if given.isdigit() and _take_domain(int(given)):
        return int(given)
    for domain in FREE_DOMAINS:
        if _take_domain(domain):
            return domain
    raise RuntimeError(f"every ROS domain of {FREE_DOMAINS} is held by another test session")


os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ["ROS_DOMAIN_ID"] = str(session_domain())
os.environ.setdefault("MPLBACKEND", "Agg")
# small dense matrices: threaded BLAS only adds contention on a 2-core machine (5-30x slower)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


#: what each test module checks against -- ``unit``: the code's own contract (errors, files,
#: commands, structure); ``paper``: the papers' stated numbers and equations;
#: ``cross_method``: two formulations, an independent library or a closed form agree;
#: ``ros_integration``: ROS processes, DDS, bags of the graph, colcon and pip layouts
KINDS = {
    "unit": ("active_bearing_cli", "exit_statuses", "readme_commands", "active_bearing_piezo", "bag_check", "bag_cli", "bag_errors",
             "bag_fuzz", "bag_sequence", "balancing_cli", "blocks", "cli", "compare_errors",
             "compare_reference", "compare_test_force", "config_errors", "config_fuzz", "config_schema",
             "config_keys", "control_block", "control_cli", "controller_faults",
             "declared_bearings", "declared_controllers", "declared_foot_mount", "import_layers",
             "launch_file", "layouts", "lockstep_record", "nodes_lockstep", "nodes_timing", "resources",
             "rosbag2_bags", "sim_profile", "sim_scenario", "sim_streaming", "sleeve_bearing_cli",
             "suite_kinds", "bag_info", "bag_sequence_streaming", "output_errors", "isolation",
             "studies_hostile", "declared_simulation", "declared_balancer", "seams", "api684_verdict",
             "golden_outputs", "block_kinds", "demo_page", "controller_recovery",
             "design_check_speeds", "studies_resume", "studies_engine", "mutation_tool",
             "compare_tolerances", "mapped_recordings", "answer_config", "report_template",
             "compare_left_out",
             "sequence_gaps", "mapped_windows", "campbell_edges",
             "harmonic_block_switching", "mapped_stream_parts", "study_journal",
             "did_you_mean", "progress_commands", "bench_smoke"),
    "paper": ("active_bearing_ff", "active_bearing_model", "balancing_rigid_runup",
              "balancing_runup_response", "balancing_switching", "foot_mount_model",
              "journal_bearing", "sleeve_bearing_model", "sleeve_bearing_paper",
              "stability_model", "stability_study", "stability_threshold"),
    "cross_method": ("active_bearing_synchronous", "api684", "balance_grade", "bag_cdr", "bag_msgdefs",
                     "bag_roundtrip", "balancing_foot_mount", "balancing_rls", "campbell", "campbell_whirl",
                     "closed_loop_formulations", "compare_lockstep", "compare_resonances",
                     "compare_streaming", "compare_synthetic", "compare_transfer",
                     "compare_verdicts", "control_discretize", "control_filter", "control_limits",
                     "control_sampled_loop", "design_check", "loop_margins", "foxglove_decode", "frf_estimate",
                     "harmonic_commission", "harmonic_dynamic", "harmonic_laws", "harmonic_machine", "harmonic_supervisor",
                     "harmonic_strategies", "harmonic_limits",
                     "modal_frf",
                     "gapped_tracking", "order_tracking", "rig_recordings", "stamp_stream",
                     "rosbag2_corpus", "runup", "sim_loop", "sim_stepper", "sim_fused",
                     "sleeve_bearing_control", "sleeve_bearing_sim",
                     "sleeve_bearing_whirl_iteration", "stability_time_domain", "studies",
                     "studies_dask", "calibrate", "calibrate_uff", "iso20816",
                     "campbell_tracking"),
    "ros_integration": ("colcon", "compare_ros", "foot_controller_input", "graph_recording",
                        "node_parameters", "node_signals", "node_transport", "nodes_messages",
                        "packaging", "plotjuggler_arrays",
                        "recorder", "recorder_output_errors", "replay", "replay_recipe",
                        "ros_faults",
                        "ros_graph", "ros_lockstep", "run_command", "ros_commission",
                        "layouts_graph"),
}
KIND_OF = {f"test_{name}": kind for kind, names in KINDS.items() for name in names}


def pytest_addoption(parser):
    parser.addoption("--full", action="store_true", default=False,
                     help="run the long physics sweeps in full instead of their short form")
    parser.addoption("--update-golden", action="store_true", default=False,
                     help="write test/golden/ from the current outputs (test_golden_outputs)")


def pytest_configure(config):
    config.addinivalue_line("markers", "sweep: long physics sweep; short form unless --full")
    config.addinivalue_line("markers", "ros: needs rclpy (ROS 2 Jazzy from PyPI)")
    for kind in KINDS:
        config.addinivalue_line("markers", f"{kind}: test kind (see KINDS in test/conftest.py)")


def pytest_collection_modifyitems(config, items):
    for item in items:
        kind = KIND_OF.get(item.module.__name__.rpartition(".")[2])
        if kind is not None:
            item.add_marker(kind)


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
    code = (f"import time\nt = time.monotonic() + {COMPETITOR_MAX_S}\n"
            "while time.monotonic() < t: pass")
    procs = [subprocess.Popen([sys.executable, "-c", code]) for _ in range(2)]
    yield procs
    for p in procs:
        p.kill()
        p.wait()
