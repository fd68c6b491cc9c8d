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
