"""Dead code: `vulture --min-confidence 80` over the four packages reports nothing beyond its
whitelist (pyproject.toml's [tool.vulture]); the whitelist is short and gives each entry a
reason; and vulture does report dead code added to a copy of the tree."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WHITELIST = ROOT / ".ci" / "vulture_whitelist.py"
PACKAGES = ("data_schema", "nvrq", "annotate", "analysis")


def _vulture(root: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "vulture"], cwd=root, capture_output=True,
                          text=True, timeout=300)


def test_vulture_reports_nothing_beyond_the_whitelist():
    proc = _vulture(ROOT)
    assert (proc.returncode, proc.stdout) == (0, ""), proc.stdout + proc.stderr


def test_the_whitelist_is_short_and_gives_each_entry_its_reason():
    text = WHITELIST.read_text(encoding="utf-8")
    lines = text.splitlines()
    body = ast.parse(text).body[1:]  # after the docstring
    assert body and all(isinstance(node, ast.Expr) for node in body)
    assert len(body) <= 30
    for node in body:
        above = lines[node.lineno - 2].strip()  # the line just above the entry
        assert above.startswith("#") and len(above) > 20, f"line {node.lineno}: no reason above it"


def test_vulture_reports_dead_code_added_to_a_copy(tmp_path):
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            target = tmp_path / path.relative_to(ROOT)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)
    (tmp_path / ".ci").mkdir()
    shutil.copyfile(WHITELIST, tmp_path / ".ci" / WHITELIST.name)
    shutil.copyfile(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    assert _vulture(tmp_path).returncode == 0  # the unchanged copy
    crops = tmp_path / "nvrq" / "crops.py"
    crops.write_text(crops.read_text(encoding="utf-8") + "\n\ndef _gone():\n    return 1\n    print('never')\n",
                     encoding="utf-8")
    proc = _vulture(tmp_path)
    assert proc.returncode == 3, proc.stdout + proc.stderr  # vulture's "dead code found"
    assert "nvrq/crops.py" in proc.stdout and "unreachable code after 'return'" in proc.stdout
    # without its whitelist, the one name the whitelist keeps is reported
    (tmp_path / ".ci" / WHITELIST.name).write_text('"""empty"""\n', encoding="utf-8")
    crops.write_text((ROOT / "nvrq" / "crops.py").read_text(encoding="utf-8"), encoding="utf-8")
    proc = _vulture(tmp_path)
    assert "unused variable 'session_id'" in proc.stdout
