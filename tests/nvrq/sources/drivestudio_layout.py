"""Write a known scene out in drivestudio's processed-scene layout (tests and benchmark only).

What each variant writes follows drivestudio's preprocessors (``ziyc/drivestudio``,
``datasets/<d>/<d>_preprocess.py``), written here from their text, not from the importer:

- ``waymo``: ``extrinsics/{cam}.txt`` camera -> vehicle in Waymo camera axes (x forward, y
  left, z up; the loader multiplies by ``OPENCV2DATASET``), ``ego_pose/{t:03d}.txt``,
  9 intrinsics with distortion. ``emernerf``: the same without ``instances/``.
- ``argoverse``, ``nuplan``, ``kitti``: the same kind with OpenCV camera axes.
- ``nuscenes``: ``extrinsics/{t:03d}_{cam}.txt`` camera -> world with each camera fired
  ``lag_us[c]`` after the frame (its own ego pose), no ``ego_pose/``, zero distortion.
- ``pandaset``: per-frame camera -> world as nuScenes, plus ``ego_pose/`` = the lidar's pose
  (a mounting turned 90 deg, as PandaSet's lidar frame is not x forward), and boxes as
  PandaSet's: ``box_size = [dimensions.x, dimensions.y, dimensions.z] = [w, l, h]`` with the
  box's x across the object (pandaset-devkit README: ``dimensions.x`` is the width).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from nvrq.geometry.poses import interpolate_poses, pose7_to_matrix

#: drivestudio waymo_sourceloader.py OPENCV2DATASET (OpenCV camera axes -> Waymo camera axes).
OPENCV2WAYMO = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1]], float)
PER_FRAME = ("nuscenes", "pandaset")
#: What each dataset calls our classes (its own vocabulary, drivestudio's preprocessors).
SOURCE_CLASS = {
    "waymo": {"automobile": "Vehicle", "bus": "Vehicle", "heavy_truck": "Vehicle", "person": "Pedestrian",
              "rider": "Cyclist"},
    "nuscenes": {"automobile": "vehicle.car", "bus": "vehicle.bus.rigid", "heavy_truck": "vehicle.truck",
                 "person": "human.pedestrian.adult", "rider": "vehicle.bicycle"},
    "pandaset": {"automobile": "Car", "bus": "Bus", "heavy_truck": "Semi-truck", "person": "Pedestrian",
                 "rider": "Bicycle"},
    "argoverse": {"automobile": "REGULAR_VEHICLE", "bus": "BUS", "heavy_truck": "TRUCK", "person": "PEDESTRIAN",
                  "rider": "BICYCLIST"},
    "nuplan": {"automobile": "vehicle", "bus": "vehicle", "heavy_truck": "vehicle", "person": "pedestrian",
               "rider": "bicycle"},
    "kitti": {"automobile": "Car", "bus": "Truck", "heavy_truck": "Truck", "person": "Pedestrian",
              "rider": "Cyclist"},
}
#: Our class expected back after the import (the issue's table); a name not listed has no class
#: of ours and is kept as it is (nuScenes' ``vehicle.bicycle``, PandaSet's ``Bicycle``, nuPlan's
#: ``bicycle``).
EXPECTED_CLASS = {
    "waymo": {"Vehicle": "automobile", "Pedestrian": "person", "Cyclist": "rider"},
    "nuscenes": {"vehicle.car": "automobile", "vehicle.bus.rigid": "bus", "vehicle.truck": "heavy_truck",
                 "human.pedestrian.adult": "person"},
    "pandaset": {"Car": "automobile", "Bus": "bus", "Semi-truck": "heavy_truck", "Pedestrian": "person"},
    "argoverse": {"REGULAR_VEHICLE": "automobile", "BUS": "bus", "TRUCK": "heavy_truck", "PEDESTRIAN": "person",
                  "BICYCLIST": "rider"},
    "nuplan": {"vehicle": "automobile", "pedestrian": "person"},
    "kitti": {"Car": "automobile", "Truck": "heavy_truck", "Pedestrian": "person", "Cyclist": "rider"},
}


def rz(deg: float) -> np.ndarray:
    """A rotation of ``deg`` about z as a 4x4 transform."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)


@dataclass
class Layout:
    """What was written: ``T_cam_world (C, F, 4, 4)`` (OpenCV axes) at camera times
    ``frame_us[t] + lag_us[c]``, each camera's ``T_sensor_rig`` and ``model`` (OpenCV axes,
    the source rig), and the source track of each instance key."""

    root: Path
    dataset: str
    frame_us: np.ndarray
    lag_us: np.ndarray
    T_sensor_rig: list
    models: list
    T_cam_world: np.ndarray
    classes: dict


