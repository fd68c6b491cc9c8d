"""Import a drivestudio processed scene folder as a scene folder (docs/FORMATS.md §13).

drivestudio (``ziyc/drivestudio``; OmniRe, and EmerNeRF's folders) preprocesses Waymo, nuScenes,
PandaSet, Argoverse 2, nuPlan and KITTI-raw into one layout. Its conventions, each with the
drivestudio file that states it (``datasets/<d>/<d>_preprocess.py`` writes the layout,
``datasets/<d>/<d>_sourceloader.py`` reads it):

``images/{t:03d}_{cam}.jpg``
    Frame ``t`` (0, 1, ...), camera index ``cam`` (``save_image`` of every preprocess;
    ``CameraData.create_all_filelist`` in ``datasets/base/pixel_source.py``). Camera names by
    index: ``DATASETS_CONFIG`` of ``datasets/dataset_meta.py`` (:data:`CAMERA_NAMES`).
``intrinsics/{cam}.txt``
    9 numbers ``fx fy cx cy k1 k2 p1 p2 k3`` in pixels (``save_calib``; ``load_calibrations``
    reads them in this order). Copied unchanged; all-zero distortion (nuScenes, PandaSet,
    Argoverse 2, KITTI write zeros) gives a ``pinhole`` camera, else ``opencv_pinhole``
    (Waymo, nuPlan). The size comes from the images.
``extrinsics/{cam}.txt`` + ``ego_pose/{t:03d}.txt`` (Waymo, Argoverse 2, nuPlan, KITTI-raw)
    camera -> ego (one per camera) and ego -> world (one per frame), 4x4 text, metres.
    Waymo's extrinsics use Waymo camera axes (x forward, y left, z up): the loader multiplies
    them by ``OPENCV2DATASET`` (``waymo_sourceloader.py``), which is :data:`OPENCV_TO_FLU`;
    every other dataset's ``OPENCV2DATASET`` is the identity (OpenCV axes, x right, y down,
    z forward). The ego frames are x forward, y left, z up (Waymo's vehicle frame, AV2's ego,
    nuPlan's ego; KITTI: the Velodyne frame, ``kitti_preprocess.py`` ``save_pose``).
``extrinsics/{t:03d}_{cam}.txt`` (nuScenes, PandaSet)
    camera -> world per frame, OpenCV axes. nuScenes composes each camera's own ego pose at its
    own timestamp (``nuscenes_preprocess.py`` ``save_calib``: the cameras of a frame fired at
    different times); it writes no ``ego_pose/``. PandaSet writes the camera poses and, as
    ``ego_pose/``, the lidar poses (``pandaset_preprocess.py`` ``save_pose``).
``instances/instances_info.json``, ``instances/frame_instances.json``
    ``{key: {id, class_name, frame_annotations: {frame_idx, obj_to_world, box_size}}}``:
    ``obj_to_world`` the box centre pose (box -> world, 4x4), ``box_size`` the extents
    ``[l, w, h]`` along the box's own x, y, z. ``frame_instances`` lists the keys of each
    frame's objects; the loader keeps an annotation only where its frame lists the object, and
    gives each object the mean ``box_size`` of those frames (``load_objects``). PandaSet writes
    ``[dimensions.x, dimensions.y, dimensions.z]`` with a yaw-only ``obj_to_world``, where
    ``dimensions.x`` is the width and ``dimensions.y`` the length (pandaset-devkit README), so
    the box's own x is across the object: the importer turns PandaSet boxes by +90 deg about
    their z (``T_box = obj_to_world @ Rz(90)``, ``dims = [y, x, z]``), which leaves the 8
    corners where they are and makes x the length. No ``instances/`` (EmerNeRF's folders):
    no tracks.
Re-based world (``source_world``)
    drivestudio trains in ``inv(ego_pose/000.txt) @ world`` (Waymo, PandaSet, Argoverse 2,
    nuPlan, KITTI; ``load_calibrations``), nuScenes in ``inv(extrinsics/000_0.txt) @ world``
    (the first front camera's frame, OpenCV axes); no axis change is applied on the world side.
    The importer keeps the layout's world and records that matrix as
    ``source_world.T_world_source`` (start_timestep 0, the whole scene).

Our scene (docs/FORMATS.md §13): frame ``t`` is at ``round(t * 1e6 / fps)`` us (the layout
saves no timestamps; :data:`DEFAULT_FPS`, nuScenes the ``_NHz`` folder suffix of
``nuscenes_preprocess.py``). Per-camera layouts: the rig is the ego, ``T_sensor_rig =
extrinsic @ OPENCV2DATASET``. Per-frame layouts: camera ``c``'s images are at frame time + ``c``
us; the rig is camera 0 at frame 0 turned to x forward, y left, z up (``T_rig_world = X[0, 0]
@ inv(T_0)``, ``T_0`` the rotation :data:`OPENCV_TO_FLU`), ``T_sensor_rig[c] = inv(T_rig_world)
@ X[0, c]``, and the rig has one sample per image, ``X[t, c] @ inv(T_sensor_rig[c])``, so that
``T_rig_world(t_image) @ T_sensor_rig`` is every layout matrix ``X[t, c]`` (to rounding) while
boxes move by under 1e-4 of a frame's motion. A track's last sample is repeated at the largest
camera offset so that every camera's image of its last frame shows it.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image, UnidentifiedImageError

from data_schema.errors import InputError, check_number
from data_schema.perturbation import PERTURBATION_COLUMNS, extra_columns, views_from
from data_schema.scene import check_rigid, save_scene
from data_schema.tables import IMAGES_COLUMNS, atomic_folder
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.poses import matrix_to_pose7
from nvrq.render_plan import default_image_path
from nvrq.sources.kitti import KITTI_CLASS_MAP, R_SENSOR_RIG

__all__ = ["DATASETS", "CAMERA_NAMES", "DEFAULT_FPS", "CLASS_MAPS", "OPENCV_TO_FLU", "DrivestudioScene",
           "map_class", "read_drivestudio", "import_drivestudio"]

#: drivestudio's dataset folder names (``--dataset``).
DATASETS = ("waymo", "nuscenes", "pandaset", "argoverse", "nuplan", "kitti")
#: Datasets with per-frame camera -> world extrinsics ``extrinsics/{t:03d}_{cam}.txt``.
PER_FRAME = ("nuscenes", "pandaset")
#: Camera names by index (drivestudio ``datasets/dataset_meta.py``).
CAMERA_NAMES = {
    "waymo": ("front_camera", "front_left_camera", "front_right_camera", "left_camera", "right_camera"),
    "nuscenes": ("CAM_FRONT", "CAM_FRONT_LEFT", "CAM_FRONT_RIGHT", "CAM_BACK_LEFT", "CAM_BACK_RIGHT", "CAM_BACK"),
    "pandaset": ("front_camera", "front_left_camera", "front_right_camera", "left_camera", "right_camera",
                 "back_camera"),
    "argoverse": ("ring_front_center", "ring_front_left", "ring_front_right", "ring_side_left", "ring_side_right",
                  "ring_rear_left", "ring_rear_right"),
    "nuplan": ("CAM_F0", "CAM_L0", "CAM_R0", "CAM_L1", "CAM_R1", "CAM_L2", "CAM_R2", "CAM_B0"),
    "kitti": ("CAM_LEFT", "CAM_RIGHT"),
}
#: Frame rate of each dataset's processed frames (Hz); nuScenes: its 2 Hz keyframes.
DEFAULT_FPS = {"waymo": 10.0, "nuscenes": 2.0, "pandaset": 10.0, "argoverse": 10.0, "nuplan": 10.0, "kitti": 10.0}
#: OpenCV camera axes (x right, y down, z forward) -> x forward, y left, z up: Waymo's
#: ``OPENCV2DATASET`` rotation, the same matrix as the KITTI importer's camera -> rig rotation.
OPENCV_TO_FLU = R_SENSOR_RIG
#: ``class_name`` -> our ``label_class`` per dataset (docs/FORMATS.md §13); any other name is
#: kept; nuScenes ``human.pedestrian.*`` -> ``person`` (:func:`map_class`).
CLASS_MAPS = {
    "waymo": {"Vehicle": "automobile", "Pedestrian": "person", "Cyclist": "rider"},
    "nuscenes": {"vehicle.car": "automobile", "vehicle.emergency.police": "automobile",
                 "vehicle.bus.bendy": "bus", "vehicle.bus.rigid": "bus",
                 "vehicle.truck": "heavy_truck", "vehicle.trailer": "heavy_truck"},
    "pandaset": {"Car": "automobile", "Pickup Truck": "automobile", "Bus": "bus",
                 "Medium-sized Truck": "heavy_truck", "Semi-truck": "heavy_truck",
                 "Pedestrian": "person", "Pedestrian with Object": "person"},
    "argoverse": {"REGULAR_VEHICLE": "automobile", "BUS": "bus", "ARTICULATED_BUS": "bus", "SCHOOL_BUS": "bus",
                  "BOX_TRUCK": "heavy_truck", "TRUCK": "heavy_truck", "TRUCK_CAB": "heavy_truck",
                  "VEHICULAR_TRAILER": "heavy_truck", "PEDESTRIAN": "person", "OFFICIAL_SIGNALER": "person",
                  "BICYCLIST": "rider", "MOTORCYCLIST": "rider", "WHEELED_RIDER": "rider"},
    "nuplan": {"vehicle": "automobile", "pedestrian": "person"},
    "kitti": dict(KITTI_CLASS_MAP),  # the one KITTI table (``nvrq import kitti``)
}
_RZ90 = np.array([[0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
_IMAGE = re.compile(r"^(\d+)_(\d+)\.jpg$")
_PER_CAMERA_FILE = re.compile(r"^(\d+)\.txt$")
_PER_FRAME_FILE = re.compile(r"^(\d+)_(\d+)\.txt$")
_HZ = re.compile(r"_(\d+(?:\.\d+)?)Hz$")


def map_class(dataset: str, class_name: str) -> str:
    """Our ``label_class`` of a drivestudio ``class_name`` (:data:`CLASS_MAPS`; others kept).

    >>> map_class("nuscenes", "human.pedestrian.adult"), map_class("waymo", "Cyclist"), map_class("waymo", "Sign")
    ('person', 'rider', 'Sign')
    """
    if dataset == "nuscenes" and class_name.startswith("human.pedestrian."):
        return "person"
    return CLASS_MAPS.get(dataset, {}).get(class_name, class_name)


@dataclass
class DrivestudioScene:
    """A read and checked drivestudio folder: everything :func:`import_drivestudio` writes.

    ``cameras``: scene camera name -> drivestudio index; ``image_paths (C, F)`` the GT images and
    ``image_us (C, F)`` their timestamps; ``T_cam_world (C, F, 4, 4)`` the layout's camera ->
    world matrices (OpenCV axes, the layout's world); ``doc`` the scene.json dict; ``notes``
    one-line remarks for the user (an inferred dataset, no instances).
    """

    root: Path
    dataset: str
    kind: str
    fps: float
    cameras: dict[str, int]
    image_paths: np.ndarray
    image_us: np.ndarray
    T_cam_world: np.ndarray
    doc: dict
    notes: list[str] = field(default_factory=list)


def _numbers(path: Path, n: int, what: str) -> np.ndarray:
    if not path.is_file():
        raise InputError(path, None, what, "no such file")
    try:
        vals = np.array(path.read_text().split(), dtype=np.float64)
    except (ValueError, UnicodeDecodeError):
        raise InputError(path, None, what, "text that is not numbers") from None
    if vals.size != n or not np.isfinite(vals).all():
        raise InputError(path, None, what, f"{vals.size} numbers" if vals.size != n else "NaN or infinity")
    return vals


def _matrices(paths: list[Path]) -> np.ndarray:
    """Rigid 4x4 text files -> ``(N, 4, 4)``; an error names the first bad file."""
    mats = np.stack([_numbers(p, 16, "a 4x4 matrix (16 numbers, metres)").reshape(4, 4) for p in paths])
    try:
        check_rigid(mats, "matrices", "")
    except InputError:
        for p, m in zip(paths, mats, strict=True):
            check_rigid(m, str(p), "matrix")
    return mats


def _scan_images(root: Path) -> dict[tuple[int, int], Path]:
    folder = root / "images"
    if not folder.is_dir():
        raise InputError(folder, None, "a drivestudio images/ folder of {t:03d}_{cam}.jpg files", "no such folder")
    found = {}
    for entry in os.scandir(folder):
        m = _IMAGE.match(entry.name)
        if m:
            found[int(m.group(1)), int(m.group(2))] = Path(entry.path)
    if not found:
        raise InputError(folder, None, "images named {t:03d}_{cam}.jpg", "none")
    return found


def _pick_cameras(all_cams: list[int], names: tuple, cameras) -> list[int]:
    if cameras is None:
        return all_cams
    by_name = {(names[c] if c < len(names) else f"cam{c}"): c for c in all_cams}
    picked = []
    for item in cameras:
        s = str(item).strip()
        c = int(s) if s.isdigit() else by_name.get(s)
        if c not in all_cams or c in picked:
            known = ", ".join(f"{c}={n}" for n, c in by_name.items())
            raise InputError("cameras", None, f"distinct cameras of the layout, by index or name ({known})", s)
        picked.append(c)
    return sorted(picked)


def _extrinsics_kind(root: Path) -> str:
    folder = root / "extrinsics"
    if not folder.is_dir():
        raise InputError(folder, None, "a drivestudio extrinsics/ folder", "no such folder")
    names = [e.name for e in os.scandir(folder)]
    per_cam = any(_PER_CAMERA_FILE.match(n) for n in names)
    per_frame = any(_PER_FRAME_FILE.match(n) for n in names)
    if per_cam == per_frame:
        raise InputError(folder, None, "either per-camera files {cam}.txt (with ego_pose/) or per-frame files "
                         "{t:03d}_{cam}.txt", "both" if per_cam else "neither")
    return "per_camera" if per_cam else "per_frame"


def _dataset(root: Path, kind: str, n_cams: int, dataset: str | None) -> tuple[str, list[str]]:
    """The dataset (``dataset`` or the one the files fit) and a note when it was inferred."""
    if dataset is not None:
        if dataset not in DATASETS:
            raise InputError("dataset", None, "one of {" + ", ".join(DATASETS) + "}", dataset)
        if (dataset in PER_FRAME) != (kind == "per_frame"):
            want = "per-frame extrinsics/{t:03d}_{cam}.txt" if dataset in PER_FRAME \
                else "per-camera extrinsics/{cam}.txt with ego_pose/"
            raise InputError(root / "extrinsics", None, f"{want} for {dataset}", kind.replace("_", "-") + " files")
        return dataset, []
    if kind == "per_frame":
        guess = ["pandaset"] if (root / "ego_pose").is_dir() else ["nuscenes"]
        why = "per-frame extrinsics " + ("with" if guess == ["pandaset"] else "without") + " ego_pose/"
    else:
        guess = [d for d in DATASETS if d not in PER_FRAME and len(CAMERA_NAMES[d]) == n_cams]
        why = f"per-camera extrinsics, {n_cams} cameras"
    if len(guess) != 1:
        fits = " or ".join(d for d in DATASETS if d not in PER_FRAME)
        raise InputError(root, None, f"--dataset NAME for this folder (its {why} fit none of {fits} by camera count)",
                         "no --dataset")
    return guess[0], [f"note: {root}: dataset {guess[0]} ({why}); --dataset overrides it"]


def _fps(root: Path, dataset: str, fps) -> float:
    if fps is not None:
        return check_number("fps", fps, low=0, high=1000, low_open=True)
    if dataset == "nuscenes":
        for part in (root.resolve(), *root.resolve().parents):
            m = _HZ.search(part.name)
            if m:
                return float(m.group(1))
    return DEFAULT_FPS[dataset]


def _intrinsics(root: Path, cam: int) -> dict:
    v = _numbers(root / "intrinsics" / f"{cam}.txt", 9, "9 intrinsics numbers fx fy cx cy k1 k2 p1 p2 k3")
    fx, fy, cx, cy, k1, k2, p1, p2, k3 = v.tolist()
    if fx <= 0 or fy <= 0:
        raise InputError(root / "intrinsics" / f"{cam}.txt", None, "positive focal lengths fx, fy", [fx, fy])
    model = {"type": "pinhole", "focal_length": [fx, fy], "principal_point": [cx, cy]}
    if any((k1, k2, p1, p2, k3)):
        model.update(type="opencv_pinhole", radial_coeffs=[k1, k2, k3, 0.0, 0.0, 0.0], tangential_coeffs=[p1, p2],
                     thin_prism_coeffs=[0.0] * 4)
    return model


def _image_size(paths) -> tuple[int, int]:
    """The one ``(W, H)`` of a camera's images (headers only); an error names the first odd one."""
    size = None
    for p in paths:
        try:
            with Image.open(p) as im:
                s = im.size
        except (UnidentifiedImageError, OSError):
            raise InputError(p, None, "a readable JPEG image", "an unreadable file") from None
        if size is None:
            size = s
        elif s != size:
            raise InputError(p, None, f"the size of the camera's other images, {size[0]}x{size[1]}",
                             f"{s[0]}x{s[1]}")
    return size


def _json(path: Path):
    if not path.is_file():
        raise InputError(path, None, "a drivestudio instances file", "no such file")
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, None, "valid JSON", str(exc)) from None


