"""Measure how well the log's viewpoint floor (``nvrq pairs --floor``) predicts a perfect render.

Usage: ``python docs/make_floor_numbers.py OUT [--fps 5]`` renders the synthetic check clip of
docs/FORMATS.md §3 (2 s, 640x360, seed 0, ``--methods perfect:0,sharp:0.5``, offsets -3..3),
makes its pairs with ``--floor``, scores them (PSNR and NVRQ-CA on efficientnet-lite0) and prints,
per lateral offset the floor covers, the medians of the floor and of the perfect render on the
same novel views (:func:`analysis.common.viewpoint_floor.floor_check`) and the verdict of the rule that
decides whether reports draw a log's floor (:func:`analysis.common.viewpoint_floor.floor_verdict`).
It takes a few minutes on a laptop CPU; the figures go into docs/FORMATS.md §3 and
:data:`analysis.common.viewpoint_floor.MEASURED_GAPS` by hand.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from analysis.common.viewpoint_floor import floor_check, floor_verdict
from nvrq.cli import main as nvrq_main

CA = "nvrq_ca:efficientnet-lite0"


def main() -> int:
    """Run the check clip and print the table (see the module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path, help="an empty or absent folder for the clip and its tables")
    p.add_argument("--fps", default="5", help="frame rate of the clip (default 5)")
    args = p.parse_args()
    scene, pairs, metrics = args.out / "scene", args.out / "pairs.csv", args.out / "metrics.csv"
    for argv in (["synth", str(scene), "--seed", "0", "--seconds", "2", "--size", "640x360", "--fps", args.fps,
                  "--methods", "perfect:0,sharp:0.5", "--offsets=-3,-2,-1,0,1,2,3", "--quiet"],
                 ["pairs", str(scene), "--out", str(pairs), "--floor", "--quiet"],
                 ["score", str(pairs), "--out", str(metrics), "--metrics", "psnr,nvrq_ca",
                  "--encoder", "efficientnet-lite0", "--quiet"]):
        if nvrq_main(argv):
            return 1
    items = pd.read_csv(pairs, keep_default_na=False, na_values=[""], dtype={"track_id": str, "camera": str})
    items = items.merge(pd.read_csv(metrics), on="pair_id")
    floor = items[items["method"] == "floor"]
    print(f"floor rows: {len(floor)}; their novel views' viewing-angle change: median "
          f"{floor['view_angle_deg'].median():.2f} deg; the partners': {floor['floor_angle_deg'].median():.2f} deg")
    checks = {m: floor_check(items, m).set_index("offset") for m in (CA, "psnr")}
    print("| offset | n | NVRQ-CA floor | NVRQ-CA perfect (same views) | gap | PSNR floor | PSNR perfect | gap |")
    print("|---|---|---|---|---|---|---|---|")
    for off, r in checks[CA].iterrows():
        s = checks["psnr"].loc[off]
        print(f"| {off:+g} m | {int(r['n'])} | {r['floor']:.3f} | {r['perfect']:.3f} | {r['gap']:+.3f} | "
              f"{s['floor']:.2f} | {s['perfect']:.2f} | {s['gap']:+.2f} |")
    gaps = {float(o): float(g) for o, g in checks[CA]["gap"].items()}
    print("gaps:", {o: round(g, 3) for o, g in gaps.items()})
    print(floor_verdict(gaps, gaps, source="on this clip").sentence)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
