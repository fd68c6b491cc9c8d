"""Each metric fact is defined in one place (issue 26), found by reading the source (ast):

- directions, reference flags and encoder families: the ``MetricInfo`` entries of
  ``nvrq/metrics/registry.py`` (and the PyIQA family's member entries, whose values PyIQA gives, in
  ``nvrq/metrics/pyiqa_bridge.py``), read only by the resolver ``nvrq/metrics/resolve.py``;
- "is this an encoder column / does it need tau": ``nvrq/metrics/resolve.py`` alone;
- the default encoder: ``DEFAULT_ENCODER`` assigned once and applied once (``get_spec``);
- the tau check: ``check_tau`` (``nvrq/metrics/formulas.py``); the tau rule (argument > user
  config > registry): ``require_tau`` (``nvrq/metrics/tau_config.py``).
"""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from data_schema.errors import InputError

ROOT = Path(__file__).resolve().parents[3]
PACKAGES = ("data_schema", "nvrq", "annotate", "analysis", "benchmarks")


@cache
def _sources() -> dict[str, ast.Module]:
    """Every module of the packages and benchmarks, except the command-line parsers (``cli.py``,
    whose ``args.higher_better`` is an option, not a registry entry)."""
    return {p.relative_to(ROOT).as_posix(): ast.parse(p.read_text(encoding="utf-8"))
            for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py")) if p.name != "cli.py"}


def _enclosing_functions(tree: ast.Module) -> dict[int, str]:
    """``id(node) -> name`` of the innermost function around each node (absent at module level)."""
    out = {}
    for fn in ast.walk(tree):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for node in ast.walk(fn):
                out[id(node)] = fn.name  # inner functions are walked later and win
    return out


@cache
def _functions_of(path: str) -> dict[int, str]:
    return _enclosing_functions(_sources()[path])


def _where(predicate) -> set[str]:
    """``path:function`` (or ``path``) of every node for which ``predicate(node)`` holds."""
    found = set()
    for path, tree in _sources().items():
        funcs = _functions_of(path)
        for node in ast.walk(tree):
            if predicate(node):
                found.add(f"{path}:{funcs[id(node)]}" if id(node) in funcs else path)
    return found


def _call_name(node) -> str | None:
    if isinstance(node, ast.Call):
        return getattr(node.func, "id", None) or getattr(node.func, "attr", None)
    return None


def test_metric_entries_are_built_in_the_registry_alone():
    assert {w.split(":")[0] for w in _where(lambda n: _call_name(n) == "MetricInfo")} == {
        "nvrq/metrics/registry.py", "nvrq/metrics/pyiqa_bridge.py"}


@pytest.mark.parametrize("field", ["higher_better", "reference", "needs_encoder"])
def test_direction_reference_and_encoder_flags_are_read_by_the_resolver_alone(field):
    reads = _where(lambda n: isinstance(n, ast.Attribute) and n.attr == field and isinstance(n.ctx, ast.Load))
    assert {w.split(":")[0] for w in reads} == {"nvrq/metrics/resolve.py"}


def test_tau_needing_family_is_named_by_the_resolver_alone():
    # issue 34: whether a column needs tau is its registry entry's ``needs_tau`` (read by
    # needs_tau), so "nvrq_ca" is compared against a column's family nowhere in nvrq (before
    # issue 34 needs_tau compared it; analysis' default_rank_metric prefers NVRQ-CA columns: a
    # choice of metric, not this rule)
    def compares_nvrq_ca(n):
        return isinstance(n, ast.Compare) and any(
            isinstance(c, ast.Constant) and c.value == "nvrq_ca" for c in [n.left, *n.comparators])
    assert {w for w in _where(compares_nvrq_ca) if w.startswith("nvrq/")} == set()
    from nvrq.metrics import needs_tau
    assert needs_tau(["psnr", "nvrq_ca:e@int8"]) and not needs_tau(["nvrq:e"])


def test_default_encoder_is_assigned_once_and_applied_once():
    def assigns(n):
        return isinstance(n, (ast.Assign, ast.AnnAssign)) and any(
            isinstance(t, ast.Name) and t.id == "DEFAULT_ENCODER"
            for t in (n.targets if isinstance(n, ast.Assign) else [n.target]))
    assert _where(assigns) == {"nvrq/encoder_specs.py"}
    reads = _where(lambda n: (isinstance(n, ast.Name) and n.id == "DEFAULT_ENCODER" and isinstance(n.ctx, ast.Load))
                   or (isinstance(n, ast.Attribute) and n.attr == "DEFAULT_ENCODER"))
    assert reads == {"nvrq/encoder_specs.py:get_spec"}
    imports = _where(lambda n: isinstance(n, ast.ImportFrom) and any(a.name == "DEFAULT_ENCODER" for a in n.names))
    # the encoder registry's re-export of the specs, and its package's
    assert imports == {"nvrq/encoders/registry.py", "nvrq/encoders/__init__.py"}
    from nvrq.encoders import (
        DEFAULT_ENCODER,
        EncoderConfig,
        encoder_config,
        encoder_for_metrics,
        get_spec,
    )

    # everything that defaults an encoder gets the one default (get_spec(None))
    assert get_spec().name == EncoderConfig().name == encoder_config().name == DEFAULT_ENCODER
    assert encoder_for_metrics(["psnr", "nvrq"]) == DEFAULT_ENCODER


def test_tau_is_checked_by_check_tau_alone():
    defs = _where(lambda n: isinstance(n, ast.FunctionDef) and n.name == "check_tau")
    assert defs == {"nvrq/metrics/formulas.py:check_tau"}

    def bounds_tau(n):  # a comparison of a tau with 0 or 1 (the range check)
        if not isinstance(n, ast.Compare):
            return False
        sides = [n.left, *n.comparators]
        named = any((isinstance(s, ast.Name) and s.id == "tau") or (isinstance(s, ast.Attribute) and s.attr == "tau")
                    for s in sides)
        return named and any(isinstance(s, ast.Constant) and s.value in (0, 1) for s in sides)
    assert _where(bounds_tau) == {"nvrq/metrics/formulas.py:check_tau"}


def _is_spec_tau(n) -> bool:
    """``spec.tau`` or ``get_spec(...).tau``: a read of the registry's tau (EncoderSpec.tau)."""
    return isinstance(n, ast.Attribute) and n.attr == "tau" and (
        (isinstance(n.value, ast.Name) and n.value.id == "spec") or _call_name(n.value) == "get_spec")


def test_tau_is_resolved_by_require_tau_alone():
    defs = _where(lambda n: isinstance(n, ast.FunctionDef) and "tau" in n.name and n.name.startswith(("resolve", "_resolve", "require")))
    assert defs == {"nvrq/metrics/tau_config.py:require_tau"}  # resolve_tau and the CLI's _resolve_tau are gone
    config_reads = _where(lambda n: _call_name(n) == "read_tau_config")
    assert config_reads == {"nvrq/metrics/tau_config.py:require_tau", "nvrq/metrics/tau_config.py:write_tau"}
    # the registry's tau (EncoderSpec.tau) is read only to hand it to the rule (registry_tau=)
    handed = _where(lambda n: _call_name(n) == "require_tau" and any(
        k.arg == "registry_tau" and _is_spec_tau(k.value) for k in n.keywords))
    assert _where(_is_spec_tau) == handed
    assert {w.split(":")[0] for w in handed} == {"nvrq/scoring/plan.py", "nvrq/commands/model_options.py"}


def test_require_tau_resolves_argument_then_config_then_registry(tmp_path, monkeypatch):
    import json
    from functools import partial

    from nvrq.encoders import get_spec
    from nvrq.metrics.tau_config import require_tau as rule

    cfg = tmp_path / "tau.json"
    monkeypatch.setenv("NVRQ_CONFIG", str(cfg))
    with pytest.raises(InputError, match=r"^tau: expected a tau for encoder efficientnet-lite0"):
        rule("efficientnet-lite0")  # no registry tau handed in, no config: none
    # the registry's tau of efficientnet-lite0 is 0.76 (nvrq/encoder_specs.py)
    require_tau = partial(rule, registry_tau=get_spec("efficientnet-lite0").tau)
    assert require_tau("efficientnet-lite0") == (0.76, "registry")
    cfg.write_text(json.dumps({"efficientnet-lite0": {"tau": 0.5}}))
    assert require_tau("efficientnet-lite0") == (0.5, str(cfg))
    assert require_tau("efficientnet-lite0", tau=np.float32(0.25)) == (0.25, "argument")
    for bad in (0.0, 1.0, True, "0.5", float("nan")):
        with pytest.raises(InputError, match=r"^tau: expected a number strictly between 0 and 1"):
            require_tau("efficientnet-lite0", tau=bad)
    cfg.write_text(json.dumps({"efficientnet-lite0": {"tau": 1.5}}))
    with pytest.raises(InputError, match=r"tau\.json: efficientnet-lite0\.tau: expected a number strictly"):
        require_tau("efficientnet-lite0")
