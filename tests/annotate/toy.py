"""A tiny scene + pairs table for annotate tests, drawn with numpy/cv2 (no synth needed).

One clip, camera ``front`` (160x120), ``n_tracks`` boxes of two classes, ``n_frames`` frames,
offsets -1, 0, +1 m. Renders are the GT image blurred by ``|offset|`` (sigma 2 per metre);
``degradation.csv`` gives ``severity = |offset| / 2``.

``methods={NAME: SCALE, ...}`` makes a multi-method clip by hand (the ``method`` column of
docs/FORMATS.md §3): one render per method, blurred by ``SCALE`` times as much, one pairs row
per (object, view, method) with the same GT crop, ``pair_id`` suffixed with ``:NAME``, and
``degradation.csv`` rows per method with ``severity = SCALE * |offset| / 2``.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from data_schema.tables import pair_id

OFFSETS = (-1.0, 0.0, 1.0)


def make_toy(root: Path, *, n_tracks: int = 4, n_frames: int = 6, seed: int = 0,
             scene_root_column: bool = False,
             methods: dict[str, float] | None = None) -> tuple[Path, Path]:
    """Write ``root/scene/...`` images + degradation.csv and ``root/pairs.csv``; return both."""
    rng = np.random.default_rng(seed)
    scene = root / "scene"
    (scene / "images").mkdir(parents=True, exist_ok=True)
    rows, deg = [], []
    for f in range(n_frames):
        ts = 100000 * f
        img = rng.integers(0, 60, size=(120, 160, 3), dtype=np.uint8)
        boxes = []
        for t in range(n_tracks):
            x0, y0 = 5 + 35 * t, 20 + 5 * (f % 3)
            x1, y1 = x0 + 30, y0 + 40
            colour = (int(40 * t) % 255, 200, int(255 - 50 * t) % 255)
            cv2.rectangle(img, (x0, y0), (x1, y1), colour, thickness=-1)
            cv2.putText(img, str(t), (x0 + 5, y0 + 25), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (0, 0, 0), 2)
            boxes.append((x0, y0, x1, y1))
        gt_rel = f"images/gt_{ts}.png"
        cv2.imwrite(str(scene / gt_rel), img)
        for off, (method, scale) in [(o, m) for o in OFFSETS for m in (methods or {None: 1.0}).items()]:
            tag = "" if method is None else f"{method}_"
            ren_rel = f"images/render_{tag}{ts}_{off:+.1f}.png"
            sigma = 2.0 * abs(off) * scale
            ren = img if sigma == 0 else cv2.GaussianBlur(img, (0, 0), sigma)
            cv2.imwrite(str(scene / ren_rel), ren)
            for t, (x0, y0, x1, y1) in enumerate(boxes):
                tid = f"trk-{t}"
                shift = int(round(-4 * off))
                pid = pair_id("toy", "front", tid, ts, off)
                rows.append({
                    "pair_id": pid if method is None else f"{pid}:{method}", "clip_id": "toy",
                    "camera": "front", "track_id": tid,
                    "label_class": "automobile" if t % 2 == 0 else "pedestrian",
                    "timestamp_us": ts, "y_offset_m": off, "gt_path": gt_rel, "render_path": ren_rel,
                    "gt_x0": x0, "gt_y0": y0, "gt_x1": x1, "gt_y1": y1,
                    "r_x0": x0 + shift + 4, "r_y0": y0, "r_x1": x1 + shift + 4, "r_y1": y1,
                    "lighting": "daytime", "road_type": "urban",
                    **({} if method is None else {"method": method})})
                deg.append({"camera": "front", "timestamp_us": ts, "track_id": tid,
                            "y_offset_m": off, "severity": scale * abs(off) / 2,
                            "blur": scale * abs(off), **({} if method is None else {"method": method})})
    pairs = pd.DataFrame(rows)
    if scene_root_column:
        pairs["scene_root"] = "scene"
    pd.DataFrame(deg).to_csv(scene / "degradation.csv", index=False)
    pairs_path = root / "pairs.csv"
    pairs.to_csv(pairs_path, index=False)
    return scene, pairs_path


def copy_gap(gt_image: np.ndarray, box, shown: np.ndarray, *, side: int, size: int, max_shift: int) -> float:
    """How far a gold item's copy ``shown`` (size, size, 3) is from the GT image cut at the
    inclusive ``box`` moved by at most ``max_shift`` pixels each way: the smallest mean
    absolute difference (grey levels) over those moves, both sides blurred by 2 display
    pixels (a copy may be blurred by up to 1.5, annotate.crops.MAX_GOLD_BLUR). Made independently of annotate.crops: cut,
    centre on a black square of ``side``, resize bicubic (enlarging) or area (shrinking)."""
    h, w = gt_image.shape[:2]
    x0, y0, x1, y1 = (int(v) for v in box)
    blur = lambda im: cv2.GaussianBlur(im.astype(np.float32), (0, 0), 2.0)  # noqa: E731
    target, best = blur(shown), np.inf
    for dx in range(-max_shift, max_shift + 1):
        for dy in range(-max_shift, max_shift + 1):
            if not (0 <= x0 + dx and x1 + dx < w and 0 <= y0 + dy and y1 + dy < h):
                continue
            c = gt_image[y0 + dy:y1 + dy + 1, x0 + dx:x1 + dx + 1]
            sq = np.zeros((side, side, 3), np.uint8)
            top, left = (side - c.shape[0]) // 2, (side - c.shape[1]) // 2
            sq[top:top + c.shape[0], left:left + c.shape[1]] = c
            interp = cv2.INTER_AREA if side > size else cv2.INTER_CUBIC
            best = min(best, float(np.abs(blur(cv2.resize(sq, (size, size), interpolation=interp))
                                          - target).mean()))
    return best
