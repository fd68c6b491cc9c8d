"""The visibility rule's figures in docs/FORMATS.md §3 and the README: pooled and within-view
SRCC of each metric with the true severity, at several ``--min-visible`` values.

For each clip (the demo's own clip at ``nvrq demo``'s defaults, and two 6 s clips at 5 fps,
640x360, rendered by two methods): ``nvrq synth`` (offsets -3..3), ``nvrq pairs --min-visible 0`` (every
pair, with its visible fractions), ``nvrq score`` (PSNR, SSIM, NVRQ, NVRQ-CA on
efficientnet-lite0); then, for each rule ``F``, the pairs at least ``F`` visible in both views.
Pooled SRCC: Spearman of the metric with ``-severity`` over the off-path pairs. Within-view
SRCC: the same inside each method x offset cell off the path (cells of at least 10 pairs from at
least 5 tracks), averaged over the cells. Run: ``python docs/make_visibility_numbers.py``
(several minutes per clip).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import spearmanr

CLIPS = {  # name: (seed, seconds, fps, size, methods; None: nvrq synth's own, the demo's render)
    "demo": (0, 6, 10, "960x540", None),  # `nvrq demo`'s clip at its defaults
    "crowded": (0, 6, 5, "640x360", "sharp:0.5,blurry:1.5"),
    "open": (13, 6, 5, "640x360", "sharp:0.5,blurry:1.5"),
}
METRICS = ["psnr", "ssim", "nvrq:efficientnet-lite0", "nvrq_ca:efficientnet-lite0"]
RULES = [0.0, 0.5, 0.8, 0.9]


def nvrq(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "nvrq", *args, "--quiet"], check=True)


def within(df: pd.DataFrame, metric: str) -> tuple[float, int]:
    rs = []
    for _, cell in df.groupby([c for c in ("method", "y_offset_m") if c in df.columns]):
        if len(cell) >= 10 and cell.track_id.nunique() >= 5:
            r = spearmanr(cell[metric], -cell.severity).statistic
            if np.isfinite(r):
                rs.append(r)
    return (float(np.mean(rs)) if rs else float("nan")), len(rs)


def clip_table(name: str, out: Path) -> pd.DataFrame:
    seed, seconds, fps, size, methods = CLIPS[name]
    scene = out / name
    if not (out / f"{name}_metrics.csv").exists():
        nvrq("synth", str(scene), "--seed", str(seed), "--seconds", str(seconds), "--fps", str(fps), "--size", size,
             "--offsets=-3,-2,-1,0,1,2,3", *(["--methods", methods] if methods else []))
        nvrq("pairs", str(scene), "--out", str(out / f"{name}_pairs.csv"), "--min-visible", "0")
        nvrq("score", str(out / f"{name}_pairs.csv"), "--out", str(out / f"{name}_metrics.csv"),
             "--metrics", "psnr,ssim,nvrq,nvrq_ca", "--encoder", "efficientnet-lite0")
    pairs = pd.read_csv(out / f"{name}_pairs.csv")
    metrics = pd.read_csv(out / f"{name}_metrics.csv")
    deg = pd.read_csv(scene / "degradation.csv")
    keys = [k for k in ("camera", "timestamp_us", "track_id", "y_offset_m", "method") if k in deg.columns]
    df = pairs.merge(metrics, on="pair_id", suffixes=("", "_m")).merge(deg[[*keys, "severity"]], on=keys)
    df = df[df.y_offset_m != 0]
    rows = []
    for rule in RULES:
        sub = df[(df.gt_visible >= rule) & (df.novel_visible >= rule)]
        for m in METRICS:
            col = next(c for c in metrics.columns if c == m or c.startswith(m.split(":")[0] + ":") or c == m.split(":")[0])
            w, cells = within(sub, col)
            rows.append({"clip": name, "min_visible": rule, "pairs": len(sub), "metric": col,
                         "pooled_srcc": spearmanr(sub[col], -sub.severity).statistic, "within_view_srcc": w,
                         "cells": cells})
    return pd.DataFrame(rows)


BLOCK_FILES = ("README.md", "docs/FORMATS.md")
_BLOCK = re.compile(r"(<!-- numbers:visibility -->\n)(.*?)(<!-- /numbers:visibility -->)", re.S)


def side_by_side(table: pd.DataFrame, rule: float = 0.8) -> str:
    """The paper's protocol (``--min-visible 0``) beside the rule, one row per clip and metric."""
    lines = [f"| clip | metric | pairs (0 / {rule:g}) | pooled SRCC, paper's protocol | pooled SRCC, rule "
             f"| within-view SRCC, paper's protocol | within-view SRCC, rule |", "|---|---|---|---|---|---|---|"]
    for (clip, metric), g in table.groupby(["clip", "metric"], sort=False):
        a = g[g.min_visible == 0].iloc[0]
        b = g[g.min_visible == rule].iloc[0]
        lines.append(f"| {clip} | {metric} | {a.pairs} / {b.pairs} | {a.pooled_srcc:.3f} | {b.pooled_srcc:.3f} "
                     f"| {a.within_view_srcc:.3f} ({a.cells} cells) | {b.within_view_srcc:.3f} ({b.cells} cells) |")
    return "\n".join(lines) + "\n"


def write_blocks(text: str) -> None:
    repo = Path(__file__).resolve().parents[1]
    for rel in BLOCK_FILES:
        path = repo / rel
        body = path.read_text()
        new = _BLOCK.sub(lambda m: m.group(1) + text + m.group(3), body)
        path.write_text(new)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/visibility", help="work folder (kept: a rerun reuses its scores)")
    ap.add_argument("--clips", default=",".join(CLIPS))
    ap.add_argument("--write", action="store_true", help="rewrite the marked blocks of the README and FORMATS")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = pd.concat([clip_table(c, out) for c in args.clips.split(",")], ignore_index=True)
    table.to_csv(out / "visibility_numbers.csv", index=False)
    text = side_by_side(table)
    print(text)
    if args.write:
        write_blocks(text)


if __name__ == "__main__":
    main()
