"""``nvrq import drivestudio``: a synthetic scene written in every drivestudio variant imports
back with its camera poses (to 1e-9), its boxes (within 1 px), its track ids and mapped classes.

The layouts are written by tests/nvrq/sources/drivestudio_layout.py from the preprocessors' text; the
expected camera matrices are recomputed here from the written files as drivestudio's loaders
compose them (``ego_pose @ extrinsics @ OPENCV2DATASET`` or the per-frame file), and the
expected boxes come from the source scene through ``nvrq.project_boxes`` at the source's own
camera poses, independently of the importer.
"""

from __future__ import annotations

import json
import shutil

import cv2
import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from data_schema.scene import load_scene, save_scene
from nvrq.cli import main
from nvrq.geometry.poses import interpolate_poses, pose7_to_matrix
from nvrq.pairs import make_pairs, project_boxes, track_boxes_at
from nvrq.sources.drivestudio import import_drivestudio, read_drivestudio
from nvrq.synth.generate import camera_models, scene_document
from nvrq.synth.layout import build_world
from tests.nvrq.sources.drivestudio_layout import OPENCV2WAYMO, camera_ring, write_layout

SIZE = (320, 180)
N_FRAMES = 6
MIN_SIDE = 8
#: variant -> (cameras, frame rate the layout is written at, per-camera lag in us)
VARIANTS = {
    "waymo": (5, 10.0, None),
    "emernerf": (5, 10.0, None),
    "argoverse": (7, 10.0, None),
    "nuplan": (8, 10.0, None),
    "kitti": (2, 10.0, None),
    "nuscenes": (6, 2.0, [0, 8_000, 17_000, 25_000, 33_000, 42_000]),  # cameras fire over ~45 ms
    "pandaset": (6, 10.0, [0, 5_000, 9_000, 14_000, 18_000, 23_000]),
}


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    """A synthetic clip (seed 0, 4 s at 10 Hz): rig trajectory and tracks, no images."""
    ts = np.round(np.arange(40) * 1e5).astype(np.int64)
    world = build_world(np.random.default_rng([0, 1]), timestamps_us=ts)
    cams = camera_models(SIZE)
    doc = scene_document(world, {"front": cams["front"]}, "src")
    root = tmp_path_factory.mktemp("src")
    save_scene(doc, pd.DataFrame({"camera": ["front"], "timestamp_us": [0], "source": ["gt"], "y_offset_m": [0.0],
                                  "path": ["x.png"]}), root)
    return load_scene(root, check_images=False), cams["front"]


def _layout(tmp_path, source, variant, **kw):
    scene, front = source
    n_cams, fps, lag = VARIANTS[variant]
    model = dict(front["model"])
    if variant in ("nuscenes", "pandaset", "argoverse", "kitti"):  # these preprocessors write zero distortion
        model = {"type": "pinhole", **{k: model[k] for k in ("resolution", "focal_length", "principal_point")}}
    T_sr, models = camera_ring(np.asarray(front["T_sensor_rig"]), model, n_cams)
    return write_layout(tmp_path / f"{variant}_scene", scene, variant, T_sensor_rig=T_sr, models=models,
                        n_frames=N_FRAMES, fps=fps, lag_us=lag, **kw)


