"""The viewpoint floor of a log (``nvrq pairs --floor``, :mod:`nvrq.floor`): a hand-built drive past
a parked car, where the novel view moved ``k`` m forward is exactly the GT view ``k`` frames later."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pandas as pd
import pytest
from PIL import Image

from data_schema.scene import load_scene, save_scene
from nvrq.cli import main as nvrq_main
from nvrq.floor import FLOOR_COLUMNS, add_floor, viewing_geometry
from nvrq.metrics.pixel import psnr
from nvrq.pairs import make_pairs

W, H, F = 640, 360, 400.0
CX, CY = 319.5, 179.5
#: a camera looking left (rig +y): camera x right = rig +x, y down = rig -z, z forward = rig +y
T_SENSOR_RIG = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 1.5], [0, 0, 0, 1.0]])
#: the rig drives along world x at 1 m per frame (0.1 s)
N_FRAMES, STEP_M, DT_US = 9, 1.0, 100_000
#: the parked car: centre (6, 8, 0.8), 4.5 x 1.9 x 1.6 m, yawed 30 deg
CAR = (6.0, 8.0, 0.8)
YAW = math.radians(30.0)
DIMS = (4.5, 1.9, 1.6)


def _pose7():
    return [*CAR, 0.0, 0.0, math.sin(YAW / 2), math.cos(YAW / 2)]


def _rig(i: int) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = STEP_M * i
    return T


def _box_px(i: int) -> tuple[int, int, int, int]:
    """The car's inclusive pixel box in GT frame ``i``, by the pinhole formula (independent of nvrq)."""
    c, s = math.cos(YAW), math.sin(YAW)
    signs = np.array([[a, b, d] for a in (-1, 1) for b in (-1, 1) for d in (-1, 1)], float)
    local = signs * np.array(DIMS) / 2
    world = local @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T + np.array(CAR)
    cam = (world - (np.array([STEP_M * i, 0, 0]) + T_SENSOR_RIG[:3, 3])) @ T_SENSOR_RIG[:3, :3]  # R^T (p - t)
    u = F * cam[:, 0] / cam[:, 2] + CX
    v = F * cam[:, 1] / cam[:, 2] + CY
    return (math.floor(u.min()), math.floor(v.min()), math.ceil(u.max()), math.ceil(v.max()))


def _valid(i: int) -> bool:
    """Whether the car passes the box rule of ``nvrq pairs`` in GT frame ``i`` (inside, sides >= 30 px)."""
    x0, y0, x1, y1 = _box_px(i)
    return 0 <= x0 and x1 <= W - 1 and 0 <= y0 and y1 <= H - 1 and min(x1 - x0 + 1, y1 - y0 + 1) >= 30


