"""Every relative link and ``#anchor`` of README.md and docs/ resolves.

A link's target file must exist (relative to the document that holds it); its ``#anchor``
must be the slug of a heading of that file, made as GitHub makes it (lowercase, punctuation
other than ``-`` and ``_`` dropped, each space a ``-``, repeats numbered ``-1``, ``-2``).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCUMENTS = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def _without_code(text: str) -> str:
    """``text`` with fenced blocks and inline code cut out (links there are not links)."""
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    return re.sub(r"`[^`\n]*`", "", text)


def slug(heading: str) -> str:
    s = heading.strip().lower().replace("`", "")
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    text = re.sub(r"```.*?```", "", path.read_text(encoding="utf-8"), flags=re.S)
    for heading in re.findall(r"^#{1,6} (.+)$", text, flags=re.M):
        s = slug(heading)
        n = seen.get(s, 0)
        out.add(s if n == 0 else f"{s}-{n}")
        seen[s] = n + 1
    return out


def test_slug_matches_github():
    assert slug("Run a public study") == "run-a-public-study"
    assert slug("3. Pairs — `nvrq pairs SCENE --out PAIRS.{csv,parquet}`") == \
        "3-pairs--nvrq-pairs-scene---out-pairscsvparquet"


def _links():
    for doc in DOCUMENTS:
        for target in LINK.findall(_without_code(doc.read_text(encoding="utf-8"))):
            if not re.match(r"[a-z]+:", target):
                yield pytest.param(doc, target, id=f"{doc.relative_to(REPO)}:{target}")


@pytest.mark.parametrize(("doc", "target"), list(_links()))
def test_link_resolves(doc, target):
    file, _, anchor = target.partition("#")
    path = (doc.parent / file).resolve() if file else doc
    assert path.exists(), f"{doc.relative_to(REPO)}: {target}: no such file"
    if anchor:
        assert path.suffix == ".md" and anchor in anchors(path), \
            f"{doc.relative_to(REPO)}: {target}: no heading with that anchor"
