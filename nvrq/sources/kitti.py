"""KITTI object benchmark frame -> scene folder (our check on real data).

One frame (``image_2/FRAME.png``, ``calib/FRAME.txt`` with ``P2``, ``label_2/FRAME.txt``)
becomes a one-frame scene: the rig sits at the rectified left colour camera, the world is
the rig (``T_rig_world = I`` at t = 0), and every labelled object (DontCare excluded)
becomes a one-sample track. The image is listed as the GT image and, so that
``nvrq pairs`` runs on it, as the render at offset 0.

Convention: KITTI labels give the *bottom* centre ``(x, y, z)`` of a box in the rectified
reference camera frame (x right, y down, z forward), dimensions ``h w l`` and
``rotation_y`` about the camera's y axis. ``P2 = K [I | t]`` with ``t = K^-1 P2[:, 3]``
(camera 2 sits ``-t`` from the reference camera). Centre in camera 2:
``(x, y - h/2, z) + t``; heading in the rig frame (x forward, y left, z up):
``yaw = -(rotation_y + pi/2)``, so ``rotation_y = 0`` (object along the camera x axis)
points the box's length to the rig's right (yaw = -90 deg).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

from data_schema.errors import InputError

__all__ = ["KITTI_CLASS_MAP", "read_calib_P2", "read_labels", "kitti_scene_doc", "import_kitti",
           "R_SENSOR_RIG"]

#: KITTI type -> our label_class (DontCare is dropped).
KITTI_CLASS_MAP = {
    "Car": "automobile", "Van": "automobile", "Truck": "heavy_truck", "Pedestrian": "person",
    "Person_sitting": "person", "Cyclist": "rider", "Tram": "tram", "Misc": "misc",
}
LABEL_COLUMNS = ["type", "truncated", "occluded", "alpha", "left", "top", "right", "bottom",
                 "h", "w", "l", "x", "y", "z", "rotation_y"]

#: Camera frame (x right, y down, z forward) -> rig frame (x forward, y left, z up).
R_SENSOR_RIG = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def read_calib_P2(path: str | os.PathLike) -> np.ndarray:
    """The 3x4 projection matrix ``P2`` of a KITTI calib file."""
    path = Path(path)
    if not path.is_file():
        raise InputError(path, None, "a KITTI calib file", "no such file")
    for line in path.read_text().splitlines():
        key, _, rest = line.partition(":")
        if key.strip() == "P2":
            try:
                vals = np.array([float(v) for v in rest.split()])
            except ValueError:
                raise InputError(path, "P2", "12 numbers", rest.strip()) from None
            if vals.size != 12:
                raise InputError(path, "P2", "12 numbers", f"{vals.size} numbers")
            return vals.reshape(3, 4)
    raise InputError(path, "P2", "a line 'P2: ...'", "missing")


def read_labels(path: str | os.PathLike) -> pd.DataFrame:
    """A KITTI ``label_2`` file as a table (columns :data:`LABEL_COLUMNS`)."""
    import pandas as pd  # here: the nvrq parser reads this module's class map

    path = Path(path)
    if not path.is_file():
        raise InputError(path, None, "a KITTI label file", "no such file")
    rows = []
    for i, line in enumerate(path.read_text().splitlines()):
        parts = line.split()
        if not parts:
            continue
        if len(parts) < 15:
            raise InputError(path, f"line {i + 1}", "15 fields", f"{len(parts)} fields")
        try:
            rows.append([parts[0]] + [float(v) for v in parts[1:15]])
        except ValueError:
            raise InputError(path, f"line {i + 1}", "numeric fields after the type", line) from None
    return pd.DataFrame(rows, columns=LABEL_COLUMNS)


def kitti_scene_doc(P2: np.ndarray, labels: pd.DataFrame, *, image_size: tuple[int, int], clip_id: str) -> dict:
    """The scene.json dict of one KITTI frame (see the module docstring for the frames)."""
    K = P2[:, :3]
    t = np.linalg.solve(K, P2[:, 3])  # reference camera -> camera 2 translation
    T_sensor_rig = np.eye(4)
    T_sensor_rig[:3, :3] = R_SENSOR_RIG
    W, H = image_size
    camera = {
        "T_sensor_rig": T_sensor_rig,
        "model": {"type": "pinhole", "resolution": [int(W), int(H)],
                  "focal_length": [float(K[0, 0]), float(K[1, 1])],
                  "principal_point": [float(K[0, 2]), float(K[1, 2])]},
    }
    objs = labels[labels["type"] != "DontCare"].reset_index(drop=True)
    centre_cam = objs[["x", "y", "z"]].to_numpy(float) + t
    centre_cam[:, 1] -= objs["h"].to_numpy(float) / 2
    centre_rig = centre_cam @ R_SENSOR_RIG.T
    yaw = -(objs["rotation_y"].to_numpy(float) + np.pi / 2)
    tracks = []
    for i, o in objs.iterrows():
        q = [0.0, 0.0, float(np.sin(yaw[i] / 2)), float(np.cos(yaw[i] / 2))]
        tracks.append({
            "track_id": f"{i:03d}-{o['type'].lower()}",
            "label_class": KITTI_CLASS_MAP.get(o["type"], o["type"].lower()),
            "dims_lwh": [float(o["l"]), float(o["w"]), float(o["h"])],
            "timestamps_us": [0],
            "poses": [centre_rig[i].tolist() + q],
        })
    return {
        "clip_id": clip_id,
        "attributes": {"lighting": "daytime", "road_type": "kitti"},
        "cameras": {"image_2": camera},
        "rig_trajectory": {"timestamps_us": [0], "T_rig_world": [np.eye(4)]},
        "tracks": tracks,
    }


def import_kitti(kitti_root: str | os.PathLike, frame: str, out: str | os.PathLike) -> Path:
    """Write the scene folder ``out`` for KITTI frame ``frame`` (e.g. ``'000000'``) of ``kitti_root``."""
    import cv2
    import pandas as pd

    from data_schema.scene import save_scene

    root, out = Path(kitti_root), Path(out)
    image = root / "image_2" / f"{frame}.png"
    if not image.is_file():
        raise InputError(image, None, "a KITTI image_2 PNG", "no such file")
    img = cv2.imread(str(image), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError(image, None, "a readable PNG image", "undecodable file")
    H, W = img.shape[:2]
    doc = kitti_scene_doc(read_calib_P2(root / "calib" / f"{frame}.txt"),
                          read_labels(root / "label_2" / f"{frame}.txt"),
                          image_size=(W, H), clip_id=f"kitti-{frame}")
    (out / "images").mkdir(parents=True, exist_ok=True)
    rel = f"images/{frame}.png"
    shutil.copyfile(image, out / rel)
    images = pd.DataFrame({"camera": ["image_2"] * 2, "timestamp_us": [0, 0], "source": ["gt", "render"],
                           "y_offset_m": [0.0, 0.0], "path": [rel, rel]})
    return save_scene(doc, images, out)