def _drivestudio_cam_to_world(layout) -> np.ndarray:
    """The layout's camera -> world matrices ``(C, F, 4, 4)`` as drivestudio's loaders compose
    them from the files (waymo_sourceloader.py, nuscenes_sourceloader.py), without the re-basing."""
    root, C, F = layout.root, len(layout.models), len(layout.frame_us)
    out = np.zeros((C, F, 4, 4))
    for c in range(C):
        for t in range(F):
            if layout.dataset in ("nuscenes", "pandaset"):
                out[c, t] = np.loadtxt(root / "extrinsics" / f"{t:03d}_{c}.txt")
            else:
                axes = OPENCV2WAYMO if layout.dataset in ("waymo", "emernerf") else np.eye(4)
                out[c, t] = np.loadtxt(root / "ego_pose" / f"{t:03d}.txt") @ (
                    np.loadtxt(root / "extrinsics" / f"{c}.txt") @ axes)
    return out


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_every_camera_pose_is_reproduced_to_1e9(tmp_path, source, variant):
    layout = _layout(tmp_path, source, variant)
    scene = load_scene(import_drivestudio(layout.root, tmp_path / "out", offsets=[0.0]), check_images=False)
    expected = _drivestudio_cam_to_world(layout)
    gt = scene.images[scene.images.source == "gt"]
    assert len(gt) == expected.shape[0] * expected.shape[1]
    for c, name in enumerate(scene.cameras):
        ts = np.sort(gt.loc[gt.camera == name, "timestamp_us"].to_numpy(np.int64))
        T_rw, ok = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, ts)
        assert ok.all()
        got = T_rw @ scene.cameras[name].T_sensor_rig
        assert np.abs(got - expected[c]).max() < 1e-9, (variant, name)
        # the rig stays x forward, y left, z up: its z axis is the world's up within a few degrees
        assert (T_rw[:, 2, 2] > np.cos(np.radians(5))).all()
    # drivestudio's re-based world: inv(ego_pose/000.txt) @ world, nuScenes inv(extrinsics/000_0.txt)
    first = layout.root / ("extrinsics/000_0.txt" if variant == "nuscenes" else "ego_pose/000.txt")
    np.testing.assert_allclose(scene.source_world.T_world_source @ np.loadtxt(first), np.eye(4), atol=1e-9)
    assert scene.source_world.name == "drivestudio"


def _expected_boxes(source_scene, layout, offsets) -> dict:
    """(camera index, frame, track_id, offset) -> (gt box, render box) from the source scene."""
    out = {}
    for c, (T_sr, model) in enumerate(zip(layout.T_sensor_rig, layout.models, strict=True)):
        for t, t_us in enumerate(layout.frame_us):
            T_rw, _ = interpolate_poses(source_scene.rig_timestamps_us, source_scene.T_rig_world,
                                        np.array([t_us + layout.lag_us[c]]))
            tr, _, T_box = track_boxes_at(source_scene, np.array([t_us]))
            if not len(tr):
                continue
            dims = np.stack([source_scene.tracks[k].dims_lwh for k in tr])
            res = project_boxes(model, T_sensor_rig=T_sr, T_rig_world=T_rw[0], T_box_world=T_box, dims_lwh=dims,
                                offsets=offsets, min_side=MIN_SIDE)
            for r in res[res.kept].itertuples():
                out[c, t, source_scene.tracks[tr[r.box]].track_id, offsets[r.view]] = (
                    (r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1), (r.r_x0, r.r_y0, r.r_x1, r.r_y1))
    return out


@pytest.mark.parametrize("variant", [v for v in VARIANTS if v != "emernerf"])
def test_boxes_ids_and_classes_come_back(tmp_path, source, variant):
    layout = _layout(tmp_path, source, variant)
    offsets = [0.0, 1.0]
    scene = load_scene(import_drivestudio(layout.root, tmp_path / "out", offsets=offsets), check_images=False)
    pairs, _ = make_pairs(scene, min_side=MIN_SIDE, progress=False)
    expected = _expected_boxes(source[0], layout, offsets)
    names = list(scene.cameras)
    got = {}
    for r in pairs.itertuples():
        c = names.index(r.camera)
        t = int(np.searchsorted(layout.frame_us, r.timestamp_us, side="right") - 1)  # frame time + c us
        got[c, t, r.track_id, r.y_offset_m] = ((r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1), (r.r_x0, r.r_y0, r.r_x1, r.r_y1))
    assert len(expected) >= 20, len(expected)  # the check has boxes in several cameras
    assert len({k[0] for k in expected}) >= 2
    assert set(got) == set(expected)
    for k, boxes in got.items():  # GT box and render box, pixels
        assert np.abs(np.subtract(boxes, expected[k])).max() <= 1, (k, boxes, expected[k])
    # the source's own track ids, and each dataset's class names mapped (tests/nvrq/sources/drivestudio_layout.py)
    assert {t.track_id: t.label_class for t in scene.tracks} == layout.classes
    # the boxes themselves: x along the length (PandaSet's boxes turned back), [l, w, h] as the source's
    src = {t.track_id: t for t in source[0].tracks}
    for tr in scene.tracks:
        s = src[tr.track_id]
        np.testing.assert_allclose(tr.dims_lwh, s.dims_lwh, atol=1e-9)
        at = tr.timestamps_us[np.isin(tr.timestamps_us, s.timestamps_us)]
        mine, _ = interpolate_poses(tr.timestamps_us, pose7_to_matrix(tr.poses), at)
        theirs, _ = interpolate_poses(s.timestamps_us, pose7_to_matrix(s.poses), at)
        assert len(at) and np.abs(mine - theirs).max() < 1e-9
    assert scene.source_world is not None and scene.source_world.dataset == variant