def camera_ring(T_front: np.ndarray, model: dict, n: int) -> tuple[list, list]:
    """``n`` cameras: ``T_front`` turned about the rig's z by 0, +50, -50, +90, -90, 180, +135, -135
    deg, all with ``model``."""
    yaws = [0, 50, -50, 90, -90, 180, 135, -135][:n]
    return [rz(y) @ T_front for y in yaws], [dict(model) for _ in yaws]


def _savetxt(path: Path, values) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, np.asarray(values, float))  # drivestudio writes every file this way


def _intrinsics(model: dict) -> list:
    fx, fy = model["focal_length"]
    cx, cy = model["principal_point"]
    k = model.get("radial_coeffs", [0.0] * 6)
    p = model.get("tangential_coeffs", [0.0, 0.0])
    return [fx, fy, cx, cy, k[0], k[1], p[0], p[1], k[2]]


def write_layout(root: Path, scene, dataset: str, *, T_sensor_rig: list, models: list, n_frames: int,
                 fps: float = 10.0, lag_us=None, instances: bool = True, image_bytes: bytes | None = None) -> Layout:
    """Write ``scene`` (a loaded source scene: rig trajectory and tracks) as a drivestudio folder.

    Frame ``t`` is at ``t * 1e6 / fps`` us of the source's clock (``n_frames`` frames, which must lie
    inside the rig trajectory, lags included); cameras ``T_sensor_rig`` / ``models`` (OpenCV axes).
    ``image_bytes``: the JPEG to write for every image (default: a grey image of the model's size).
    """
    root.mkdir(parents=True, exist_ok=True)
    per_frame = dataset in PER_FRAME
    C = len(models)
    lag = np.zeros(C, np.int64) if lag_us is None else np.asarray(lag_us, np.int64)
    frame_us = np.round(np.arange(n_frames) * 1e6 / fps).astype(np.int64)
    T_cw = np.zeros((C, n_frames, 4, 4))
    for c in range(C):
        T_rw, ok = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, frame_us + lag[c])
        assert ok.all(), "the layout's camera times must lie inside the source trajectory"
        T_cw[c] = T_rw @ T_sensor_rig[c]
    ego, _ = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, frame_us)
    blobs = {}
    for c, m in enumerate(models):
        W, H = m["resolution"]
        if image_bytes is None:
            ok, buf = cv2.imencode(".jpg", np.full((H, W, 3), 128, np.uint8))
            blobs[c] = buf.tobytes()
        else:
            blobs[c] = image_bytes
        _savetxt(root / "intrinsics" / f"{c}.txt", _intrinsics(m))
        if not per_frame:
            axes = np.linalg.inv(OPENCV2WAYMO) if dataset in ("waymo", "emernerf") else np.eye(4)
            _savetxt(root / "extrinsics" / f"{c}.txt", T_sensor_rig[c] @ axes)
    (root / "images").mkdir(parents=True, exist_ok=True)
    for t in range(n_frames):
        for c in range(C):
            (root / "images" / f"{t:03d}_{c}.jpg").write_bytes(blobs[c])
            if per_frame:
                _savetxt(root / "extrinsics" / f"{t:03d}_{c}.txt", T_cw[c, t])
        if not per_frame:
            _savetxt(root / "ego_pose" / f"{t:03d}.txt", ego[t])
        elif dataset == "pandaset":
            _savetxt(root / "ego_pose" / f"{t:03d}.txt", ego[t] @ rz(90))
    classes = {}
    if instances:
        ds = "waymo" if dataset == "emernerf" else dataset
        info, frame_instances = {}, {str(t): [] for t in range(n_frames)}
        for track in scene.tracks:
            hit = np.isin(track.timestamps_us, frame_us)
            if not hit.any():
                continue
            key = str(len(info))
            frames = np.searchsorted(frame_us, track.timestamps_us[hit])
            T_box = pose7_to_matrix(track.poses[hit])
            size = np.broadcast_to(track.dims_lwh, (len(frames), 3))
            if ds == "pandaset":  # the box's x across the object: [w, l, h]
                T_box, size = T_box @ rz(-90), size[:, [1, 0, 2]]
            name = SOURCE_CLASS[ds][track.label_class]
            info[key] = {"id": track.track_id, "class_name": name,
                         "frame_annotations": {"frame_idx": frames.tolist(), "obj_to_world": T_box.tolist(),
                                               "box_size": size.tolist()}}
            for f in frames:
                frame_instances[str(f)].append(int(key))
            classes[track.track_id] = EXPECTED_CLASS[ds].get(name, name)
        (root / "instances").mkdir(exist_ok=True)
        (root / "instances" / "instances_info.json").write_text(json.dumps(info, indent=1))
        (root / "instances" / "frame_instances.json").write_text(json.dumps(frame_instances, indent=1))
    return Layout(root, dataset, frame_us, lag, list(T_sensor_rig), list(models), T_cw, classes)
