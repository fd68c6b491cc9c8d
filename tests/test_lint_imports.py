"""The import-linter contracts of pyproject.toml hold the layers: `lint-imports` passes on the
tree, and fails on a copy of it where one module imports a layer above its own."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("data_schema", "nvrq", "annotate", "analysis", "benchmarks")
LINT = "from importlinter.cli import lint_imports_command; lint_imports_command()"
N = (ROOT / "pyproject.toml").read_text(encoding="utf-8").count("[[tool.importlinter.contracts]]")


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Path:
    """A copy of the packages' Python files and pyproject.toml."""
    out = tmp_path_factory.mktemp("tree")
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            target = out / path.relative_to(ROOT)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)
    shutil.copyfile(ROOT / "pyproject.toml", out / "pyproject.toml")
    return out


def _lint(root: Path) -> subprocess.CompletedProcess:
    # the copy, not the installed packages; wide lines: a contract's name and verdict on one
    env = {**os.environ, "PYTHONPATH": str(root), "COLUMNS": "300"}
    return subprocess.run([sys.executable, "-c", LINT, "--no-cache"], cwd=root, env=env,
                          capture_output=True, text=True, timeout=300)


def _with_import(tree: Path, tmp_path: Path, module: str, statement: str) -> Path:
    """A copy of ``tree`` where ``module`` (a path) ends with ``statement``."""
    copy = tmp_path / "copy"
    shutil.copytree(tree, copy)
    path = copy / module
    path.write_text(path.read_text(encoding="utf-8") + f"\n{statement}  # noqa\n", encoding="utf-8")
    return copy


def test_the_tree_keeps_every_contract(tree):
    proc = _lint(tree)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert f"Contracts: {N} kept, 0 broken." in proc.stdout


@pytest.mark.parametrize(("module", "statement", "broken"), [
    # the two arrows that once ran back up inside nvrq
    ("nvrq/scoring/plan.py", "from nvrq.calibrate import calibrate_tau", "nvrq: commands"),
    # the plan names its encoder (nvrq.encoder_specs); loading one is its caller's
    ("nvrq/scoring/plan.py", "def _up():\n    from nvrq.encoders import load_encoder", "nvrq: commands"),
    ("nvrq/metrics/resolve.py", "from nvrq.encoders.registry import get_spec", "nvrq: commands"),
    # between the packages; inside analysis and annotate; a deferred (function-level) import
    ("annotate/access.py", "import analysis.common.choices", "The five packages"),
    ("analysis/stats/stats.py", "def _up():\n    from analysis import report", "analysis: the CLI"),
    ("annotate/store.py", "from annotate.study import Study", "annotate: entry points"),
    # the other CLIs take the shared argument types from below nvrq's command layer
    ("analysis/cli.py", "from nvrq.commands.args import int_arg", "annotate and analysis use"),
])
def test_an_upward_import_breaks_its_contract(tree, tmp_path, module, statement, broken):
    proc = _lint(_with_import(tree, tmp_path, module, statement))
    assert proc.returncode == 1, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert f"Contracts: {N - 1} kept, 1 broken." in proc.stdout
    verdicts = [line for line in proc.stdout.splitlines() if line.endswith((" KEPT", " BROKEN"))]
    assert [line.endswith(" BROKEN") for line in verdicts] == [
        line.startswith(broken) for line in verdicts], proc.stdout[-3000:]
    importer = module.removesuffix(".py").replace("/", ".")
    assert importer in proc.stdout  # the report names the module that imports upward
