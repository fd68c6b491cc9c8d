"""Shared test fixtures.

The folders of ``tests/`` mirror the packages they test: ``nvrq/`` (its subfolders those of
nvrq's packages, ``nvrq/scoring/``, ``nvrq/commands/``, ...; a test of the module ``nvrq/pairs.py``
is ``nvrq/test_pairs*.py``), ``data_schema/``, ``annotate/`` and ``analysis/``; ``workflows/`` runs
commands end to end, ``e2e/`` drives a real browser, ``malformed/`` is the bad-input corpus and
``data/`` holds files written by earlier versions. Only project-wide checks sit at the top: the
import layers, the README's commands, the benchmarks' smoke runs and the numpydoc count.
"""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """The ``../shared`` folder beside the repository (tests needing it skip when absent)."""
    if not SHARED.is_dir():
        pytest.skip("../shared is absent")
    return SHARED


@pytest.fixture(scope="session", autouse=True)
def _nvrq_cache(tmp_path_factory):
    """Exported encoder models and drift-check records go to a per-session folder, never ~/.cache."""
    import os

    old = os.environ.get("NVRQ_CACHE")
    os.environ["NVRQ_CACHE"] = str(tmp_path_factory.mktemp("nvrq_cache"))
    yield
    if old is None:
        os.environ.pop("NVRQ_CACHE", None)
    else:
        os.environ["NVRQ_CACHE"] = old


@pytest.fixture(scope="session")
def make_numbers():
    """docs/make_numbers.py as a module (docs/ is no package)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_numbers", REPO / "docs" / "make_numbers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def doc_demos(tmp_path_factory, make_numbers) -> Path:
    """The one-minute demos whose reports the README and the guides quote (``demo/``,
    ``methods/``), run once per session: tests/test_doc_numbers.py and the report browser
    test share them. About a minute and a half on 2 cores."""
    root = tmp_path_factory.mktemp("doc_demos")
    make_numbers.run_demos(root)
    return root


@pytest.fixture(scope="session")
def demo_report_pages(tmp_path_factory):
    """The demo-like reports of tests/analysis/demo_reports.py, built once per session (about
    30 s): ``(root, pages, figures)``, ``pages`` ``{'report', 'leaderboard', 'pairwise'}`` to
    each report.html and ``figures`` every figure they drew, by file name (matplotlib Figures)."""
    from tests.analysis.demo_reports import demo_reports, recording_figures

    root = tmp_path_factory.mktemp("demo_reports")
    with pytest.MonkeyPatch.context() as mp, recording_figures(mp) as seen:
        pages = demo_reports(root)
    return root, pages, dict(seen)
