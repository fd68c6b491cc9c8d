"""A rectified stereo pair -> scene folder: a real photograph at a known lateral offset.

``nvrq import stereo LEFT RIGHT --calibration F --baseline B [--disparity PNG] [--labels FILE]
OUT`` writes a one-frame scene whose GT image is ``LEFT`` and whose one render is ``RIGHT``, at
``y_offset_m = -B`` with method ``real`` (:data:`data_schema.methods.REAL_METHOD`): the right
camera of a rig sits ``B`` metres to the *right* of the left one, and a positive ``y_offset_m``
moves the camera to the left (docs/FORMATS.md §1). Nothing in the right image is reconstructed,
so its pairs measure what a metric gives for the change of view alone.

Convention (rectified pairs; Argoverse 1.1 ``argoverse/utils/calibration.py`` and KITTI's
stereo devkit): both images share the intrinsics ``fx, fy, cx, cy``; a left pixel ``(u, v)``
with disparity ``d > 0`` shows the point that the right image has at ``(u - d, v)``, at depth
``Z = fx * B / d`` metres. Disparity PNGs are ``uint16`` with ``d = value / 256`` pixels and 0
for none (Argoverse ``disparity_maps_v1.1``, KITTI ``disp_occ``). The rig sits at the left
camera (camera frame x right, y down, z forward; rig x forward, y left, z up), the world is the
rig (``T_rig_world = I`` at t = 0).

Objects come from ``--labels`` (KITTI ``label_2`` boxes, with a KITTI calib file holding ``P2``)
or, without labels, from the objects-only disparity map ``--disparity`` by
:func:`cluster_objects`: DBSCAN (scikit-learn) on ``(u, v * V_SCALE, d * D_SCALE)`` joins the
sparse LiDAR scan lines of one object, then a cluster whose disparities differ from their median
by more than ``margin`` pixels is split in two at the disparity that minimises the within-part
variance (Otsu's rule in 1D), and each part is clustered again, until every cluster is
disparity-coherent. Each cluster of at least :data:`MIN_POINTS` points becomes a camera-facing
box (:func:`object_boxes`): its left box is the points' pixel extent padded by ``margin`` pixels
(:data:`MARGIN_PX`), its depth ``Z = fx * B / median(d)``, its width and height that padded
extent at ``Z`` and its thickness :data:`THICKNESS_M`, so ``nvrq pairs`` projects it back to
the padded extent in the left image and to that box moved ``median(d)`` pixels left in the right
image. How good this is: a point whose disparity differs from the median by ``delta`` pixels
lands ``delta`` pixels off the moved box, so every point of a cluster (``delta <= margin`` by
construction) lands inside its right box, up to the pixel rounding of the box edges; an object
much deeper than ``margin`` pixels of disparity (a car seen along its side) is cut into slices.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from data_schema.errors import InputError, check_number
from nvrq.sources.stereo_meta import MARGIN_PX, ROW_TOLERANCE_PX, UNKNOWN_CLASS

__all__ = ["Intrinsics", "StereoObject", "read_calibration", "read_disparity", "row_offset", "cluster_objects",
           "object_boxes", "object_tracks", "label_tracks", "StereoOptions", "read_stereo", "StereoImporter", "IMPORTER",
           "MARGIN_PX", "MIN_POINTS", "ROW_TOLERANCE_PX", "THICKNESS_M", "DISPARITY_SCALE", "CAMERA",
           "UNKNOWN_CLASS"]

#: the fewest disparity points a cluster needs to become an object
MIN_POINTS = 20
#: a box's extent along the viewing axis (metres): a camera-facing plate
THICKNESS_M = 0.001
#: a disparity PNG's value per pixel of disparity (uint16 PNG, 0 = none)
DISPARITY_SCALE = 256.0
#: how far inside the left box's edges its projected corners are placed (pixels), so that
#: the pixel box ``nvrq pairs`` rounds them to is the left box itself
_INSIDE_PX = 0.05
#: the scene's camera name
CAMERA = "left"
#: DBSCAN's neighbourhood radius (pixels) and the scales of its rows (LiDAR scan lines are far
#: apart vertically) and disparities (a 5 px disparity step is a 15 px step)
EPS_PX = 15.0
V_SCALE = 0.35
D_SCALE = 3.0

#: camera frame (x right, y down, z forward) -> rig frame (x forward, y left, z up)
R_SENSOR_RIG = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


@dataclass(frozen=True)
class Intrinsics:
    """The rectified pinhole intrinsics both images share (pixels)."""

    fx: float
    fy: float
    cx: float
    cy: float


@dataclass(frozen=True)
class StereoObject:
    """One object found in the disparity.

    Attributes
    ----------
    left_box : (4,) float ndarray
        ``x0, y0, x1, y1`` pixel centres of the padded box in the left image (inclusive).
    disparity : float
        The median disparity of its points (pixels).
    points : (N, 3) float ndarray
        Its points ``u, v, d`` (left pixel, disparity).
    """

    left_box: np.ndarray
    disparity: float
    points: np.ndarray

    @property
    def right_box(self) -> np.ndarray:
        """The left box moved ``disparity`` pixels left: ``(4,)`` ``x0, y0, x1, y1``."""
        return self.left_box - np.array([self.disparity, 0.0, self.disparity, 0.0])


def read_calibration(path: str | os.PathLike) -> Intrinsics:
    """The rectified intrinsics from ``path``, one of three layouts (docs/FORMATS.md §16):

    - JSON ``{"focal_length": [fx, fy], "principal_point": [cx, cy]}`` (the scene's pinhole fields);
    - Argoverse's ``vehicle_calibration_stereo_info.json``: the ``image_raw_stereo_front_left_rect``
      entry of ``camera_data_``;
    - a KITTI calib ``.txt``: ``P2``'s ``K``.

    Parameters
    ----------
    path : str or os.PathLike
        The calibration file.

    Returns
    -------
    Intrinsics
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, None, "a calibration file", "no such file")
    if path.suffix.lower() == ".txt":
        from nvrq.sources.kitti import read_calib_P2

        K = read_calib_P2(path)[:, :3]
        return _intrinsics(path, "P2", [K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
    try:
        doc = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(path, None, "a JSON calibration file", str(exc)) from None
    if isinstance(doc, dict) and "camera_data_" in doc:
        entry = next((c.get("value") for c in doc["camera_data_"] if isinstance(c, dict)
                      and c.get("key") == "image_raw_stereo_front_left_rect"), None)
        if not isinstance(entry, dict):
            raise InputError(path, "camera_data_", "an entry image_raw_stereo_front_left_rect", "none")
        keys = ("focal_length_x_px_", "focal_length_y_px_", "focal_center_x_px_", "focal_center_y_px_")
        return _intrinsics(path, "image_raw_stereo_front_left_rect", [entry.get(k) for k in keys])
    if not isinstance(doc, dict) or "focal_length" not in doc or "principal_point" not in doc:
        raise InputError(path, None, "a JSON object with focal_length [fx, fy] and principal_point [cx, cy] "
                         "(or Argoverse's camera_data_)", "neither")
    f, c = doc["focal_length"], doc["principal_point"]
    if not (isinstance(f, list) and isinstance(c, list) and len(f) == 2 and len(c) == 2):
        raise InputError(path, "focal_length/principal_point", "two numbers each", f"{f!r}, {c!r}")
    return _intrinsics(path, "focal_length/principal_point", [*f, *c])


def _intrinsics(path, field, values) -> Intrinsics:
    try:
        fx, fy, cx, cy = (float(v) for v in values)
    except (TypeError, ValueError):
        raise InputError(path, field, "numbers fx, fy, cx, cy", repr(values)) from None
    if not (np.isfinite([fx, fy, cx, cy]).all() and fx > 0 and fy > 0):
        raise InputError(path, field, "finite intrinsics with fx, fy > 0", repr(values))
    return Intrinsics(fx, fy, cx, cy)


def _read_image(path: Path, what: str, flags=None) -> np.ndarray:
    import cv2

    if not path.is_file():
        raise InputError(path, None, what, "no such file")
    img = cv2.imread(str(path), cv2.IMREAD_COLOR if flags is None else flags)
    if img is None:
        raise InputError(path, None, what, "undecodable file")
    return img


def read_disparity(path: str | os.PathLike, *, size: tuple[int, int]) -> np.ndarray:
    """A disparity PNG as pixels (``uint16 / 256``; 0 = none), checked against the image size.

    Parameters
    ----------
    path : str or os.PathLike
        The ``uint16`` PNG.
    size : tuple of int
        ``(W, H)`` of the left image.

    Returns
    -------
    (H, W) float64 numpy.ndarray
        Disparity in pixels, 0 where none.
    """
    import cv2

    path = Path(path)
    raw = _read_image(path, "a uint16 disparity PNG", cv2.IMREAD_UNCHANGED)
    if raw.ndim != 2 or raw.dtype != np.uint16:
        raise InputError(path, None, "a one-channel uint16 disparity PNG", f"{raw.dtype} with shape {raw.shape}")
    if (raw.shape[1], raw.shape[0]) != tuple(size):
        raise InputError(path, None, f"a disparity map of the left image's size {size[0]}x{size[1]}",
                         f"{raw.shape[1]}x{raw.shape[0]}")
    return raw.astype(np.float64) / DISPARITY_SCALE


def row_offset(left: np.ndarray, right: np.ndarray, *, n_features: int = 3000) -> tuple[float, int]:
    """The median ``|v_left - v_right|`` of ORB matches (OpenCV, cross-checked Hamming matches):
    how far a pair is from rectified (0 for a perfect one).

    Parameters
    ----------
    left, right : (H, W, 3) or (H, W) uint8 numpy.ndarray
        The two images.
    n_features : int
        ORB keypoints per image.

    Returns
    -------
    tuple of (float, int)
        The median absolute row difference (pixels; NaN without matches) and the number of matches.
    """
    import cv2

    grey = [cv2.cvtColor(x, cv2.COLOR_BGR2GRAY) if x.ndim == 3 else x for x in (left, right)]
    orb = cv2.ORB_create(n_features)
    (kl, dl), (kr, dr) = (orb.detectAndCompute(g, None) for g in grey)
    if dl is None or dr is None:
        return float("nan"), 0
    matches = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(dl, dr)
    if not matches:
        return float("nan"), 0
    dy = np.array([kl[m.queryIdx].pt[1] - kr[m.trainIdx].pt[1] for m in matches])
    return float(np.median(np.abs(dy))), len(matches)


def _otsu_split(d: np.ndarray) -> np.ndarray:
    """Boolean mask of the lower part of ``d (N,)`` at the cut that minimises the summed
    within-part variance (both parts non-empty)."""
    order = np.argsort(d, kind="stable")
    s = d[order]
    n = len(s)
    k = np.arange(1, n)  # sizes of the lower part
    c1, c2 = np.cumsum(s)[:-1], np.cumsum(s ** 2)[:-1]
    t1, t2 = s.sum(), (s ** 2).sum()
    within = (c2 - c1 ** 2 / k) + ((t2 - c2) - (t1 - c1) ** 2 / (n - k))
    cut = int(np.argmin(within)) + 1
    low = np.zeros(n, bool)
    low[order[:cut]] = True
    return low


def cluster_objects(disparity: np.ndarray, *, margin: float = MARGIN_PX,
                    min_points: int = MIN_POINTS) -> list[np.ndarray]:
    """The objects of an objects-only disparity map: disparity-coherent clusters of its points
    (module docstring).

    Parameters
    ----------
    disparity : (H, W) float numpy.ndarray
        Disparity in pixels, 0 where none.
    margin : float
        A cluster's disparities lie within ``margin`` pixels of their median.
    min_points : int
        The fewest points a cluster keeps.

    Returns
    -------
    list of (N, 3) float numpy.ndarray
        Each cluster's points ``u, v, d``, largest first.
    """
    from sklearn.cluster import DBSCAN

    v, u = np.nonzero(disparity > 0)
    pts = np.c_[u, v, disparity[v, u]].astype(np.float64)
    out, todo = [], [pts]
    while todo:
        part = todo.pop()
        if len(part) < min_points:
            continue
        labels = DBSCAN(eps=EPS_PX, min_samples=5).fit_predict(
            np.c_[part[:, 0], part[:, 1] * V_SCALE, part[:, 2] * D_SCALE])
        for k in range(labels.max() + 1):
            c = part[labels == k]
            if len(c) < min_points:
                continue
            if np.abs(c[:, 2] - np.median(c[:, 2])).max() <= margin:
                out.append(c)
            else:
                low = _otsu_split(c[:, 2])
                todo += [c[low], c[~low]]
    return sorted(out, key=lambda c: (-len(c), c[:, 0].min(), c[:, 1].min()))


def object_boxes(clusters, *, margin: float, size: tuple[int, int]) -> list[StereoObject]:
    """The padded left box and median disparity of each cluster, the box clipped to the image.

    Parameters
    ----------
    clusters : list of (N, 3) numpy.ndarray
        :func:`cluster_objects`.
    margin : float
        Pixels added on every side.
    size : tuple of int
        ``(W, H)``.

    Returns
    -------
    list of StereoObject

    >>> o = object_boxes([np.array([[10., 20, 5], [30, 40, 7]])], margin=2, size=(100, 100))[0]
    >>> o.left_box.tolist(), o.disparity, o.right_box.tolist()
    ([8.0, 18.0, 32.0, 42.0], 6.0, [2.0, 18.0, 26.0, 42.0])
    """
    W, H = size
    out = []
    for c in clusters:
        box = np.array([c[:, 0].min() - margin, c[:, 1].min() - margin, c[:, 0].max() + margin,
                        c[:, 1].max() + margin])
        box = np.clip(box, 0, [W - 1, H - 1, W - 1, H - 1])
        out.append(StereoObject(box, float(np.median(c[:, 2])), c))
    return out


def _edges(lo: float, hi: float, c: float, f: float, Z: float) -> tuple[float, float]:
    """Metric coordinates of a box's two edges (pixels ``lo < hi``, principal point ``c``) such
    that both faces of the box, at ``Z -/+ THICKNESS_M / 2``, project within ``[lo, hi]``: each
    edge is placed by the face that projects farthest out (the far face moves towards ``c``)."""
    near, far = Z - THICKNESS_M / 2, Z + THICKNESS_M / 2
    return (lo - c) * (far if lo > c else near) / f, (hi - c) * (near if hi > c else far) / f


def object_tracks(objects, intr: Intrinsics, baseline: float, *, label_class: str = UNKNOWN_CLASS):
    """One one-sample track per object: a camera-facing box centred at ``Z = fx * B / d``, of
    thickness :data:`THICKNESS_M`, whose 8 corners project onto the object's left box (each edge
    by the face that reaches it), so ``nvrq pairs`` gives that box back.

    Parameters
    ----------
    objects : list of StereoObject
        :func:`object_boxes`.
    intr : Intrinsics
        The shared intrinsics.
    baseline : float
        Metres between the cameras (> 0).
    label_class : str
        The tracks' class.

    Returns
    -------
    list of data_schema.scene.Track
        Ids ``000-unknown``, ``001-unknown``, ... (rig frame, t = 0).
    """
    from data_schema.scene import Track

    tracks = []
    for i, o in enumerate(objects):
        Z = intr.fx * baseline / o.disparity
        x0, y0, x1, y1 = o.left_box + np.array([1, 1, -1, -1]) * _INSIDE_PX
        X0, X1 = _edges(x0, x1, intr.cx, intr.fx, Z)
        Y0, Y1 = _edges(y0, y1, intr.cy, intr.fy, Z)
        width, height = X1 - X0, Y1 - Y0
        centre = R_SENSOR_RIG @ np.array([(X0 + X1) / 2, (Y0 + Y1) / 2, Z])
        tracks.append(Track(f"{i:03d}-{label_class}", label_class, np.array([THICKNESS_M, width, height]),
                            np.zeros(1, np.int64), np.array([[*centre, 0.0, 0.0, 0.0, 1.0]])))
    return tracks


def label_tracks(calib_path: Path, labels_path: Path):
    """The tracks of a KITTI ``label_2`` file (boxes in the left colour camera of ``P2``).

    Parameters
    ----------
    calib_path, labels_path : pathlib.Path
        The KITTI calib file (``P2``) and the label file.

    Returns
    -------
    list of data_schema.scene.Track
    """
    from nvrq.sources.kitti import kitti_scene, read_calib_P2, read_labels

    scene = kitti_scene(read_calib_P2(calib_path), read_labels(labels_path), image_size=(1, 1), clip_id="x")
    return scene.tracks


@dataclass(frozen=True)
class StereoOptions:
    """How a pair is read (``nvrq import stereo``'s options, made once by the command or a caller).

    Attributes
    ----------
    calibration : path
        :func:`read_calibration`.
    baseline : float
        Metres between the cameras (> 0).
    disparity : path or None
        The objects-only disparity PNG of the left image (objects without ``labels``).
    labels : path or None
        KITTI ``label_2`` boxes (``calibration`` then is the KITTI calib file).
    label_class : str
        The class of the boxes found in the disparity.
    margin : float
        :data:`MARGIN_PX`.
    row_tolerance : float
        :data:`ROW_TOLERANCE_PX`.
    clip_id : str
        The scene's clip id.
    """

    calibration: str | os.PathLike
    baseline: float
    disparity: str | os.PathLike | None = None
    labels: str | os.PathLike | None = None
    label_class: str = UNKNOWN_CLASS
    margin: float = MARGIN_PX
    row_tolerance: float = ROW_TOLERANCE_PX
    clip_id: str = "stereo"


def read_stereo(left, right, options: StereoOptions):
    """Read and check a rectified pair; nothing written (module docstring).

    Parameters
    ----------
    left, right : path
        The rectified left (GT) and right (the ``real`` render) images.
    options : StereoOptions
        The calibration, baseline and the objects' source.

    Returns
    -------
    nvrq.sources.base.ImportedScene
        One camera, one frame, its tracks, the right image as the render at ``y = -baseline``.
    """
    from data_schema.methods import REAL_METHOD
    from data_schema.scene import CameraCalib
    from data_schema.scene_writer import NewScene, SceneFrame
    from nvrq.sources.base import ImportedScene

    o = options
    baseline = check_number("baseline", o.baseline, low=0, low_open=True)
    margin = check_number("margin", o.margin, low=0)
    calibration, disparity, labels = o.calibration, o.disparity, o.labels
    left, right = Path(left), Path(right)
    limg = _read_image(left, "the left image (JPEG or PNG)")
    rimg = _read_image(right, "the right image (JPEG or PNG)")
    H, W = limg.shape[:2]
    if rimg.shape[:2] != limg.shape[:2]:
        raise InputError(right, None, f"an image of the left image's size {W}x{H}",
                         f"{rimg.shape[1]}x{rimg.shape[0]}")
    intr = read_calibration(calibration)
    if (disparity is None) == (labels is None):
        raise InputError(param="disparity", expected="the objects' source: `disparity` (a PNG) or `labels` "
                         "(a KITTI label file), one of them", got="both" if labels is not None else "neither")
    disp = None if disparity is None else read_disparity(disparity, size=(W, H))
    dy, n = row_offset(limg, rimg)
    if not n or not dy <= o.row_tolerance:
        raise InputError(right, None, f"a rectified pair: matching points on the same rows (median |dy| <= "
                         f"{o.row_tolerance:g} px)", f"median |dy| {dy:.1f} px over {n} ORB matches")
    notes = [f"rows of {n} matching points differ by median {dy:.1f} px (tolerance {o.row_tolerance:g})"]
    if labels is not None:
        tracks = label_tracks(Path(calibration), Path(labels))
    else:
        objects = object_boxes(cluster_objects(disp, margin=margin), margin=margin, size=(W, H))
        inside = [o for o in objects if o.right_box[0] >= 0]
        if len(inside) < len(objects):
            notes.append(f"{len(objects) - len(inside)} of {len(objects)} objects leave the right image (dropped)")
        tracks = object_tracks(inside, intr, baseline, label_class=o.label_class)
    T = np.eye(4)
    T[:3, :3] = R_SENSOR_RIG
    model = {"type": "pinhole", "resolution": [W, H], "focal_length": [intr.fx, intr.fy],
             "principal_point": [intr.cx, intr.cy]}
    gt = f"images/left{left.suffix.lower()}"
    render = f"images/right{right.suffix.lower()}"
    scene = NewScene(o.clip_id, {CAMERA: CameraCalib(CAMERA, T, model)}, np.zeros(1, np.int64), np.eye(4)[None],
                     tracks, [SceneFrame(CAMERA, 0, gt, left)], {"source": "stereo"})
    return ImportedScene(scene, np.array([[0.0, -baseline, 0, 0, 0, 0]]), notes=tuple(notes),
                         detail=f"stereo, baseline {baseline:g} m", render_path=lambda camera, t, view: render,
                         method=REAL_METHOD, render_files={render: right})


class StereoImporter:
    """``nvrq import stereo LEFT RIGHT --calibration F --baseline B OUT``
    (:class:`nvrq.sources.base.Importer`)."""

    def read(self, path, *, right, **options):
        """Read the pair of the left image ``path`` and ``right`` (:func:`read_stereo`).

        Parameters
        ----------
        path : path
            The rectified left (GT) image.
        right : path
            The rectified right image (the ``real`` render).
        **options
            :class:`StereoOptions`' fields (``calibration`` and ``baseline`` at least).

        Returns
        -------
        nvrq.sources.base.ImportedScene
        """
        return read_stereo(path, right, StereoOptions(**options))


#: The importer of ``nvrq import stereo``.
IMPORTER = StereoImporter()
