"""The declared seams: every implementation of a protocol offers each of its members, and each
method with the protocol's parameters (names, kinds, defaults), so a caller written against the
protocol works with any of them -- the recording readers (MCAP file, rosbag2 directory), the run
sources of a comparison, the point sets and evaluators of the study engine."""
import inspect
import typing
from pathlib import Path

import numpy as np
import pytest

from rotor_avc.analysis.gain_study import GainCurves
from rotor_avc.analysis.robustness import RobustnessPoint
from rotor_avc.analysis.stability_study import ThresholdPoint
from rotor_avc.bag.reader import BagReader
from rotor_avc.bag.recording_reader import RecordingReader
from rotor_avc.bag.rosbag2 import DirectoryBag, open_bag
from rotor_avc.calibration.problem import Columns, FitEvaluator, ResidualEvaluator, Starts
from rotor_avc.compare.bag_source import BagSource
from rotor_avc.compare.mapped_stream import MappedStream
from rotor_avc.compare.recorded_run import RecordedRun, read_run
from rotor_avc.compare.run_source import GridRunSource, RunSource
from rotor_avc.config import load_config
from rotor_avc.studies.points import Grid, Sample, ValueList, parse_sample, parse_vary
from rotor_avc.studies.spec import Evaluator, PointSet

from test_rosbag2_bags import corpus  # noqa: F401 -- the fixture: a two-file rosbag2 directory

REFERENCE_BAG = Path(__file__).resolve().parents[1] / "bags" / "reference" / "case3_stepped.mcap"


def _members(protocol) -> dict:
    """The protocol's own members: name -> function, property or annotation."""
    out = {}
    for cls in reversed(protocol.__mro__):
        if cls in (object, typing.Protocol, typing.Generic) or not getattr(cls, "_is_protocol",
                                                                          False):
            continue
        out.update({k: v for k, v in vars(cls).items() if not k.startswith("_")
                    or k in ("__len__", "__enter__", "__exit__")})
        out.update({k: "attribute" for k in getattr(cls, "__annotations__", {})})
    return out


def _parameters(fn) -> list:
    """Kind and default of each parameter after ``self``; the name too where a caller must use
    it (keyword-only, or with a default)."""
    out = []
    for p in list(inspect.signature(fn).parameters.values())[1:]:
        named = p.kind == p.KEYWORD_ONLY or p.default is not p.empty
        out.append((p.name if named else "", p.kind, p.default))
    return out


def assert_implements(cls, protocol) -> None:
    for name, member in _members(protocol).items():
        if member == "attribute":
            continue                                       # instance data: checked on objects
        assert hasattr(cls, name), f"{cls.__name__} lacks {protocol.__name__}.{name}"
        mine = inspect.getattr_static(cls, name)
        if isinstance(member, property):
            assert isinstance(mine, property) or not callable(mine), (cls, name)
        elif callable(member):
            assert callable(mine), (cls, name)
            assert _parameters(mine) == _parameters(member), (cls.__name__, name)


@pytest.mark.parametrize("cls", [BagReader, DirectoryBag])
def test_both_recording_readers_implement_the_protocol(cls):
    assert_implements(cls, RecordingReader)


def test_open_bag_gives_a_recording_reader_for_a_file_and_a_directory(corpus):
    _, bag = corpus
    for path in (REFERENCE_BAG, bag):
        with open_bag(path) as reader:              # (isinstance would read every property)
            assert_implements(type(reader), RecordingReader)
            assert reader.message_count > 0 and reader.topics and reader.path


@pytest.mark.parametrize("cls, protocol", [(RecordedRun, GridRunSource), (BagSource, GridRunSource),
                                           (MappedStream, RunSource)])
def test_every_run_source_implements_its_protocol(cls, protocol):
    assert_implements(cls, protocol)


def test_run_sources_carry_the_protocols_data(corpus):
    root, bag = corpus
    for run, protocol in ((read_run(REFERENCE_BAG), GridRunSource),
                          (BagSource(REFERENCE_BAG), GridRunSource),
                          (MappedStream(bag, root / "machine.yaml", root / "map.yaml"), RunSource)):
        assert isinstance(run, protocol), type(run)


def _point_sets():
    cfg = load_config("foot_mount_case3")
    yield Grid([parse_vary("foundation.tan_delta=0.03:0.05:3")], cfg)
    yield ValueList("kp", [1.0e5, 2.0e5])
    yield Sample([parse_sample("foundation.mass_kg*=normal(1, 0.1)")], 4, 1, cfg)
    yield Columns((1.0, 1.0), (1e-6, 1e-6), (0, 1))
    yield Starts(((1.0, 1.0), (2.0, 0.5)))


def test_every_point_set_implements_the_protocol():
    for points in _point_sets():
        assert_implements(type(points), PointSet)
        assert isinstance(points, PointSet)
        first = points.point(0)
        assert first.index == 0 and isinstance(points.describe(), dict) and len(points) >= 2


@pytest.mark.parametrize("cls", [ThresholdPoint, GainCurves, RobustnessPoint, ResidualEvaluator,
                                 FitEvaluator])
def test_every_evaluator_implements_the_protocol(cls):
    assert_implements(cls, Evaluator)
    assert hasattr(cls, "fields")


def test_the_protocols_are_not_satisfied_by_accident():
    """A class missing one member, or with other parameters, fails the check."""
    class Partial:
        def __len__(self):
            return 1

        def point(self, i, extra):
            return None

        def describe(self):
            return {}

    with pytest.raises(AssertionError):
        assert_implements(Partial, PointSet)
    with pytest.raises(AssertionError):
        assert_implements(type("Empty", (), {}), Evaluator)
    assert not isinstance(np.zeros(2), RecordingReader)
