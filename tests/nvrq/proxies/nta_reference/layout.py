"""Inputs of the ``recondreamer`` acceptance test, written in ReconDreamer's text layout.

``make_inputs(seed)`` draws, per shift and frame, integer projected boxes in a 480x320 image and
the detections of a detector with known jitter, misses, false positives and near-ties (two
detections at the same distance from a box centre, so the first-in-file rule matters).
``write_layout(root, inputs)`` writes them as ReconDreamer's scripts leave them:

- ``ROOT/shift_gt/{shift}/{frame:06d}_0.txt``: one projected box per line, ``x_min,y_min,x_max,y_max``
  (``GT.py``'s output);
- ``ROOT/detect_txt/shifting_{shift}_lane/{frame:06d}_0_rgb.txt``: one detection per line,
  ``x1,y1,x2,y2`` (``detect.py``'s output: classes car and bus, score > 0.5, ``int()``-truncated).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

SHIFTS = (-3, -2, -1, 1, 2, 3, 4, 5)  # calculate.py's shift_values
N_FRAMES = 6


def make_inputs(seed: int = 35) -> dict:
    """``{shift: [(boxes (n, 4) int, dets (m, 4) int) per frame]}``; jitter grows with |shift|."""
    rng = np.random.default_rng(seed)
    out = {}
    for shift in SHIFTS:
        frames = []
        for _ in range(N_FRAMES):
            n = int(rng.integers(0, 7))
            x0 = rng.integers(0, 420, n)
            y0 = rng.integers(0, 280, n)
            w = rng.integers(4, 60, n)
            h = rng.integers(4, 40, n)
            boxes = np.stack([x0, y0, np.minimum(x0 + w, 480), np.minimum(y0 + h, 320)], axis=1)
            jitter = rng.integers(-abs(shift) * 2, abs(shift) * 2 + 1, (n, 4))
            dets = boxes + jitter
            dets[:, 2:] = np.maximum(dets[:, 2:], dets[:, :2])
            dets = dets[rng.random(n) > 0.2]  # misses
            fp = rng.integers(0, 400, (int(rng.integers(0, 3)), 2))
            fps = np.concatenate([fp, fp + rng.integers(5, 50, fp.shape)], axis=1)
            ties = []
            if n:  # two detections with the same centre distance from box 0 (6 px left and right)
                b = boxes[0]
                ties = [b + np.array([-6, 0, -6, 0]), b + np.array([6, 0, 6, 0])]
            dets = np.concatenate([dets, fps, *[t[None] for t in ties]]).astype(np.int64).reshape(-1, 4)
            frames.append((boxes.astype(np.int64).reshape(-1, 4), dets[rng.permutation(len(dets))]))
        out[shift] = frames
    return out


def write_layout(root: Path, inputs: dict) -> None:
    """Write ``inputs`` in ReconDreamer's layout under ``root`` (module docstring)."""
    root = Path(root)
    for shift, frames in inputs.items():
        gt_dir = root / "shift_gt" / str(shift)
        det_dir = root / "detect_txt" / f"shifting_{shift}_lane"
        gt_dir.mkdir(parents=True, exist_ok=True)
        det_dir.mkdir(parents=True, exist_ok=True)
        for f, (boxes, dets) in enumerate(frames):
            (gt_dir / f"{f:06d}_0.txt").write_text("".join(",".join(map(str, b)) + "\n" for b in boxes.tolist()))
            (det_dir / f"{f:06d}_0_rgb.txt").write_text("".join(
                f"{d[0]},{d[1]},{d[2]},{d[3]}\n" for d in dets.tolist()))


def layout_digest(root: Path) -> str:
    """sha256 over the layout's relative paths and bytes (sorted), to pin the written files."""
    import hashlib

    h = hashlib.sha256()
    for p in sorted(Path(root).rglob("*.txt")):
        h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()
