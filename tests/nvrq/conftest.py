"""Fixtures for the scoring tests: a tiny scene of smooth random images written as PNG."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest
from PIL import Image

from data_schema.tables import PAIRS_COLUMNS, pair_id


def smooth_image(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """A smooth random RGB uint8 image (H, W, 3): upsampled coarse noise (object-like blobs)."""
    coarse = rng.integers(0, 256, (h // 16 + 1, w // 16 + 1, 3)).astype(np.float32)
    img = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC)
    fine = rng.normal(0, 8, (h, w, 3))
    return np.clip(img + fine, 0, 255).astype(np.uint8)


def write_rgb(path, rgb: np.ndarray) -> None:
    """Write an RGB array with Pillow (an RGB-native writer, independent of OpenCV)."""
    Image.fromarray(rgb).save(path)


@pytest.fixture
def tiny_scene(tmp_path):
    """2 frames x 3 objects x 3 offsets = 18 pairs; renders are shifted, noisier GT copies.

    Returns (scene_root, pairs DataFrame with a scene_root column).
    """
    rng = np.random.default_rng(7)
    h, w = 120, 200
    offsets = [-1.0, 0.0, 1.0]
    boxes = [(10, 20, 59, 79), (80, 10, 139, 49), (150, 60, 189, 109)]  # inclusive x0 y0 x1 y1
    rows = []
    (tmp_path / "gt").mkdir()
    (tmp_path / "render").mkdir()
    for t in (0, 100000):
        gt = smooth_image(rng, h, w)
        gt_rel = f"gt/front_{t}.png"
        write_rgb(tmp_path / gt_rel, gt)
        for k, off in enumerate(offsets):
            shift = int(2 * off)
            render = np.roll(gt, shift, axis=1).astype(np.int16) + rng.normal(0, 4 + 6 * k, gt.shape)
            r_rel = f"render/front_{t}_{off:+.1f}.png"
            write_rgb(tmp_path / r_rel, np.clip(render, 0, 255).astype(np.uint8))
            for j, (x0, y0, x1, y1) in enumerate(boxes):
                cls = ["automobile", "pedestrian", "truck"][j]
                rows.append(dict(
                    pair_id=pair_id("clip", "front", f"obj{j}", t, off), clip_id="clip", camera="front",
                    track_id=f"obj{j}", label_class=cls, timestamp_us=t, y_offset_m=off,
                    gt_path=gt_rel, render_path=r_rel, gt_x0=x0, gt_y0=y0, gt_x1=x1, gt_y1=y1,
                    r_x0=x0 + shift, r_y0=y0, r_x1=x1 + shift, r_y1=y1))
    pairs = pd.DataFrame(rows, columns=list(PAIRS_COLUMNS))
    pairs["scene_root"] = str(tmp_path)
    return tmp_path, pairs
