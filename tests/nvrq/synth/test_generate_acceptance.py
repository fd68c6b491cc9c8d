"""Acceptance of ``nvrq synth`` (issue 3): pairs for every class and offset, severity grows
with |offset|, renders at 3 m differ from GT more than at 0 m, determinism."""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
from scipy.stats import spearmanr

from data_schema.scene import load_scene
from nvrq.pairs import make_pairs
from nvrq.synth import generate_scene

CLASSES = ["automobile", "bus", "heavy_truck", "person", "rider"]
OFFSETS = [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]


@pytest.fixture(scope="module")
def clip(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("synth") / "clip"
    return generate_scene(out, seed=0, seconds=4.0, size=(640, 360), progress=False)


@pytest.fixture(scope="module")
def pairs(clip):
    scene = load_scene(clip)
    p, _ = make_pairs(scene, min_visible=0, progress=False)  # the paper's protocol: every class at every offset
    return scene, p


def test_pairs_at_every_offset_for_every_class(pairs):
    _, p = pairs
    table = (
        pd.crosstab(p.label_class, p.y_offset_m).reindex(index=CLASSES, columns=OFFSETS).fillna(0)
    )
    assert (table.to_numpy() > 0).all(), table


def test_severity_rises_with_offset(clip):
    deg = pd.read_csv(clip / "degradation.csv")
    rho = spearmanr(deg.y_offset_m.abs(), deg.severity).statistic
    assert rho > 0.5
    assert deg.severity.between(0, 1).all()
    for a in ["blur", "ghost", "floaters", "smear", "color_shift", "holes"]:
        assert deg[a].between(0, 1).all() and (deg[a] <= deg.severity + 1e-9).all()
    # the 0 m render is close to, but not exactly, the GT (latent severity > 0)
    assert (deg[deg.y_offset_m == 0].severity > 0).all()


@functools.lru_cache(maxsize=256)
def _read(path: Path) -> np.ndarray:
    return cv2.imread(str(path), cv2.IMREAD_COLOR)


def _crop(root: Path, path: str, box) -> np.ndarray:
    x0, y0, x1, y1 = box
    return _read(root / path)[y0 : y1 + 1, x0 : x1 + 1].astype(np.float32)


def test_render_crops_at_3m_differ_more_than_at_0m(pairs):
    scene, p = pairs
    diffs = {}
    for o in (0.0, 3.0, -3.0):
        sub = p[p.y_offset_m == o].sort_values(["timestamp_us"])
        vals = []
        for r in sub.itertuples():
            gt = _crop(scene.root, r.gt_path, (r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1))
            rd = _crop(scene.root, r.render_path, (r.r_x0, r.r_y0, r.r_x1, r.r_y1))
            rd = cv2.resize(rd, (gt.shape[1], gt.shape[0]), interpolation=cv2.INTER_CUBIC)
            vals.append(np.abs(gt - rd).mean())
        diffs[o] = np.array(vals)
    assert diffs[0.0].mean() > 0.0  # not identical
    assert diffs[3.0].mean() > diffs[0.0].mean() and diffs[-3.0].mean() > diffs[0.0].mean()
    assert np.median(diffs[3.0]) > 2 * np.median(diffs[0.0])


def test_images_are_rgb_pngs_of_the_requested_size(clip):
    images = pd.read_csv(clip / "images.csv")
    assert set(images.source) == {"gt", "render"}
    assert sorted(images[images.source == "render"].y_offset_m.unique()) == OFFSETS
    img = cv2.imread(str(clip / images.path.iloc[0]), cv2.IMREAD_UNCHANGED)
    assert img.shape == (360, 640, 3)
    # sky (top rows, daytime or night) is blue-ish: in RGB order blue >= red, and cv2 reads BGR
    top = img[:10].reshape(-1, 3).mean(0)
    assert top[0] >= top[2]


def _digest(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def test_same_seed_is_byte_identical_and_seeds_differ(tmp_path):
    kw = dict(
        seconds=0.2,
        fps=10.0,
        offsets=(-1, 0, 2),
        cameras=("pinhole", "ftheta"),
        size=(192, 128),
        progress=False,
    )
    a = _digest(generate_scene(tmp_path / "a", seed=7, **kw))
    b = _digest(generate_scene(tmp_path / "b", seed=7, **kw))
    c = _digest(generate_scene(tmp_path / "c", seed=8, **kw))
    assert a == b
    assert (
        len(a) == 3 + 2 * 2 * 4
    )  # scene.json, images.csv, degradation.csv; 2 cams x 2 frames x 4 images
    assert a["scene.json"] != c["scene.json"]
    assert sum(a[k] != c.get(k) for k in a) > len(a) // 2