def test_emernerf_folder_without_instances_imports_without_tracks(tmp_path, source, capsys):
    layout = _layout(tmp_path, source, "emernerf", instances=False)
    assert main(["import", "drivestudio", str(layout.root), str(tmp_path / "out"), "--offsets", "0"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert any("no instances/ folder" in line for line in err), err
    scene = load_scene(tmp_path / "out", check_images=False)
    assert scene.tracks == [] and len(scene.cameras) == 5


def _break(root, case):
    """Damage a fresh layout in one way; returns the file the error must name."""
    def edit_json(name, change):
        path = root / "instances" / name
        doc = json.loads(path.read_text())
        change(doc)
        path.write_text(json.dumps(doc))
        return path

    if case == "missing intrinsics":
        (root / "intrinsics" / "2.txt").unlink()
        return root / "intrinsics" / "2.txt"
    if case.startswith("not rigid") and case != "not rigid box":
        name = {"not rigid extrinsics": "extrinsics/1.txt", "not rigid ego_pose": "ego_pose/001.txt",
                "not rigid per-frame": "extrinsics/002_1.txt"}[case]
        M = np.loadtxt(root / name)
        M[:3, :3] *= 1.01  # a scale, not a rotation
        np.savetxt(root / name, M)
        return root / name
    if case == "not rigid box":
        def shear(doc):
            doc["1"]["frame_annotations"]["obj_to_world"][0][0][1] += 0.2
        return edit_json("instances_info.json", shear)
    if case == "unknown object":
        return edit_json("frame_instances.json", lambda doc: doc["2"].append(99))
    if case == "missing image":
        (root / "images" / "001_3.jpg").unlink()
        return root / "images" / "001_3.jpg"
    if case == "missing ego pose":
        (root / "ego_pose" / "002.txt").unlink()
        return root / "ego_pose" / "002.txt"
    if case == "missing per-frame extrinsics":
        (root / "extrinsics" / "001_4.txt").unlink()
        return root / "extrinsics" / "001_4.txt"
    if case == "image size":
        ok, buf = cv2.imencode(".jpg", np.zeros((90, 160, 3), np.uint8))
        (root / "images" / "002_3.jpg").write_bytes(buf.tobytes())
        return root / "images" / "002_3.jpg"
    if case.startswith("box_size"):
        bad = {"box_size negative": [4.0, -1.0, 1.5], "box_size two numbers": [4.0, 1.5],
               "box_size text": ["4", 1.9, 1.6]}[case]

        def set_size(doc):
            doc["0"]["frame_annotations"]["box_size"][0] = bad
        return edit_json("instances_info.json", set_size)
    raise AssertionError(case)


BAD_CASES = {  # case -> layout variant
    "missing intrinsics": "waymo", "not rigid extrinsics": "waymo", "not rigid ego_pose": "waymo",
    "not rigid per-frame": "nuscenes", "not rigid box": "waymo", "unknown object": "waymo",
    "missing image": "waymo", "missing ego pose": "waymo", "missing per-frame extrinsics": "nuscenes",
    "image size": "waymo", "box_size negative": "waymo", "box_size two numbers": "pandaset",
    "box_size text": "waymo",
}


@pytest.mark.parametrize("case", list(BAD_CASES))
def test_bad_layout_is_one_line_exit_2_and_nothing_written(tmp_path, source, capsys, case):
    layout = _layout(tmp_path, source, BAD_CASES[case])
    named = _break(layout.root, case)
    before = sorted(p.name for p in tmp_path.iterdir())
    out = tmp_path / "out" / "scene"
    rc = main(["import", "drivestudio", str(layout.root), str(out), "--offsets", "0,1"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert err[0].startswith(f"error: {named}"), (case, err[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # not even OUT's parent


def test_ambiguous_folder_asks_for_the_dataset_and_dataset_overrides(tmp_path, source, capsys):
    layout = _layout(tmp_path, source, "waymo")
    for c in (3, 4):  # 3 cameras: no per-camera dataset has that many
        for p in [*layout.root.glob(f"images/*_{c}.jpg"), layout.root / "intrinsics" / f"{c}.txt",
                  layout.root / "extrinsics" / f"{c}.txt"]:
            p.unlink()
    assert main(["import", "drivestudio", str(layout.root), str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--dataset" in err[0], err
    assert not (tmp_path / "out").exists()
    assert main(["import", "drivestudio", str(layout.root), str(tmp_path / "out"), "--dataset", "waymo",
                 "--offsets", "0", "--cameras", "front_camera,2"]) == 0
    scene = load_scene(tmp_path / "out", check_images=False)
    assert list(scene.cameras) == ["front_camera", "front_right_camera"]
    # the GT images are links to the layout's files, never moved (--copy copies them)
    gt = tmp_path / "out" / scene.images[scene.images.source == "gt"].path.iloc[0]
    assert gt.is_symlink() and gt.resolve() == (layout.root / "images" / "000_0.jpg").resolve()
    assert (layout.root / "images" / "000_0.jpg").is_file()


def test_copy_time_rule_and_source_world(tmp_path, source):
    layout = _layout(tmp_path, source, "nuscenes")
    # drivestudio's 10 Hz nuScenes folders are named processed_10Hz (nuscenes_preprocess.py)
    hz = tmp_path / "processed_10Hz" / "mini" / "000"
    hz.parent.mkdir(parents=True)
    shutil.copytree(layout.root, hz)
    ds = read_drivestudio(hz)
    assert ds.dataset == "nuscenes" and ds.fps == 10.0
    assert read_drivestudio(layout.root).fps == 2.0  # keyframes
    assert read_drivestudio(hz, fps=4).fps == 4.0
    # frame t at t / fps; camera c's images at frame time + c us
    np.testing.assert_array_equal(ds.image_us[:, 2], 200_000 + np.arange(6))
    scene = load_scene(import_drivestudio(hz, tmp_path / "out", offsets=[0.0], copy=True), check_images=False)
    gt = tmp_path / "out" / scene.images[scene.images.source == "gt"].path.iloc[0]
    assert gt.is_file() and not gt.is_symlink()
    # nuScenes: drivestudio's world is inv(extrinsics/000_0.txt) @ world (nuscenes_sourceloader.py)
    X0 = np.loadtxt(hz / "extrinsics" / "000_0.txt")
    np.testing.assert_allclose(scene.source_world.T_world_source @ X0, np.eye(4), atol=1e-9)
    with pytest.raises(InputError, match="cameras: expected at least one camera"):
        read_drivestudio(hz, cameras=[])
    with pytest.raises(InputError, match=r"cameras: expected distinct cameras .*0=CAM_FRONT"):
        read_drivestudio(hz, cameras=["CAM_MIDDLE"])
    with pytest.raises(InputError, match="per-camera extrinsics.* for waymo, got per-frame files"):
        read_drivestudio(hz, dataset="waymo")  # per-frame files are not Waymo's kind


def test_source_world_key_is_validated(tmp_path, source):
    layout = _layout(tmp_path, source, "kitti")
    out = import_drivestudio(layout.root, tmp_path / "out", offsets=[0.0])
    doc = json.loads((out / "scene.json").read_text())
    doc["source_world"]["T_world_source"][0][0] = 2.0  # not a rotation
    (out / "scene.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="source_world.T_world_source"):
        load_scene(out, check_images=False)
    del doc["source_world"]  # optional: a scene without it loads as before
    (out / "scene.json").write_text(json.dumps(doc))
    assert load_scene(out, check_images=False).source_world is None
