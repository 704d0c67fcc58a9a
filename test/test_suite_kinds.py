"""Every test module is of one declared kind (test/conftest.py KINDS), so a reader sees what is
validated against what, and ``pytest -m unit|paper|cross_method|ros_integration`` selects it."""
from pathlib import Path

from conftest import KIND_OF, KINDS


def test_every_test_module_has_one_kind():
    modules = {p.stem for p in Path(__file__).parent.glob("test_*.py")}
    listed = [name for names in KINDS.values() for name in names]
    assert len(listed) == len(set(listed)), "a module is listed under two kinds"
    unclassified = sorted(modules - set(KIND_OF))
    assert not unclassified, f"add these to KINDS in test/conftest.py: {unclassified}"
    assert not set(KIND_OF) - modules, f"KINDS lists missing modules: {set(KIND_OF) - modules}"
