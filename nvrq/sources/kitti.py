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
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

from data_schema.errors import InputError
from data_schema.images import check_image

if TYPE_CHECKING:  # imported where used: drivestudio_meta (read by the nvrq parser) imports this module
    from data_schema.scene_writer import NewScene
    from nvrq.sources.base import ImportedScene

__all__ = ["KITTI_CLASS_MAP", "read_calib_P2", "read_labels", "kitti_scene", "read_kitti",
           "import_kitti", "KittiImporter", "IMPORTER", "R_SENSOR_RIG"]

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
    """The 3x4 projection matrix ``P2`` of a KITTI calib file.

    Parameters
    ----------
    path : str or os.PathLike
        A ``calib/<frame>.txt`` file (lines ``P0: ...`` to ``Tr_imu_to_velo: ...``).

    Returns
    -------
    (3, 4) float numpy.ndarray
        ``P2``, the left colour camera's projection (pixels from rectified camera-0 metres).
    """
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
    """A KITTI ``label_2`` file as a table (columns :data:`LABEL_COLUMNS`).

    Parameters
    ----------
    path : str or os.PathLike
        The KITTI label file.

    Returns
    -------
    pandas.DataFrame
        One row per label line: ``type`` and the 14 numeric fields of :data:`LABEL_COLUMNS`.
    """
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


def kitti_scene(P2: np.ndarray, labels: pd.DataFrame, *, image_size: tuple[int, int], clip_id: str,
                image: str | os.PathLike | None = None, frame: str = "000000") -> NewScene:
    """The typed scene of one KITTI frame (see the module docstring for the frames).

    Parameters
    ----------
    P2 : numpy.ndarray, (3, 4)
        The projection matrix of the rectified left colour camera.
    labels : pandas.DataFrame
        The frame's ``label_2`` rows (:func:`read_labels`); DontCare rows are dropped.
    image_size : tuple of int
        ``(W, H)`` pixels.
    clip_id : str
        The scene's clip id.
    image : path, optional
        The ``image_2`` PNG, copied into the scene at ``images/FRAME.png``.
    frame : str
        The frame id (the image's name in the scene).

    Returns
    -------
    NewScene
        One camera ``image_2``, the rig at it (``T_rig_world = I`` at t = 0), one one-sample track
        per object and the one GT frame.
    """
    from data_schema.scene import CameraCalib, Track
    from data_schema.scene_writer import NewScene, SceneFrame

    K = P2[:, :3]
    t = np.linalg.solve(K, P2[:, 3])  # reference camera -> camera 2 translation
    T_sensor_rig = np.eye(4)
    T_sensor_rig[:3, :3] = R_SENSOR_RIG
    W, H = image_size
    model = {"type": "pinhole", "resolution": [int(W), int(H)], "focal_length": [float(K[0, 0]), float(K[1, 1])],
             "principal_point": [float(K[0, 2]), float(K[1, 2])]}
    objs = labels[labels["type"] != "DontCare"].reset_index(drop=True)
    centre_cam = objs[["x", "y", "z"]].to_numpy(float) + t
    centre_cam[:, 1] -= objs["h"].to_numpy(float) / 2
    centre_rig = centre_cam @ R_SENSOR_RIG.T
    yaw = -(objs["rotation_y"].to_numpy(float) + np.pi / 2)
    tracks = []
    for i, o in objs.iterrows():
        q = [0.0, 0.0, float(np.sin(yaw[i] / 2)), float(np.cos(yaw[i] / 2))]
        tracks.append(Track(f"{i:03d}-{o['type'].lower()}", KITTI_CLASS_MAP.get(o["type"], o["type"].lower()),
                            np.array([o["l"], o["w"], o["h"]], float), np.zeros(1, np.int64),
                            np.array([centre_rig[i].tolist() + q]),
                            (f"occluded={int(o['occluded'])} truncated={float(o['truncated']):.2f}",)))
    frame_image = SceneFrame("image_2", 0, f"images/{frame}.png", None if image is None else Path(image))
    return NewScene(clip_id, {"image_2": CameraCalib("image_2", T_sensor_rig, model)}, np.zeros(1, np.int64),
                    np.eye(4)[None], tracks, [frame_image], {"lighting": "daytime", "road_type": "kitti"})


class KittiImporter:
    """``nvrq import kitti KITTI_ROOT FRAME OUT`` (:class:`nvrq.sources.base.Importer`)."""

    def read(self, path, *, frame: str) -> ImportedScene:
        """Read the frame ``frame`` of the KITTI object folder ``path`` (:func:`read_kitti`).

        Parameters
        ----------
        path : path
            The KITTI object folder.
        frame : str
            The frame id.

        Returns
        -------
        ImportedScene
            The scene, its image listed as the GT image and as the render at offset 0.
        """
        return read_kitti(path, frame)


#: The importer of ``nvrq import kitti``.
IMPORTER = KittiImporter()


def read_kitti(kitti_root: str | os.PathLike, frame: str) -> ImportedScene:
    """Read and check KITTI frame ``frame`` (e.g. ``'000000'``) of ``kitti_root``; nothing written.

    Parameters
    ----------
    kitti_root : path
        The KITTI object folder (``image_2/``, ``label_2/``, ``calib/``).
    frame : str
        The frame id.

    Returns
    -------
    ImportedScene
        The scene; one view (offset 0) whose render is the GT image itself, so that
        ``nvrq pairs`` runs on it.
    """
    import cv2

    from nvrq.sources.base import ImportedScene

    root = Path(kitti_root)
    image = root / "image_2" / f"{frame}.png"
    if not image.is_file():
        raise InputError(image, None, "a KITTI image_2 PNG", "no such file")
    check_image(image)  # the header before any decode (a decompression bomb, a file cut short)
    img = cv2.imread(str(image), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError(image, None, "a readable PNG image", "undecodable file")
    H, W = img.shape[:2]
    scene = kitti_scene(read_calib_P2(root / "calib" / f"{frame}.txt"), read_labels(root / "label_2" / f"{frame}.txt"),
                        image_size=(W, H), clip_id=f"kitti-{frame}", image=image, frame=frame)
    rel = scene.frames[0].path
    return ImportedScene(scene, np.zeros((1, 6)), render_path=lambda camera, t, view: rel)


def import_kitti(kitti_root: str | os.PathLike, frame: str, out: str | os.PathLike) -> Path:
    """Write the scene folder ``out`` for KITTI frame ``frame`` of ``kitti_root`` (whole and
    atomically: :func:`nvrq.sources.base.write_imported`).

    Parameters
    ----------
    kitti_root : path
        The KITTI object folder.
    frame : str
        The frame id, e.g. ``'000000'``.
    out : path
        The scene folder.

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    from nvrq.sources.base import write_imported

    return write_imported(read_kitti(kitti_root, frame), out)
