"""An in-process run as a bag: the same topics, types and stamps the ROS graph records.

:func:`write_run_bag` turns a :class:`rotor_avc.sim.timeseries.TimeSeries` of a scenario into the
streams of rotor_avc.bag.topics, so ``rotor-avc compare``, ``replay`` and every other bag reader
treat a simulated run and a recorded ROS run alike:

* ``rotor/joint_state`` and ``/clock`` at every sample;
* ``foot/<id>/acceleration`` of every actuated foot and, for a controller on displacement or
  velocity, ``foot/<id>/<kind>``;
* ``foot/<id>/actuator_force`` of every controlled foot, stamped with the sample it answers;
* ``plant/observables``: ``time_s`` then the measurement vector (foot signals, outputs);
* ``balancer/command`` when the run had a balancer;
* ``harmonic/forces`` when the time series carries the adaptive harmonic controller's forces as
  channels ``harmonic_<id>_f<axis>`` (labels ``<id>_f<axis>``; ``actuator_<id>_f<axis>`` is then
  the feedback controller's part alone, as the foot controller publishes it in the ROS graph);
* ``plant/test_signal`` when the run had a broadband test force (``simulation.test_signal``,
  rotor_avc.sim.broadband): ``time_s`` then ``test_signal_<id>_f<axis>``, the force ``d_k`` (N)
  the plant added to the actuator's commanded force over ``[t_k, t_k+1)``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Iterator

import numpy as np

from .bag import topics as T
from .block_kinds import BALANCER, HARMONIC, answer_prefixes
from .bag.writer import BagWriter, write_bag


def write_run_bag(path, scenario, ts, namespace: str = T.NAMESPACE) -> Path:
    """Write the run ``ts`` of ``scenario`` (rotor_avc.scenario.Scenario) to ``path``."""
    write_bag(path, run_streams(scenario, ts, namespace), scenario.run_config())
    return Path(path)


def stream_run_bag(path, scenario, blocks: Iterable, namespace: str = T.NAMESPACE) -> Iterator:
    """Write consecutive time-series blocks of a run (``Scenario.run_blocks``) to ``path`` as
    they come, passing each block on: memory independent of the run's length. The bag is closed
    (valid, readable) when the blocks end -- also early, e.g. after Ctrl-C; a reader then notes
    the run as shorter than its scenario (rotor_avc.bag.sequence)."""
    with BagWriter(path, scenario.run_config()) as bag:
        for ts in blocks:
            bag.write_streams(run_streams(scenario, ts, namespace))
            yield ts


def run_streams(scenario, ts, namespace: str = T.NAMESPACE) -> list:
    """The bag streams of the run ``ts`` (a whole run or consecutive parts of one, each written
    with :meth:`rotor_avc.bag.writer.BagWriter.write_streams`)."""
    plant = scenario.machine.plant
    t = ts.time_s
    feedback = {foot: c.feedback for foot, c in scenario.machine.controllers.items()}
    streams = [T.joint_state(t, ts.angle_rad, ts.speed_rad_s, namespace), T.clock(t)]
    letters = {"acceleration": "a", "velocity": "v", "displacement": "d"}
    for act in plant.actuators:
        for kind in sorted({"acceleration", feedback.get(act.id, "acceleration")}):
            values = ts[f"foot_{act.id}_{letters[kind]}{act.axis}"]
            streams.append(T.foot_signal(act.id, kind, t, values, act.axis, namespace))
        if act.id in feedback:
            streams.append(T.actuator_force(act.id, t, ts[f"actuator_{act.id}_f{act.axis}"],
                                            axis=act.axis, namespace=namespace))
    names = [n for n in ts.channels if not n.startswith(answer_prefixes() + ("test_signal_",))]
    streams.append(T.labelled_array("plant/observables", t, ["time_s"] + names,
                                    np.column_stack([t] + [ts[n] for n in names]), namespace))
    for kind in (BALANCER, HARMONIC):      # the machine-wide answers: one labelled array each
        answers = [n for n in ts.channels if n.startswith(kind.channel_prefix)]
        if answers:
            labels = ["time_s"] + [n[len(kind.channel_prefix):] for n in answers]
            streams.append(T.labelled_array(kind.answer_topic, t, labels, np.column_stack(
                [t] + [ts[n] for n in answers]), namespace))
    test = scenario.test_force
    if test is not None:
        streams.append(T.labelled_array("plant/test_signal", t, ["time_s", test.channel],
                                        np.column_stack([t, ts[test.channel]]), namespace))
    return streams