def _listed(path: Path, frame_instances, keys: set, n_frames: int) -> dict[str, np.ndarray]:
    """Object key -> the frames ``frame_instances.json`` lists it in (sorted), checked."""
    if not isinstance(frame_instances, dict):
        raise InputError(path, None, "an object {frame: [object keys]}", type(frame_instances).__name__)
    listed: dict[str, list] = {}
    for f, objs in frame_instances.items():
        if not str(f).isdigit() or int(f) >= n_frames:
            raise InputError(path, f"frame {f!r}", f"a frame of the layout (0-{n_frames - 1})", f)
        if not isinstance(objs, list):
            raise InputError(path, f"frame {f}", "a list of object keys", type(objs).__name__)
        for k in objs:
            if str(k) not in keys:
                raise InputError(path, f"frame {f}", "objects of instances_info.json", f"unknown object {k!r}")
            listed.setdefault(str(k), []).append(int(f))
    return {k: np.unique(v) for k, v in listed.items()}


def _box_sizes(info_path: Path, fld: str, sizes: list) -> np.ndarray:
    """``box_size`` entries -> ``(n, 3)``; an error names the first that is not 3 positive numbers."""
    try:
        arr = np.asarray(sizes)
    except ValueError:  # ragged
        arr = np.zeros(0)
    if arr.ndim == 2 and arr.shape[1] == 3 and np.issubdtype(arr.dtype, np.number) \
            and np.isfinite(arr).all() and (arr > 0).all():
        return arr.astype(np.float64)
    if not sizes:
        return np.zeros((0, 3))
    for i, s in enumerate(sizes):
        good = isinstance(s, list) and len(s) == 3 and all(
            isinstance(x, int | float) and not isinstance(x, bool) and np.isfinite(x) and x > 0 for x in s)
        if not good:
            raise InputError(info_path, f"{fld}.frame_annotations.box_size[{i}]", "3 positive numbers [l, w, h]", s)
    return np.asarray(sizes, dtype=np.float64)  # e.g. a bool among the numbers


