"""The map of ``analysis`` (docs/ARCHITECTURE.md, "Inside ``analysis``"): its stages are
subpackages, a few top-level modules sit beside them, and the tests mirror the packages."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "analysis"
TESTS = ROOT / "tests" / "analysis"


def test_analysis_has_at_most_eight_top_level_modules():
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(top) <= 8, top
    subpackages = sorted(p.parent.name for p in PACKAGE.glob("*/__init__.py"))
    assert subpackages == ["common", "report", "stats", "tables"]


def test_a_module_s_test_sits_at_its_mirrored_path():
    # analysis/stats/bootstrap.py -> tests/analysis/stats/test_bootstrap.py
    where = {p.stem: p.parent.relative_to(PACKAGE) for p in PACKAGE.rglob("*.py") if p.stem != "__init__"}
    for test in TESTS.rglob("test_*.py"):
        module = test.stem.removeprefix("test_")
        if module in where:
            assert test.parent.relative_to(TESTS) == where[module], test.relative_to(ROOT)
