"""The plant_simulator node's declared parameters, exit statuses and real-time rate check
(rotor_avc.nodes.plant_simulator; each parameter has a type, a description and bounds, see
rotor_avc.nodes.runtime.Param)."""
from __future__ import annotations

from . import messages as m
from .lockstep import POLICIES
from .runtime import COMMON_PARAMS, Param

#: real time: the first RATE_CHECK_S of the run decide whether the graph holds the rate
RATE_CHECK_S = 0.25
RATE_CHECK_OVERRUNS = 0.05
EXIT_RECORDER_LOST, EXIT_RATE_NOT_HELD = 1, 3
#: a complete run that was not lockstep (a fault policy acted, an answer changed, a responder
#: was absent: rotor_avc.bag.lockstep); a responder left the graph or never connected (the run
#: ends); 6, another plant on the namespace: rotor_avc.nodes.namespace_guard
EXIT_NOT_LOCKSTEP, EXIT_NODE_LEFT = 4, 5
#: lockstep, fault_policy wait: while a sample waits longer than controller_timeout_s, the log
#: and /diagnostics say for whom, at which sample and for how long, once per this many seconds
WAIT_REPORT_S = 5.0

PARAMS = COMMON_PARAMS + (
    Param("scenario", "", "scenario config (path or shipped name): machine, controllers, "
          "simulation section"),
    Param("mode", "lockstep", "lockstep: step when every controller answered; realtime: step on "
          "the wall clock with the latest forces", choices=("lockstep", "realtime")),
    Param("namespace", m.NAMESPACE, "topic namespace of the machine (/<namespace>/foot/...)"),
    Param("duration_s", 0.0, "simulated time in s; 0 = the scenario's duration", minimum=0.0),
    Param("controller_timeout_s", 1.0, "wall time without an answer before the plant says it "
          "waits (fault_policy wait) or declares the controller absent (hold, zero)",
          minimum=1e-3, maximum=3600.0),
    Param("resend_after_s", 0.25, "lockstep: wall time after which an unanswered sample is "
          "published again", minimum=1e-3, maximum=3600.0),
    Param("fault_policy", "wait", "wait: lockstep, wait for every answer however long it takes "
          "(a responder that left the graph ends the run, exit status 5); hold or zero: fault "
          "studies only, step on without an absent controller with its last force or zero (the "
          "run is then not lockstep: said in the bag, exit status 4)", choices=POLICIES),
    Param("discovery_timeout_s", 30.0, "wall time to wait for every controller (and the awaited "
          "recorder) to connect",
          minimum=0.0, maximum=3600.0),
    Param("balancer", False, "lockstep: also wait for the balancer's command at every sample"),
    Param("harmonic", False, "lockstep: also wait for the harmonic controller's forces "
          "(harmonic/forces, added to the feedback forces) at every sample"),
    Param("result_path", "", "save the run's time series here at the end (.npz or .mcap)"),
    Param("exit_when_done", True, "end the node when the run is complete"),
    Param("wait_for_recorder", "", "name of a recorder node that must subscribe to every topic "
          "of the run (the plant's, the controllers' forces, the balancer's) before sample 0, "
          "so the bag misses nothing; empty: do not wait"),
    Param("recorder_window", 1000, "lockstep with wait_for_recorder: the most samples the plant "
          "runs ahead of what the recorder has taken", minimum=1,
          maximum=m.LOCKSTEP_DEPTH - m.RECORDER_MARGIN),
    Param("recorder_timeout_s", 10.0, "lockstep with wait_for_recorder: wall time the plant waits "
          "for a recorder that takes nothing before it ends the run (exit status 1)",
          minimum=0.1, maximum=3600.0),
    Param("realtime_overload", "warn", "real time: a rate the graph does not hold in the "
          "first 0.25 s is reported on /diagnostics and in the log (warn) or also ends the run "
          "(abort, exit status 3)", choices=("warn", "abort")),
)
