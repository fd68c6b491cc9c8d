"""Issue 46, item 1: ``ScorePlan`` is the only way into scoring (its acceptance, pinned on the tree).

- no ``_legacy_plan`` is left; ``check_metric_args`` is defined once (``nvrq/scoring/plan.py``) and
  called only by :class:`~nvrq.scoring.plan.ScorePlan`;
- ``plan_from_args`` lives under ``nvrq/commands/``;
- nothing under ``nvrq/scoring`` or ``nvrq/metrics`` imports ``nvrq.calibrate`` or ``nvrq.encoders``
  (at a module's top or in a function): they name encoders through the leaf ``nvrq.encoder_specs``;
- a plan loads its encoder by the loader its caller hands it (the Ray engine's, for its actors).
"""

from __future__ import annotations

import ast
import pickle
from pathlib import Path

import pytest

from data_schema.errors import InputError
from nvrq.scoring.plan import ScorePlan, resolve_plan
from tests.nvrq.scoring.toy_encoder import ToyEncoder

REPO = Path(__file__).resolve().parents[3]


def _trees():
    for path in sorted((REPO / "nvrq").rglob("*.py")):
        yield path.relative_to(REPO).as_posix(), ast.parse(path.read_text(encoding="utf-8"))


def _enclosing(tree) -> dict:
    """node -> the names of the classes and functions around it, outermost first."""
    out = {}

    def walk(node, names):
        for child in ast.iter_child_nodes(node):
            here = (*names, child.name) if isinstance(child, (ast.ClassDef, ast.FunctionDef)) else names
            out[child] = names
            walk(child, here)
    walk(tree, ())
    return out


def test_no_legacy_plan_and_check_metric_args_is_the_plans_alone():
    defs, calls, legacy = [], [], []
    for rel, tree in _trees():
        around = _enclosing(tree)
        for node in ast.walk(tree):
            name = getattr(node, "name", None) or getattr(node, "id", None) or getattr(node, "attr", None)
            if name == "_legacy_plan":
                legacy.append(rel)
            if isinstance(node, ast.FunctionDef) and node.name == "check_metric_args":
                defs.append(rel)
            if isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None)) == \
                    "check_metric_args":
                calls.append((rel, around[node][:1]))
    assert legacy == []
    assert defs == ["nvrq/scoring/plan.py"]
    assert calls == [("nvrq/scoring/plan.py", ("ScorePlan",))]


def test_plan_from_args_lives_under_the_commands():
    defs = [rel for rel, tree in _trees() for node in ast.walk(tree)
            if isinstance(node, ast.FunctionDef) and node.name == "plan_from_args"]
    assert defs == ["nvrq/commands/score.py"]


def _imports(tree) -> set[str]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.update([node.module, *(f"{node.module}.{a.name}" for a in node.names)])
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_scoring_and_metrics_import_no_encoder_and_no_calibration():
    checked, bad = [], {}
    for rel, tree in _trees():
        if rel.startswith(("nvrq/scoring/", "nvrq/metrics/")):
            checked.append(rel)
            hits = sorted(m for m in _imports(tree) if m.split(".")[:2] in (["nvrq", "encoders"], ["nvrq", "calibrate"]))
            if hits:
                bad[rel] = hits
    assert "nvrq/scoring/plan.py" in checked and "nvrq/metrics/resolve.py" in checked
    assert bad == {}
    # the reader sees a function-level import too (as the plan's loader once was)
    assert _imports(ast.parse("def f():\n    from nvrq.encoders import load_encoder\n")) >= {"nvrq.encoders"}


def _load_toy(config):
    return ToyEncoder(config.name)


def test_a_plan_loads_its_encoder_by_the_loader_it_is_given():
    plan = resolve_plan("psnr,nvrq", encoder="efficientnet-lite0")
    with pytest.raises(InputError, match="^loader: expected the loader of the plan's encoder"):
        plan.load()
    from dataclasses import replace

    given = replace(plan, loader=_load_toy)
    assert given == plan and ScorePlan.from_json(given.to_json()) == plan  # not part of the plan's identity
    again = pickle.loads(pickle.dumps(given))  # as a Ray actor receives it
    model = again.load()
    assert model.spec.name == "efficientnet-lite0" and again.model_columns == ("nvrq:efficientnet-lite0",)