def _track(info_path: Path, key: str, inst, dataset: str, n_frames: int, listed: dict):
    """One instance -> ``(track_id, label_class, frames (n,), T_box_world (n, 4, 4), dims (3,))`` or None."""
    fld = key
    if not isinstance(inst, dict):
        raise InputError(info_path, fld, "an object with id, class_name, frame_annotations", type(inst).__name__)
    for name in ("id", "class_name", "frame_annotations"):
        if name not in inst:
            raise InputError(info_path, f"{fld}.{name}", "this field", "missing")
    tid, cls, ann = str(inst["id"]), inst["class_name"], inst["frame_annotations"]
    if not tid or ":" in tid:
        raise InputError(info_path, f"{fld}.id", "a non-empty id without ':'", repr(tid))
    if not isinstance(cls, str) or not cls:
        raise InputError(info_path, f"{fld}.class_name", "a class name", repr(cls))
    cols = {}
    for name in ("frame_idx", "obj_to_world", "box_size"):
        v = ann.get(name) if isinstance(ann, dict) else None
        if not isinstance(v, list):
            raise InputError(info_path, f"{fld}.frame_annotations.{name}", "a list", type(v).__name__)
        cols[name] = v
    n = len(cols["frame_idx"])
    for name in ("obj_to_world", "box_size"):
        if len(cols[name]) != n:
            raise InputError(info_path, f"{fld}.frame_annotations.{name}", f"{n} entries (one per frame_idx)",
                             len(cols[name]))
    frames = np.asarray(cols["frame_idx"])
    if frames.ndim != 1 or (n and not np.issubdtype(frames.dtype, np.integer)) \
            or np.any(frames < 0) or np.any(frames >= n_frames) or len(np.unique(frames)) != n:
        raise InputError(info_path, f"{fld}.frame_annotations.frame_idx",
                         f"distinct frames of the layout (0-{n_frames - 1})", cols["frame_idx"])
    sizes = _box_sizes(info_path, fld, cols["box_size"])
    keep = np.isin(frames, listed.get(key, np.zeros(0, np.int64)))
    if not keep.any():
        return None  # never listed in frame_instances: drivestudio drops it too
    order = np.argsort(frames[keep], kind="stable")
    try:
        T = np.asarray(cols["obj_to_world"], dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(info_path, f"{fld}.frame_annotations.obj_to_world", "4x4 matrices", "ragged values") from None
    if T.shape != (n, 4, 4):
        raise InputError(info_path, f"{fld}.frame_annotations.obj_to_world", "4x4 matrices", f"shape {T.shape}")
    check_rigid(T, str(info_path), f"{fld}.frame_annotations.obj_to_world")
    T, dims = T[keep][order], sizes[keep].mean(axis=0)
    if dataset == "pandaset":  # dimensions.x is the width: make the box's x its length
        T, dims = T @ _RZ90, dims[[1, 0, 2]]
    return tid, map_class(dataset, cls), frames[keep][order], T, dims


def _tracks(root: Path, dataset: str, n_frames: int, frame_us: np.ndarray, hold_us: int) -> tuple[list, list]:
    folder = root / "instances"
    if not folder.is_dir():
        return [], [f"note: {root} has no instances/ folder (an EmerNeRF-style layout): the scene has no tracks"]
    info_path, fi_path = folder / "instances_info.json", folder / "frame_instances.json"
    info, frame_instances = _json(info_path), _json(fi_path)
    if not isinstance(info, dict):
        raise InputError(info_path, None, "an object {key: instance}", type(info).__name__)
    listed = _listed(fi_path, frame_instances, {str(k) for k in info}, n_frames)
    found = {str(k): _track(info_path, str(k), v, dataset, n_frames, listed) for k, v in info.items()}
    for key, frames in listed.items():  # a listed object must be annotated in that frame
        missing = np.setdiff1d(frames, np.asarray(info[key]["frame_annotations"]["frame_idx"]))
        if len(missing):
            raise InputError(fi_path, f"frame {missing[0]}", f"objects annotated in that frame in {info_path.name}",
                             f"object {key!r}")
    kept = [t for t in found.values() if t is not None]
    ids = [t[0] for t in kept]
    dup = next((i for i in ids if ids.count(i) > 1), None)
    if dup is not None:
        raise InputError(info_path, "id", "a distinct id per object", f"{dup!r} twice")
    poses = matrix_to_pose7(np.concatenate([t[3] for t in kept])) if kept else np.zeros((0, 7))
    tracks, start = [], 0
    for tid, label, frames, _, dims in kept:
        p = poses[start:start + len(frames)]
        start += len(frames)
        ts = frame_us[frames]
        if hold_us:  # every camera's image of the last frame shows the box
            ts, p = np.append(ts, ts[-1] + hold_us), np.concatenate([p, p[-1:]])
        tracks.append({"track_id": tid, "label_class": label, "dims_lwh": dims.tolist(),
                       "timestamps_us": ts.tolist(), "poses": p.tolist()})
    return tracks, []


def read_drivestudio(scene_dir: str | os.PathLike, *, dataset: str | None = None, fps: float | None = None,
                     cameras=None) -> DrivestudioScene:
    """Read and check the drivestudio folder ``scene_dir`` (module docstring) without writing.

    Parameters
    ----------
    scene_dir : path
        A processed scene folder (``images/``, ``intrinsics/``, ``extrinsics/``, ``ego_pose/``,
        ``instances/``).
    dataset : {'waymo', 'nuscenes', 'pandaset', 'argoverse', 'nuplan', 'kitti'}, optional
        drivestudio's folder name of the source dataset; default: inferred from the files.
    fps : float, optional
        Frame rate in Hz; default :data:`DEFAULT_FPS` (nuScenes: a ``_NHz`` folder suffix).
    cameras : list of str or int, optional
        Camera indices or names to import; default all.

    Returns
    -------
    DrivestudioScene

    Raises
    ------
    InputError
        A missing or malformed file, naming it (docs/FORMATS.md §13 lists the checks).
    """
    root = Path(scene_dir)
    if dataset is not None and dataset not in DATASETS:
        raise InputError("dataset", None, "one of {" + ", ".join(DATASETS) + "}", dataset)
    if not root.is_dir():
        raise InputError(root, None, "a drivestudio scene folder", "no such folder")
    found = _scan_images(root)
    all_cams = sorted({c for _, c in found})
    kind = _extrinsics_kind(root)
    dataset, notes = _dataset(root, kind, len(all_cams), dataset)
    names = CAMERA_NAMES[dataset]
    cams = _pick_cameras(all_cams, names, cameras)
    n_frames = max(t for t, _ in found) + 1
    paths = np.empty((len(cams), n_frames), dtype=object)
    for i, c in enumerate(cams):
        for t in range(n_frames):
            p = found.get((t, c))
            if p is None:
                raise InputError(root / "images" / f"{t:03d}_{c}.jpg", None,
                                 f"an image of every frame 0-{n_frames - 1} of camera {c}", "no such file")
            paths[i, t] = p
    models = {c: _intrinsics(root, c) for c in cams}
    rate = _fps(root, dataset, fps)
    frame_us = np.round(np.arange(n_frames) * 1e6 / rate).astype(np.int64)
    axes = OPENCV_TO_FLU if dataset == "waymo" else np.eye(3)
    A = np.eye(4)
    A[:3, :3] = axes
    cam_names = [names[c] if c < len(names) else f"cam{c}" for c in cams]
    if kind == "per_camera":
        E = _matrices([root / "extrinsics" / f"{c}.txt" for c in cams]) @ A  # camera (OpenCV) -> ego
        ego = _matrices([root / "ego_pose" / f"{t:03d}.txt" for t in range(n_frames)])
        T_cw = ego[None] @ E[:, None]  # (C, F, 4, 4)
        T_sr, rig_us, T_rw = E, frame_us, ego
        offs = np.zeros(len(cams), np.int64)
        T_world_source = np.linalg.inv(ego[0])
    else:
        X = _matrices([root / "extrinsics" / f"{t:03d}_{c}.txt" for c in cams for t in range(n_frames)])
        T_cw = X.reshape(len(cams), n_frames, 4, 4) @ A
        raw0 = _matrices([root / "extrinsics" / "000_0.txt"])[0]  # camera 0, frame 0
        first = raw0 @ A
        T_front = np.eye(4)
        T_front[:3, :3] = OPENCV_TO_FLU
        rig0 = first @ T_front.T  # camera 0 at frame 0, turned to x forward, y left, z up
        T_sr = np.linalg.inv(rig0) @ T_cw[:, 0]
        offs = np.asarray(cams, np.int64)  # camera c's images at frame time + c us
        img_us = frame_us[None] + offs[:, None]
        T_all = T_cw @ np.linalg.inv(T_sr)[:, None]
        order = np.argsort(img_us.reshape(-1), kind="stable")
        rig_us, T_rw = img_us.reshape(-1)[order], T_all.reshape(-1, 4, 4)[order]
        if np.any(np.diff(rig_us) <= 0):
            raise InputError("fps", None, f"a frame interval above {int(offs.max())} us (one per camera)", rate)
        T_world_source = np.linalg.inv(_matrices([root / "ego_pose" / "000.txt"])[0]) if dataset == "pandaset" \
            else np.linalg.inv(raw0)
    for i, c in enumerate(cams):
        W, H = _image_size(paths[i])
        models[c] = {**models[c], "resolution": [int(W), int(H)]}
        camera_from_model(models[c], where=str(root / "intrinsics" / f"{c}.txt"), field_prefix="")
    hold = int(offs.max()) if len(offs) else 0
    tracks, more = _tracks(root, dataset, n_frames, frame_us, hold)
    doc = {
        "clip_id": f"{dataset}-{root.resolve().name}".replace(":", "-"),
        "attributes": {},
        "cameras": {n: {"T_sensor_rig": T_sr[i], "model": models[c]} for i, (n, c) in enumerate(zip(cam_names, cams,
                                                                                                       strict=True))},
        "rig_trajectory": {"timestamps_us": rig_us.tolist(), "T_rig_world": T_rw},
        "tracks": tracks,
        "source_world": {"name": "drivestudio", "dataset": dataset, "T_world_source": T_world_source},
    }
    return DrivestudioScene(root, dataset, kind, rate, dict(zip(cam_names, cams, strict=True)), paths,
                            frame_us[None] + offs[:, None], T_cw, doc, notes + more)


def _gt_path(camera: str, t_us: int) -> str:
    """``images/<camera>/gt/<t>.jpg``: :func:`default_image_path`'s GT path, with the source's suffix."""
    return str(Path(default_image_path(camera, t_us, "gt")).with_suffix(".jpg").as_posix())


def write_drivestudio(ds: DrivestudioScene, out: str | os.PathLike, *, offsets=(-3, -2, -1, 0, 1, 2, 3),
                      perturbations=None, copy: bool = False) -> Path:
    """Write the scene folder ``out`` of ``ds`` (:func:`read_drivestudio`); returns ``out``.

    GT images are symbolic links to the layout's files (``copy=True``: copies); ``images.csv``
    lists them and one render per view at :func:`default_image_path` (files still to render).
    """
    out = Path(out)
    views = views_from(offsets, perturbations)
    rows, links = [], []
    for i, name in enumerate(ds.cameras):
        for t, src in zip(ds.image_us[i].tolist(), ds.image_paths[i], strict=True):
            rel = _gt_path(name, t)
            links.append((src, rel))
            rows.append((name, t, "gt", *[0.0] * 6, rel))
            rows += [(name, t, "render", *v.tolist(), default_image_path(name, t, "render", v[1], perturbation=v))
                     for v in views]
    images = pd.DataFrame(rows, columns=["camera", "timestamp_us", "source", *PERTURBATION_COLUMNS, "path"])
    images = images.drop_duplicates(["camera", "timestamp_us", "source", *PERTURBATION_COLUMNS])
    with atomic_folder(out) as tmp:
        made = set()
        for src, rel in links:
            dst = tmp / rel
            if dst.parent not in made:
                dst.parent.mkdir(parents=True, exist_ok=True)
                made.add(dst.parent)
            try:
                shutil.copyfile(src, dst) if copy else os.symlink(os.path.abspath(src), dst)
            except OSError as exc:
                raise InputError(out / rel, None, "a writable output (with symbolic links, or use --copy)",
                                 exc.strerror or type(exc).__name__) from None
        save_scene(ds.doc, images.loc[:, [*IMAGES_COLUMNS, *extra_columns(views)]], tmp)
    return out


def import_drivestudio(scene_dir: str | os.PathLike, out: str | os.PathLike, *, offsets=(-3, -2, -1, 0, 1, 2, 3),
                       perturbations=None, fps: float | None = None, cameras=None, dataset: str | None = None,
                       copy: bool = False) -> Path:
    """Convert the drivestudio folder ``scene_dir`` into the scene folder ``out``; returns ``out``.

    :func:`read_drivestudio` (every check, nothing written) then :func:`write_drivestudio`
    (atomically: a bad layout leaves ``out`` as it was). ``offsets``: lateral render offsets
    (metres), or ``perturbations (K, 6)`` (docs/FORMATS.md §9), which replace them.
    """
    ds = read_drivestudio(scene_dir, dataset=dataset, fps=fps, cameras=cameras)
    return write_drivestudio(ds, out, offsets=offsets, perturbations=perturbations, copy=copy)
