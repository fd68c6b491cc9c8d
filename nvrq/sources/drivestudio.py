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
    corners where they are and makes x the length (:mod:`nvrq.sources.drivestudio_instances`
    reads and checks these files). No ``instances/`` (EmerNeRF's folders):
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

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from data_schema.errors import InputError, check_number
from data_schema.images import check_image
from data_schema.perturbation import views_from
from data_schema.scene import CameraCalib, SourceWorld, Track, check_rigid, validate_camera_model
from data_schema.scene_writer import NewScene, SceneFrame, scene_doc
from nvrq.render_plans import default_image_path
from nvrq.sources.base import ImportedScene, write_imported
from nvrq.sources.drivestudio_instances import MAX_TRANSLATION_M, check_translation, read_instances
from nvrq.sources.drivestudio_meta import (
    CAMERA_NAMES,
    DATASETS,
    DEFAULT_FPS,
    OPENCV_TO_FLU,
    PER_FRAME,
    map_class,
)

__all__ = ["DrivestudioScene", "read_drivestudio", "write_drivestudio", "import_drivestudio", "DrivestudioImporter",
           "IMPORTER"]

_IMAGE = re.compile(r"^(\d+)_(\d+)\.jpg$")
_PER_CAMERA_FILE = re.compile(r"^(\d+)\.txt$")
_PER_FRAME_FILE = re.compile(r"^(\d+)_(\d+)\.txt$")
_HZ = re.compile(r"_(\d+(?:\.\d+)?)Hz$")


@dataclass
class DrivestudioScene:
    """A read and checked drivestudio folder: everything :func:`import_drivestudio` writes.

    ``cameras``: scene camera name -> drivestudio index; ``image_paths (C, F)`` the GT images and
    ``image_us (C, F)`` their timestamps; ``T_cam_world (C, F, 4, 4)`` the layout's camera ->
    world matrices (OpenCV axes, the layout's world); ``scene`` the typed scene
    (:class:`data_schema.scene_writer.NewScene`; ``doc`` its scene.json dict); ``notes``
    one-line remarks for the user (an inferred dataset, no instances).

    Attributes
    ----------
    root : pathlib.Path
        The drivestudio scene folder.
    dataset : str
        The source dataset (e.g. ``waymo``, ``nuscenes``).
    kind : str
        The extrinsics layout: ``per_camera`` (with ``ego_pose/``) or ``per_frame``.
    fps : float
        Frame rate in Hz.
    cameras : dict of str to int
        Scene camera name -> drivestudio camera index.
    image_paths : (C, F) numpy.ndarray
        The GT images per camera and frame.
    image_us : (C, F) int numpy.ndarray
        Their timestamps (microseconds).
    T_cam_world : (C, F, 4, 4) float numpy.ndarray
        Camera -> world matrices (OpenCV axes, the layout's world).
    scene : NewScene
        The typed scene.
    notes : list of str
        One-line remarks for the user.
    """

    root: Path
    dataset: str
    kind: str
    fps: float
    cameras: dict[str, int]
    image_paths: np.ndarray
    image_us: np.ndarray
    T_cam_world: np.ndarray
    scene: NewScene
    notes: list[str] = field(default_factory=list)

    @property
    def doc(self) -> dict:
        """The scene.json document (:func:`data_schema.scene_writer.scene_doc`)."""
        return scene_doc(self.scene)


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
    """Rigid 4x4 text files -> ``(N, 4, 4)``, translations within ``MAX_TRANSLATION_M``; an error
    names the first bad file (and the row of a translation out of bounds)."""
    mats = np.stack([_numbers(p, 16, "a 4x4 matrix (16 numbers, metres)").reshape(4, 4) for p in paths])
    big = np.abs(mats[:, :3, 3]) > MAX_TRANSLATION_M
    if big.any():
        i = int(np.argmax(big.any(axis=1)))
        row = int(np.argmax(big[i]))
        check_translation(mats[i:i + 1], paths[i], lambda _: f"row {row + 1}")
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
    if not list(cameras):
        raise InputError(param="cameras", expected="at least one camera index or name", got="an empty list")
    by_name = {(names[c] if c < len(names) else f"cam{c}"): c for c in all_cams}
    picked = []
    for item in cameras:
        s = str(item).strip()
        c = int(s) if s.isdigit() else by_name.get(s)
        if c not in all_cams or c in picked:
            known = ", ".join(f"{c}={n}" for n, c in by_name.items())
            raise InputError(param="cameras", expected=f"distinct cameras of the layout, by index or name ({known})", got=s)
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
    if dataset is not None:  # a name of DATASETS (read_drivestudio checked it first)
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
        raise InputError(root, None, f"`dataset` for this folder (its {why} fit none of {fits} by camera count)",
                         "none given")
    return guess[0], [f"note: {root}: dataset {guess[0]} ({why}); `dataset` overrides it"]


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
        head = check_image(p)  # the header only: no decode, a bomb or a file cut short refused
        s = (head.width, head.height)
        if size is None:
            size = s
        elif s != size:
            raise InputError(p, None, f"the size of the camera's other images, {size[0]}x{size[1]}",
                             f"{s[0]}x{s[1]}")
    return size


def _tracks(root: Path, dataset: str, n_frames: int, frame_us: np.ndarray, hold_us: int) -> tuple[list, list]:
    folder = root / "instances"
    if not folder.is_dir():
        return [], [f"note: {root} has no instances/ folder (an EmerNeRF-style layout): the scene has no tracks"]
    found = read_instances(folder, n_frames=n_frames, frame_us=frame_us, hold_us=hold_us,
                           label_of=lambda name: map_class(dataset, name), turn_z90=dataset == "pandaset")
    return [Track(t["track_id"], t["label_class"], np.asarray(t["dims_lwh"], float),
                  np.asarray(t["timestamps_us"], np.int64), np.asarray(t["poses"], float)) for t in found], []


def _per_frame_geometry(root: Path, cams: list, frame_us: np.ndarray, A: np.ndarray, dataset: str, rate: float):
    """Per-frame layouts (module docstring): ``(T_cw (C, F, 4, 4), T_sr (C, 4, 4), rig_us, T_rw,
    offs (C,) us, T_world_source)``."""
    n_frames = len(frame_us)
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
        raise InputError(param="fps", expected=f"a frame interval above {int(offs.max())} us (one per camera)", got=rate)
    T_world_source = np.linalg.inv(_matrices([root / "ego_pose" / "000.txt"])[0]) if dataset == "pandaset" \
        else np.linalg.inv(raw0)
    return T_cw, T_sr, rig_us, T_rw, offs, T_world_source


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
        raise InputError(param="dataset", expected="one of {" + ", ".join(DATASETS) + "}", got=dataset)
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
        T_cw, T_sr, rig_us, T_rw, offs, T_world_source = _per_frame_geometry(root, cams, frame_us, A, dataset, rate)
    for i, c in enumerate(cams):
        W, H = _image_size(paths[i])
        models[c] = validate_camera_model({**models[c], "resolution": [int(W), int(H)]},
                                          str(root / "intrinsics" / f"{c}.txt"), "")
    hold = int(offs.max()) if len(offs) else 0
    tracks, more = _tracks(root, dataset, n_frames, frame_us, hold)
    image_us = frame_us[None] + offs[:, None]
    frames = [SceneFrame(n, t, _gt_path(n, t), Path(src)) for i, n in enumerate(cam_names)
              for t, src in zip(image_us[i].tolist(), paths[i], strict=True)]
    scene = NewScene(f"{dataset}-{root.resolve().name}".replace(":", "-"),
                     {n: CameraCalib(n, T_sr[i], models[c]) for i, (n, c) in enumerate(zip(cam_names, cams, strict=True))},
                     rig_us, T_rw, tracks, frames, {}, SourceWorld("drivestudio", dataset, T_world_source))
    return DrivestudioScene(root, dataset, kind, rate, dict(zip(cam_names, cams, strict=True)), paths,
                            image_us, T_cw, scene, notes + more)


def _gt_path(camera: str, t_us: int) -> str:
    """``images/<camera>/gt/<t>.jpg``: :func:`default_image_path`'s GT path, with the source's suffix."""
    return str(Path(default_image_path(camera, t_us, "gt")).with_suffix(".jpg").as_posix())


def write_drivestudio(ds: DrivestudioScene, out: str | os.PathLike, *, offsets=(-3, -2, -1, 0, 1, 2, 3),
                      perturbations=None, copy: bool = False) -> Path:
    """Write the scene folder ``out`` of ``ds`` (:func:`read_drivestudio`) through the one writer.

    Parameters
    ----------
    ds : DrivestudioScene
        The read folder.
    out : path
        The scene folder (whole and atomically: a failure leaves it as it was).
    offsets : sequence of float
        Lateral render offsets (metres), used when ``perturbations`` is None.
    perturbations : numpy.ndarray, (K, 6), optional
        6-DoF views (docs/FORMATS.md §9).
    copy : bool
        Copy the GT images (default: absolute symbolic links to the layout's files).

    Returns
    -------
    pathlib.Path
        ``out``; ``images.csv`` lists the GT images and one render per view at
        :func:`default_image_path` (files still to render).
    """
    views = views_from(offsets, perturbations)
    return write_imported(ImportedScene(ds.scene, views, link=not copy), out)


class DrivestudioImporter:
    """``nvrq import drivestudio SCENE_DIR OUT`` (:class:`nvrq.sources.base.Importer`)."""

    def read(self, path, *, offsets=(-3, -2, -1, 0, 1, 2, 3), perturbations=None, copy: bool = False,
             **options) -> ImportedScene:
        """Read the drivestudio folder ``path`` (:func:`read_drivestudio`) with its views.

        Parameters
        ----------
        path : path
            The processed scene folder.
        offsets, perturbations
            The views, as for :func:`import_drivestudio`.
        copy : bool
            Copy the GT images when written (default: symbolic links).
        **options
            :func:`read_drivestudio`'s ``dataset``, ``fps``, ``cameras``.

        Returns
        -------
        ImportedScene
            The scene, its views, and the notes for the user.
        """
        views = views_from(offsets, perturbations)  # the views first, then the files
        ds = read_drivestudio(path, **options)
        return ImportedScene(ds.scene, views, link=not copy, notes=tuple(ds.notes),
                             detail=f"{ds.dataset}, {ds.fps:g} Hz")


#: The importer of ``nvrq import drivestudio``.
IMPORTER = DrivestudioImporter()


def import_drivestudio(scene_dir: str | os.PathLike, out: str | os.PathLike, *, offsets=(-3, -2, -1, 0, 1, 2, 3),
                       perturbations=None, fps: float | None = None, cameras=None, dataset: str | None = None,
                       copy: bool = False) -> Path:
    """Convert the drivestudio folder ``scene_dir`` into the scene folder ``out``; returns ``out``.

    :func:`read_drivestudio` (every check, nothing written) then :func:`write_drivestudio`
    (atomically: a bad layout leaves ``out`` as it was). ``offsets``: lateral render offsets
    (metres), or ``perturbations (K, 6)`` (docs/FORMATS.md §9), which replace them.

    Parameters
    ----------
    scene_dir : str or os.PathLike
        The drivestudio scene folder.
    out : str or os.PathLike
        The scene folder to write.
    offsets : sequence of float, optional
        Lateral render offsets in metres (default -3 .. 3).
    perturbations : (K, 6) array-like, optional
        Views ``dx, dy, dz, roll, pitch, yaw`` (metres, degrees); replace ``offsets``.
    fps : float, optional
        Frame rate in Hz (default as :func:`read_drivestudio`).
    cameras : list of str or int, optional
        Camera indices or names to import (default: all).
    dataset : str, optional
        drivestudio's name of the source dataset (default: inferred from the files).
    copy : bool, optional
        Copy the GT frames into ``out`` instead of linking them (default False).

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    ds = read_drivestudio(scene_dir, dataset=dataset, fps=fps, cameras=cameras)
    return write_drivestudio(ds, out, offsets=offsets, perturbations=perturbations, copy=copy)
