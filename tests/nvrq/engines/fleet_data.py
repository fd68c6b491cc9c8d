"""Test data for the engines: two clips of smooth random images and their pairs dataset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image

from data_schema import datasets as ds
from data_schema.tables import PAIRS_COLUMNS, pair_id

#: full-reference, no-reference (render crop alone) and encoder columns
METRICS = ["psnr", "ssim", "gmsd", "brisque", "niqe", "piqe", "entropy", "nvrq:efficientnet-lite0",
           "nvrq_ca:efficientnet-lite0"]
#: inclusive x0 y0 x1 y1; the first is 100 x 100 px, so NIQE (one 96x96 block) has values
BOXES = [(10, 12, 109, 111), (80, 10, 139, 49), (150, 60, 189, 109)]


def _smooth(rng, h, w):
    import cv2

    coarse = rng.integers(0, 256, (h // 16 + 1, w // 16 + 1, 3)).astype(np.float32)
    img = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC) + rng.normal(0, 8, (h, w, 3))
    return np.clip(img, 0, 255).astype(np.uint8)


def write_fleet(root: Path, *, n_clips: int = 2, n_frames: int = 4):
    """``n_clips`` clips x ``n_frames`` frames x 3 objects x 3 offsets (9 pairs per GT image)."""
    rng = np.random.default_rng(11)
    rows = []
    for c in range(n_clips):
        clip, scene = f"clip{c}", root / f"clip{c}"
        (scene / "img").mkdir(parents=True)
        for t in range(n_frames):
            ts = t * 100_000
            gt = _smooth(rng, 120, 200)
            Image.fromarray(gt).save(scene / f"img/gt_{ts}.png")
            for k, off in enumerate((-1.0, 0.0, 1.0)):
                shift = int(2 * off)
                r = np.roll(gt, shift, axis=1).astype(np.int16) + rng.normal(0, 4 + 6 * k, gt.shape)
                Image.fromarray(np.clip(r, 0, 255).astype(np.uint8)).save(scene / f"img/r_{ts}_{off:+.1f}.png")
                for j, (x0, y0, x1, y1) in enumerate(BOXES):
                    rows.append(dict(pair_id=pair_id(clip, "front", f"o{j}", ts, off), clip_id=clip,
                                     camera="front", track_id=f"o{j}", label_class="automobile",
                                     timestamp_us=ts, y_offset_m=off, gt_path=f"img/gt_{ts}.png",
                                     render_path=f"img/r_{ts}_{off:+.1f}.png", gt_x0=x0, gt_y0=y0,
                                     gt_x1=x1, gt_y1=y1, r_x0=x0 + shift, r_y0=y0, r_x1=x1 + shift,
                                     r_y1=y1, scene_root=str(scene)))
    pairs = pd.DataFrame(rows)[list(PAIRS_COLUMNS) + ["scene_root"]]
    with ds.DatasetWriter(root / "pairs") as w:
        for clip, g in pairs.groupby("clip_id"):
            w.write(clip, g)
    return root, root / "pairs"


def local_scores(root: Path, pairs_ds: Path) -> pd.DataFrame:
    """The local engine's scores of the same pairs (tau 0.6), in the dataset's order."""
    from nvrq.cli import main

    flat = ds.read_dataset(pairs_ds)
    flat.to_parquet(root / "flat.parquet")
    assert main(["score", str(root / "flat.parquet"), "--out", str(root / "local.parquet"), "--metrics",
                 ",".join(METRICS), "--tau", "0.6", "--quiet"]) == 0
    return pd.read_parquet(root / "local.parquet")
