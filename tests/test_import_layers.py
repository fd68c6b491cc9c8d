"""The stage order of imports (data_schema <- nvrq <- annotate <- analysis; commands on top)
and the command-line entry points' import cost (no deep-learning runtime for ``--help``)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: each package may import only the stages at or below it (its index in this tuple)
STAGES = ("data_schema", "nvrq", "annotate", "analysis")


def _imported_packages(path: Path) -> set[str]:
    """First components of every absolute import in ``path`` (module top or in functions)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.add(node.module.split(".")[0])
        elif isinstance(node, ast.Import):
            out.update(a.name.split(".")[0] for a in node.names)
    return out


@pytest.mark.parametrize("package", STAGES)
def test_no_module_imports_a_later_stage(package):
    later = set(STAGES[STAGES.index(package) + 1:])
    bad = {
        str(p.relative_to(ROOT)): sorted(_imported_packages(p) & later)
        for p in sorted((ROOT / package).rglob("*.py"))
    }
    assert {k: v for k, v in bad.items() if v} == {}


def test_command_line_parsers_load_no_deep_learning_runtime():
    # `nvrq --help`, `annotate --help` and `analyze --help` build every parser; the heavy
    # optional packages must stay deferred to the commands that use them
    code = (
        "import sys\n"
        "import nvrq.cli, annotate.cli, analysis.cli\n"
        "for m in (nvrq.cli, annotate.cli, analysis.cli): m.build_parser()\n"
        "heavy = ('torch', 'transformers', 'ray', 'openvino', 'onnxruntime', 'streamlit',"
        " 'playwright', 'ultralytics')\n"
        "print(sorted(h for h in heavy if h in sys.modules))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "[]"


#: The command layer, on top of every stage: the three entry points (and ``python -m nvrq``) and
#: their subcommand modules (``nvrq.commands.args`` holds the argument conventions all three share).
COMMAND_LAYER = ("nvrq.cli", "nvrq.__main__", "nvrq.commands", "annotate.cli", "annotate.commands",
                 "analysis.cli")


def _in_command_layer(module: str) -> bool:
    return any(module == c or module.startswith(c + ".") for c in COMMAND_LAYER)


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported_modules(path: Path, text: str | None = None) -> set[str]:
    """Every module the file ``path`` (its ``text``, default: read) imports by name, relative
    imports resolved: ``from a.b import c`` gives ``a.b`` and ``a.b.c`` (``c`` may be a module)."""
    package = _module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8") if text is None else text)):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            out.add(module)
            out.update(f"{module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_only_the_command_layer_imports_the_command_layer():
    # the library of every stage is callable without its CLI: no module outside the command
    # layer imports an entry point or a subcommand module (the CLIs import the library)
    bad = {}
    for package in STAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if _in_command_layer(_module_name(path)):
                continue
            hits = sorted(m for m in _imported_modules(path) if _in_command_layer(m))
            if hits:
                bad[str(path.relative_to(ROOT))] = hits
    assert bad == {}


def test_the_command_layer_rule_sees_every_kind_of_import():
    # the rule's import reader on a hand-written module with each kind of import
    lib = ROOT / "nvrq" / "engines" / "example.py"  # as if it were in nvrq.engines (not written)
    text = ("import nvrq.commands.args\nfrom nvrq import cli\nfrom ..commands import score\n"
            "from annotate.commands.serve import base_url\nimport numpy\n")
    modules = {m for m in _imported_modules(lib, text) if _in_command_layer(m)}
    assert modules == {"nvrq.commands.args", "nvrq.cli", "nvrq.commands", "nvrq.commands.score",
                       "annotate.commands.serve", "annotate.commands.serve.base_url"}
    assert not _in_command_layer("nvrq.client") and _in_command_layer("analysis.cli")