def _scene(root, *, frames=N_FRAMES, forward=(-1.0, 0.0, 1.0, 2.0), lateral=()):
    rng = np.random.default_rng(3)
    rows = []
    for i in range(frames):
        t = i * DT_US
        coarse = rng.integers(0, 256, (H // 16 + 1, W // 16 + 1, 3)).astype(np.float32)
        img = np.clip(cv2.resize(coarse, (W, H), interpolation=cv2.INTER_CUBIC), 0, 255).astype(np.uint8)
        (root / "gt").mkdir(parents=True, exist_ok=True)
        Image.fromarray(img).save(root / f"gt/{t}.png")
        rows.append(("side", t, "gt", 0.0, 0.0, f"gt/{t}.png"))
        for dx in forward:
            rows.append(("side", t, "render", 0.0, dx, f"gt/{t}.png"))  # the render files are not read here
        for dy in lateral:
            rows.append(("side", t, "render", dy, 0.0, f"gt/{t}.png"))
    images = pd.DataFrame(rows, columns=["camera", "timestamp_us", "source", "y_offset_m", "x_offset_m", "path"])
    doc = {"clip_id": "drive", "attributes": {},
           "cameras": {"side": {"T_sensor_rig": T_SENSOR_RIG, "model": {
               "type": "pinhole", "resolution": [W, H], "focal_length": [F, F], "principal_point": [CX, CY]}}},
           "rig_trajectory": {"timestamps_us": [i * DT_US for i in range(frames)],
                              "T_rig_world": [_rig(i) for i in range(frames)]},
           "tracks": [{"track_id": "car", "label_class": "automobile", "dims_lwh": list(DIMS),
                       "timestamps_us": sorted({0, (frames - 1) * DT_US}),
                       "poses": [_pose7()] * len({0, (frames - 1) * DT_US})}]}
    save_scene(doc, images, root)
    return root


def _angle_between_frames(i: int, j: int) -> float:
    """The angle (deg) between the car's viewing directions from frames i and j (world vectors:
    a rotation of both into the box frame keeps their angle)."""
    a = np.array([STEP_M * i, 0, 1.5]) - np.array(CAR)
    b = np.array([STEP_M * j, 0, 1.5]) - np.array(CAR)
    return math.degrees(math.acos(a @ b / np.linalg.norm(a) / np.linalg.norm(b)))


def test_viewing_geometry_is_the_box_frame_direction():
    T = np.eye(4)[None].copy()
    T[0, :3, :3] = [[math.cos(YAW), -math.sin(YAW), 0], [math.sin(YAW), math.cos(YAW), 0], [0, 0, 1]]
    T[0, :3, 3] = CAR
    d, r = viewing_geometry(T, np.array([[6.0, 0.0, 0.8]]))
    # the camera is 8 m along world -y: in a box yawed 30 deg, that is (-sin 30, -cos 30, 0)
    assert d[0] == pytest.approx([-0.5, -math.sqrt(3) / 2, 0.0]) and r[0] == pytest.approx(8.0)


def test_forward_view_finds_the_later_frame(tmp_path):
    scene = load_scene(_scene(tmp_path / "s"))
    pairs, _ = make_pairs(scene, progress=False)
    out, stats = add_floor(scene, pairs, min_side=30, min_area=0)
    floor = out[out["method"] == "floor"].set_index(["timestamp_us", "x_offset_m"])
    assert stats.views == int((pairs["x_offset_m"] != 0).sum()) and stats.matched == len(floor) > 0
    assert set(FLOOR_COLUMNS) <= set(out.columns)
    for (t, dx), row in floor.iterrows():
        i = t // DT_US
        j = i + int(dx)
        # any partner is within the tolerances of its novel view's change of viewpoint
        assert abs(row["floor_angle_deg"] - row["view_angle_deg"]) <= max(1.0, 0.15 * row["view_angle_deg"])
        assert abs(math.log(row["floor_ratio"] / row["view_ratio"])) <= math.log(1.1)
        assert dx != 0  # the recorded view has no floor row
        if not (0 <= j < N_FRAMES and _valid(j)):  # no exact partner in the log
            assert row["render_path"] != row["gt_path"]
            continue
        # moved dx m forward = exactly the GT view dx frames later (angle and distance equal)
        assert row["render_path"] == f"gt/{j * DT_US}.png", (t, dx)
        assert (row["r_x0"], row["r_y0"], row["r_x1"], row["r_y1"]) == _box_px(j)
        assert (row["gt_x0"], row["gt_y0"], row["gt_x1"], row["gt_y1"]) == _box_px(i)
        assert row["view_angle_deg"] == pytest.approx(_angle_between_frames(i, j), abs=1e-6)
        assert row["floor_angle_deg"] == pytest.approx(row["view_angle_deg"], abs=1e-6)
        assert row["floor_ratio"] == pytest.approx(row["view_ratio"], abs=1e-9)
    # every forward view whose later frame exists and shows the car gets its floor row (the others
    # may find a mirror view: the same angle and distance on the car's other side)
    kept = set(pairs.set_index(["timestamp_us", "x_offset_m"]).index)
    want = {(t, dx) for t, dx in kept if dx != 0 and 0 <= t // DT_US + dx < N_FRAMES and _valid(int(t // DT_US + dx))}
    got = {k for k in floor.index if k[1] != 0}
    assert want and want <= got
    assert floor.index.is_unique and out["pair_id"].is_unique
    recorded = out[out["x_offset_m"] == 0]
    assert (recorded["view_angle_deg"] == 0).all() and (recorded["view_ratio"] == 1).all()
    assert all(p.endswith(":floor") for p in floor["pair_id"])


def test_floor_pairs_are_scored_unchanged(tmp_path):
    root = _scene(tmp_path / "s")
    pairs_csv, metrics_csv = tmp_path / "pairs.csv", tmp_path / "metrics.csv"
    assert nvrq_main(["pairs", str(root), "--out", str(pairs_csv), "--floor", "--quiet"]) == 0
    assert nvrq_main(["score", str(pairs_csv), "--out", str(metrics_csv), "--metrics", "psnr", "--quiet"]) == 0
    pairs = pd.read_csv(pairs_csv, keep_default_na=False, na_values=[""])
    floor = pairs[pairs["method"] == "floor"]
    scores = pd.read_csv(metrics_csv).set_index("pair_id")["psnr"]
    assert len(floor) > 0 and floor["pair_id"].isin(scores.index).all()
    # each floor score is the PSNR of the GT crop against the other GT image's crop, resized to it
    for _, r in floor.iterrows():
        gt = np.asarray(Image.open(root / r["gt_path"]).convert("RGB"))[r.gt_y0:r.gt_y1 + 1, r.gt_x0:r.gt_x1 + 1]
        other = np.asarray(Image.open(root / r["render_path"]).convert("RGB"))[r.r_y0:r.r_y1 + 1, r.r_x0:r.r_x1 + 1]
        other = cv2.resize(other, (gt.shape[1], gt.shape[0]), interpolation=cv2.INTER_CUBIC)
        mse = np.mean((gt.astype(np.float64) - other.astype(np.float64)) ** 2)
        assert scores[r["pair_id"]] == pytest.approx(10 * math.log10(255.0**2 / mse), rel=1e-9)
        assert scores[r["pair_id"]] == pytest.approx(psnr(gt, other), rel=1e-12)


def test_a_view_closer_than_the_closest_approach_has_no_partner(tmp_path):
    # frame 6 passes the car at its closest (8 m, the car's x); 1.5 m toward it the distance is
    # 6.5 m (ratio ~0.81), while every other GT view of the drive is farther (ratio >= 1): no
    # floor row. Every floor row of the lateral views keeps to the tolerances.
    scene = load_scene(_scene(tmp_path / "s", forward=(), lateral=(1.5,)))
    pairs, _ = make_pairs(scene, progress=False)
    out, _ = add_floor(scene, pairs, min_side=30, min_area=0)
    t6 = 6 * DT_US
    moved = out[(out["y_offset_m"] == 1.5) & (out["timestamp_us"] == t6)]
    assert list(moved["method"]) == [""]  # the render's pair, no floor
    assert moved["view_ratio"].iloc[0] == pytest.approx(math.hypot(6.5, 0.7) / math.hypot(8.0, 0.7), abs=1e-9)
    floor = out[out["method"] == "floor"]
    assert (abs(np.log(floor["floor_ratio"] / floor["view_ratio"])) <= math.log(1.1)).all()


def test_one_frame_scene_is_refused(tmp_path, capsys):
    root = _scene(tmp_path / "s", frames=1)
    out = tmp_path / "pairs.csv"
    assert nvrq_main(["pairs", str(root), "--out", str(out), "--floor", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--floor" in err[0] and "images.csv" in err[0] and "1 GT image" in err[0], err
    assert not out.exists()


def test_floor_takes_one_scene_and_a_table(tmp_path, capsys):
    root = _scene(tmp_path / "s", frames=3)
    out = tmp_path / "dataset"
    assert nvrq_main(["pairs", str(root), str(root), "--out", str(out), "--floor", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--floor: expected one scene folder and a table --out" in err[0], err
    assert not out.exists()
