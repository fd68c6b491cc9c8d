"""An independent re-implementation of ReconDreamer's ``script/NTAIou/script/calculate.py``
(GigaAI-research/ReconDreamer, commit 959c859), used only to make the acceptance fixture
``expected_recondreamer.json``; the test itself does not run it.

Semantics kept from ``calculate.py``, loop for loop:

- every detect folder ``shifting_{k}_*`` whose ``k`` is one of the shift values; every ``.txt``
  in it; its GT file is the same name with ``_rgb.`` replaced by ``.`` under ``shift_gt/{k}``
  (a missing GT file is skipped);
- each GT box takes the detection whose centre is nearest, the running minimum starting at
  10 px and updated only on a strictly smaller distance (``np.linalg.norm`` of the centre
  difference), so the first detection of equal distance wins and a detection at exactly 10 px
  is never taken; no one-to-one assignment;
- IoU without ``+1``; 0 for a box without a detection;
- the average per shift over every box of every frame (0 for a shift without boxes).

Command that made the fixture (from the repository root)::

    python tests/nvrq/proxies/nta_reference/reference_recondreamer.py --seed 35 \
        --out tests/nvrq/proxies/nta_reference/expected_recondreamer.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

SHIFT_VALUES = [-1, -2, -3, 1, 2, 3, 4, 5]


def box_iou(a, b):
    ix0, iy0, ix1, iy1 = max(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), min(a[3], b[3])
    inter = max(0, ix1 - ix0) * max(0, iy1 - iy0)
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union


def nearest(gt, dets):
    centre = np.array([(gt[0] + gt[2]) / 2, (gt[1] + gt[3]) / 2])
    best, found = 10, None
    for d in dets:
        dist = np.linalg.norm(centre - np.array([(d[0] + d[2]) / 2, (d[1] + d[3]) / 2]))
        if dist < best:
            best, found = dist, d
    return found if best <= 10 else None


def read_rows(path):
    with open(path) as f:
        return [list(map(float, line.strip().split(","))) for line in f.readlines()]


def average_iou(root: Path) -> dict:
    per_shift = {s: [] for s in SHIFT_VALUES}
    det_root = root / "detect_txt"
    for folder in os.listdir(det_root):
        try:
            shift = int(folder.split("shifting_")[1].split("_")[0])
        except (IndexError, ValueError):
            continue
        gt_dir = root / "shift_gt" / str(shift)
        if shift not in SHIFT_VALUES or not gt_dir.exists():
            continue
        for name in [f for f in os.listdir(det_root / folder) if f.endswith(".txt")]:
            dets = read_rows(det_root / folder / name)
            gt_file = str(gt_dir / name).replace("_rgb.", ".")
            if not os.path.exists(gt_file):
                continue
            for gt in read_rows(gt_file):
                d = nearest(gt, dets)
                per_shift[shift].append(box_iou(gt, d) if d is not None else 0)
    return {s: (sum(v) / len(v) if v else 0) for s, v in per_shift.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=35)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from layout import layout_digest, make_inputs, write_layout

    with tempfile.TemporaryDirectory() as tmp:
        write_layout(Path(tmp), make_inputs(args.seed))
        result = average_iou(Path(tmp))
        digest = layout_digest(Path(tmp))
    doc = {"command": "python tests/nvrq/proxies/nta_reference/reference_recondreamer.py --seed "
                      f"{args.seed} --out {args.out}",
           "seed": args.seed, "layout_sha256": digest,
           "average_iou": {str(k): float(v) for k, v in result.items()}}
    Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc["average_iou"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
