"""Every ``nvrq.…`` name that docs/PYTHON.md gives resolves after a plain ``import nvrq``.

The names are read from the guide itself (dotted ``nvrq.a.b`` names in its text and code, and the
``from nvrq.x import y`` lines of its examples), and resolved attribute by attribute in a fresh
interpreter that ran nothing but ``import nvrq``, so a name that works only after some other import
(``import nvrq.sets``) fails here.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "PYTHON.md"

_DOTTED = re.compile(r"(?<![\w./])nvrq(?:\.[A-Za-z_]\w*)+")
_FROM = re.compile(r"^from (nvrq(?:\.\w+)*) import ([\w, ]+)$", re.MULTILINE)

_RESOLVE = """
import json, sys
import nvrq
missing = {}
for name in json.loads(sys.argv[1]):
    obj = nvrq
    for i, part in enumerate(name.split(".")[1:], start=1):
        try:
            obj = getattr(obj, part)
        except AttributeError as e:
            missing[name] = ".".join(name.split(".")[:i + 1]) + ": " + str(e)
            break
print(json.dumps(missing))
"""


def guide_names(text: str) -> list[str]:
    """The dotted ``nvrq`` names of ``text``: ``nvrq.a.b`` and each ``from nvrq.a import b`` as
    ``nvrq.a.b``."""
    names = set(_DOTTED.findall(text))
    for module, imported in _FROM.findall(text):
        names |= {f"{module}.{n.strip()}" for n in imported.split(",") if n.strip()}
    return sorted(names)


def test_guide_names_are_read_from_text_and_imports():
    # a hand-made snippet: a name in prose, one in a call, a path (not a name) and an import line
    text = ("Use `nvrq.sets.kid(x)` or nvrq.Evaluator. See nvrq/api.py.\n"
            "from nvrq.pairs import track_boxes_at, DROP_REASONS\n")
    assert guide_names(text) == ["nvrq.Evaluator", "nvrq.pairs", "nvrq.pairs.DROP_REASONS",
                                 "nvrq.pairs.track_boxes_at", "nvrq.sets.kid"]


def _unresolved(names: list[str]) -> dict:
    out = subprocess.run([sys.executable, "-c", _RESOLVE, json.dumps(names)], cwd=ROOT,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def test_every_name_in_the_python_guide_resolves_after_import_nvrq():
    names = guide_names(GUIDE.read_text(encoding="utf-8"))
    # the guide's subpackages and its top-level API are all there to be checked
    assert {"nvrq.sets.kid", "nvrq.scoring.core", "nvrq.metrics.REGISTRY", "nvrq.Evaluator",
            "nvrq.geometry.poses.interpolate_poses"} <= set(names)
    assert _unresolved(names) == {}


def test_a_name_that_does_not_exist_is_reported():
    # the check can fail: a missing submodule and a missing attribute of a real one
    assert set(_unresolved(["nvrq.no_such_module.x", "nvrq.sets.no_such_name"])) == {
        "nvrq.no_such_module.x", "nvrq.sets.no_such_name"}
