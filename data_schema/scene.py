"""The scene folder (docs/FORMATS.md §2): ``scene.json`` + ``images.csv`` + image files.

:func:`load_scene` reads and validates a scene into typed objects; every problem raises
:class:`~data_schema.errors.InputError` naming the file and the field, e.g.
``scene.json: cameras.front.T_sensor_rig: expected a 4x4 matrix, got 3x4``.
:func:`save_scene` writes one (atomically), used by ``nvrq synth`` and the importers.

Convention: ``T_a_b`` maps frame ``a`` to frame ``b``; poses are ``[x, y, z, qx, qy, qz, qw]``;
timestamps are integer microseconds.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.images import check_image
from data_schema.methods import METHOD_COLUMN, check_table_methods, method_columns, method_values
from data_schema.perturbation import (
    EXTRA_PERTURBATION_COLUMNS,
    PERTURBATION_COLUMNS,
    is_lateral,
    perturbation_array,
)
from data_schema.tables import (
    IMAGES_COLUMNS,
    atomic_write_text,
    inside_scene,
    require_columns,
    write_table,
)

__all__ = [
    "IMPORT_STAGING",
    "CAMERA_MODEL_SCHEMA",
    "CameraCalib",
    "Track",
    "SourceWorld",
    "Scene",
    "load_scene",
    "scene_parts",
    "check_images_table",
    "save_scene",
    "write_images",
    "validate_camera_model",
    "check_rigid",
]

FORMAT = "nvrq-scene"
VERSION = 1
ROT_TOL = 1e-6

#: Parameters of each camera model: name -> (length or 0 for a scalar, default or None if required).
CAMERA_MODEL_SCHEMA: dict[str, dict[str, tuple[int, object]]] = {
    "pinhole": {
        "resolution": (2, None), "focal_length": (2, None), "principal_point": (2, None),
    },
    "opencv_pinhole": {
        "resolution": (2, None), "focal_length": (2, None), "principal_point": (2, None),
        "radial_coeffs": (6, [0.0] * 6), "tangential_coeffs": (2, [0.0] * 2),
        "thin_prism_coeffs": (4, [0.0] * 4),
    },
    "opencv_fisheye": {
        "resolution": (2, None), "focal_length": (2, None), "principal_point": (2, None),
        "radial_coeffs": (4, [0.0] * 4),
    },
    "ftheta": {
        "resolution": (2, None), "principal_point": (2, None), "reference_poly": (0, None),
        "pixeldist_to_angle_poly": (6, None), "angle_to_pixeldist_poly": (6, None),
        "max_angle": (0, None), "linear_cde": (3, [1.0, 0.0, 0.0]),
    },
}
FTHETA_REFERENCE_POLYS = ("PIXELDIST_TO_ANGLE", "ANGLE_TO_PIXELDIST")


@dataclass(frozen=True)
class CameraCalib:
    """A camera: ``T_sensor_rig: (4, 4)`` and its validated ``model`` dict (docs/FORMATS.md §2).

    Attributes
    ----------
    name : str
        The camera's name.
    T_sensor_rig : (4, 4) float64 ndarray
        Rigid transform from the sensor frame to the rig frame.
    model : dict
        The camera model, checked by :func:`validate_camera_model` (defaults filled).
    """

    name: str
    T_sensor_rig: np.ndarray
    model: dict


@dataclass(frozen=True)
class Track:
    """One object's 3D box track: ``timestamps_us: (T,)`` int64, ``poses: (T, 7)`` world box
    centres.

    Attributes
    ----------
    track_id : str
        The track's unique id.
    label_class : str
        The object's class.
    dims_lwh : (3,) float64 ndarray
        Box length, width, height (positive).
    timestamps_us : (T,) int64 ndarray
        Timestamps of the poses, in microseconds.
    poses : (T, 7) float64 ndarray
        World box poses ``[x, y, z, qx, qy, qz, qw]`` (unit quaternions), one per timestamp.
    source_visibility : tuple of str, optional
        The dataset's own visibility label of each sample (docs/FORMATS.md §2), e.g. KITTI's
        ``occluded=1 truncated=0.00``; None when the source has none.
    """

    track_id: str
    label_class: str
    dims_lwh: np.ndarray
    timestamps_us: np.ndarray
    poses: np.ndarray
    source_visibility: tuple | None = None


@dataclass(frozen=True)
class SourceWorld:
    """The optional ``source_world`` of scene.json (docs/FORMATS.md §2): the world of the tool a
    scene was imported from. ``T_world_source: (4, 4)`` maps points of the scene's world into
    that tool's world (e.g. drivestudio's world re-based on the first ego pose).

    Attributes
    ----------
    name : str
        The source tool's name.
    dataset : str
        The source dataset.
    T_world_source : (4, 4) float64 ndarray
        Maps points of the scene's world into the source tool's world.
    """

    name: str
    dataset: str
    T_world_source: np.ndarray


@dataclass
class Scene:
    """A validated scene folder. ``T_rig_world: (F, 4, 4)`` at ``rig_timestamps_us: (F,)``;
    ``source_world`` when the scene was imported from a tool with its own world (else None).

    Attributes
    ----------
    root : Path
        The scene folder.
    clip_id : str
        The scene's clip id.
    attributes : dict of str to str
        The scene's free-form attributes.
    cameras : dict of str to CameraCalib
        The cameras by name.
    rig_timestamps_us : (F,) int64 ndarray
        Timestamps of the rig poses, in microseconds.
    T_rig_world : (F, 4, 4) float64 ndarray
        Rig-to-world transform at each timestamp.
    tracks : list of Track
        The objects' 3D box tracks.
    images : pandas.DataFrame
        The checked ``images.csv`` table.
    source_world : SourceWorld or None
        The world of the tool the scene was imported from, if any.
    """

    root: Path
    clip_id: str
    attributes: dict[str, str]
    cameras: dict[str, CameraCalib]
    rig_timestamps_us: np.ndarray
    T_rig_world: np.ndarray
    tracks: list[Track]
    images: pd.DataFrame = field(repr=False)
    source_world: SourceWorld | None = None


def _get(obj: dict, key: str, where: str, prefix: str):
    if not isinstance(obj, dict):
        raise InputError(where, prefix or "top level", "a JSON object", type(obj).__name__)
    if key not in obj:
        raise InputError(where, f"{prefix}.{key}" if prefix else key, "this key to be present", "missing")
    return obj[key]


def _array(value, shape: tuple, where: str, fld: str, what: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(where, fld, what, "non-numeric or ragged values") from None
    if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape, strict=False)):
        raise InputError(where, fld, what, "shape " + "x".join(map(str, arr.shape)) if arr.ndim else "a scalar")
    if not np.all(np.isfinite(arr)):
        raise InputError(where, fld, what + " of finite numbers", "NaN or infinity")
    return arr


def check_rigid(T: np.ndarray, where: str, fld: str) -> np.ndarray:
    """Check ``T: (..., 4, 4)``: orthonormal rotation with det +1 (tol 1e-6), bottom row 0 0 0 1.

    Parameters
    ----------
    T : (..., 4, 4) array-like
        The matrix or stack of matrices to check.
    where : str
        The file named in errors.
    fld : str
        The field named in errors (``fld[i]`` for the i-th of a stack).

    Returns
    -------
    (..., 4, 4) float64 ndarray
        ``T`` as an array.
    """
    T = _array(T, (None,) * (np.ndim(T) - 2) + (4, 4), where, fld, "4x4 matrices") if np.ndim(T) > 2 \
        else _array(T, (4, 4), where, fld, "a 4x4 matrix")
    flat = T.reshape(-1, 4, 4)
    bottom_bad = np.any(np.abs(flat[:, 3] - [0, 0, 0, 1]) > 0, axis=-1)
    R = flat[:, :3, :3]
    ortho_err = np.abs(R @ np.swapaxes(R, -1, -2) - np.eye(3)).max(axis=(-1, -2))
    det_bad = np.linalg.det(R) < 0
    for bad, expected in ((bottom_bad, "a bottom row of 0 0 0 1"),
                          ((ortho_err > ROT_TOL) | det_bad, f"an orthonormal rotation (tolerance {ROT_TOL:g})")):
        if bad.any():
            i = int(np.argmax(bad))
            sub = f"{fld}[{i}]" if T.ndim > 2 else fld
            got = flat[i, 3].tolist() if expected.startswith("a bottom") else f"max |R R^T - I| = {ortho_err[i]:.3g}"
            raise InputError(where, sub, expected, got)
    return T


def _sub(fld: str, name: str) -> str:
    return f"{fld}.{name}" if fld else name


def validate_camera_model(model, where: str, fld: str) -> dict:
    """Check a ``model`` dict against :data:`CAMERA_MODEL_SCHEMA`; return it with defaults filled.

    The one check of parameter names, lengths, finiteness and defaults (the camera classes of
    ``nvrq.geometry.cameras`` call it and add checks on values). Errors name ``fld.param``
    (just ``param`` when ``fld`` is empty).

    Parameters
    ----------
    model : dict
        The camera model (``type`` and its parameters).
    where : str
        The file named in errors.
    fld : str
        The field prefix named in errors (may be empty).

    Returns
    -------
    dict
        The checked model, defaults filled.
    """
    mtype = _get(model, "type", where, fld)
    if mtype not in CAMERA_MODEL_SCHEMA:
        raise InputError(where, _sub(fld, "type"), "one of {" + ", ".join(map(repr, CAMERA_MODEL_SCHEMA)) + "}",
                         repr(mtype))
    out = {"type": mtype}
    for name, (length, default) in CAMERA_MODEL_SCHEMA[mtype].items():
        if name not in model:
            if default is None:
                raise InputError(where, _sub(fld, name), f"this {mtype} parameter to be present", "missing")
            out[name] = list(default)
            continue
        value = model[name]
        if name == "reference_poly":
            if value not in FTHETA_REFERENCE_POLYS:
                raise InputError(where, _sub(fld, name), "one of " + " or ".join(FTHETA_REFERENCE_POLYS), repr(value))
            out[name] = value
        elif length == 0:
            out[name] = float(_array(value, (), where, _sub(fld, name), "a number"))
        else:
            arr = _array(value, (length,), where, _sub(fld, name), f"a list of {length} numbers")
            if name == "resolution":
                if np.any(arr <= 0) or np.any(arr != np.round(arr)):
                    raise InputError(where, _sub(fld, name), "two positive integers [W, H]", arr.tolist())
                out[name] = [int(v) for v in arr]
            else:
                out[name] = arr.tolist()
    if mtype == "ftheta" and not 0 < out["max_angle"] <= math.pi:
        raise InputError(where, _sub(fld, "max_angle"), "an angle in (0, pi] radians", out["max_angle"])
    return out


def _timestamps(value, where: str, fld: str) -> np.ndarray:
    arr = _array(value, (None,), where, fld, "a list of integer microseconds")
    if len(arr) == 0:
        raise InputError(where, fld, "at least one timestamp", "an empty list")
    if np.any(arr != np.round(arr)):
        raise InputError(where, fld, "integer microseconds", "fractional values")
    if np.any(np.diff(arr) <= 0):
        i = int(np.argmax(np.diff(arr) <= 0)) + 1
        raise InputError(where, f"{fld}[{i}]", "strictly increasing timestamps", f"{arr[i]:.0f} after {arr[i-1]:.0f}")
    return arr.astype(np.int64)


def _poses7(value, n: int, where: str, fld: str) -> np.ndarray:
    if not isinstance(value, list) or len(value) != n:
        raise InputError(where, fld, f"{n} poses (one per timestamp)", f"{len(value) if isinstance(value, list) else type(value).__name__}")
    for i, p in enumerate(value):
        if not isinstance(p, list) or len(p) != 7:
            raise InputError(where, f"{fld}[{i}]", "7 numbers [x, y, z, qx, qy, qz, qw]",
                             f"{len(p) if isinstance(p, list) else type(p).__name__}")
    poses = _array(value, (n, 7), where, fld, "poses of 7 numbers")
    norms = np.linalg.norm(poses[:, 3:], axis=1)
    if np.any(norms < 1e-6):
        i = int(np.argmax(norms < 1e-6))
        raise InputError(where, f"{fld}[{i}]", "a quaternion of non-zero norm", f"norm {norms[i]:.3g}")
    poses = poses.copy()
    poses[:, 3:] /= norms[:, None]
    return poses


def _resolve_image(root: Path, rel: str, where: str, fld: str, check: bool, linked: dict,
                   follow: bool | None) -> None:
    # the path rule shared with pairs tables; ``linked`` is this load's folder cache
    inside_scene(root, rel, where=where, field=fld, linked=linked, follow=follow)
    if check and not (root / rel).is_file():
        raise InputError(where, fld, "an existing image file", f"{rel} (not found)")


def _load_images(root: Path, cameras: dict, check_images: bool, follow: bool | None) -> pd.DataFrame:
    path = root / "images.csv"
    where = str(path)
    if not path.is_file():
        raise InputError(where, None, "an images.csv file in the scene folder", "no such file")
    return _read_images(path, root, cameras, check_images, follow, where)


def _read_images(source, root: Path, cameras: dict, check_images: bool, follow: bool | None,
                 where: str) -> pd.DataFrame:
    """Read and check an images.csv (a path or a text buffer) as :func:`load_scene` does."""
    try:
        df = pd.read_csv(source, dtype={"camera": str, "source": str, "path": str, METHOD_COLUMN: str})
    except pd.errors.EmptyDataError:
        raise InputError(where, None, "a header row " + ",".join(IMAGES_COLUMNS), "an empty file") from None
    require_columns(df, IMAGES_COLUMNS, where=where)
    for col in ("timestamp_us", *PERTURBATION_COLUMNS):
        if col not in df.columns:  # an optional perturbation column: 0 (lateral-only scene)
            df[col] = 0.0
        num = pd.to_numeric(df[col], errors="coerce")
        bad = num.isna() | ~np.isfinite(num.to_numpy(np.float64, na_value=np.nan))
        if bad.any():
            i = int(np.argmax(bad.to_numpy()))
            raise InputError(where, f"row {i + 2}, column {col}", "a number", repr(df[col].iloc[i]))
        df[col] = num
    df["timestamp_us"] = df["timestamp_us"].astype(np.int64)
    df[list(PERTURBATION_COLUMNS)] = df[list(PERTURBATION_COLUMNS)].astype(np.float64)
    gt_moved = (df["source"] == "gt").to_numpy() & (df[list(EXTRA_PERTURBATION_COLUMNS)] != 0).any(axis=1).to_numpy()
    if gt_moved.any():
        i = int(np.argmax(gt_moved))
        raise InputError(where, f"row {i + 2}", "zero perturbation columns for a gt image", "non-zero")
    linked = {}
    for i, row in enumerate(df.itertuples(index=False)):
        r = f"row {i + 2}"
        if row.camera not in cameras:
            raise InputError(where, f"{r}, column camera", "a camera of scene.json (" + ", ".join(cameras) + ")",
                             repr(row.camera))
        if row.source not in ("gt", "render"):
            raise InputError(where, f"{r}, column source", "'gt' or 'render'", repr(row.source))
        if row.source == "gt" and row.y_offset_m != 0:
            raise InputError(where, f"{r}, column y_offset_m", "0 for a gt image", row.y_offset_m)
        _resolve_image(root, row.path, where, f"{r}, column path", check_images, linked, follow)
    methods = _method_column(df, where)
    dup = df.duplicated(["camera", "timestamp_us", "source", *PERTURBATION_COLUMNS, *methods])
    if dup.any():
        i = int(np.argmax(dup.to_numpy()))
        key = "(camera, timestamp_us, source, perturbation" + (", method)" if methods else ")")
        raise InputError(where, f"row {i + 2}", f"one image per {key}", "a duplicate")
    if check_images:
        _check_image_headers(df, root, cameras, where)
    return df.loc[:, [*IMAGES_COLUMNS, *EXTRA_PERTURBATION_COLUMNS, *methods]]


def _check_image_headers(df: pd.DataFrame, root: Path, cameras: dict, where: str) -> None:
    """Every image of ``df`` a readable image of its camera's resolution, from its header
    (:func:`data_schema.images.check_image`: no pixel decoded); one error names every bad one,
    with their count."""
    bad = []
    for i, (cam, rel) in enumerate(zip(df["camera"], df["path"], strict=True)):
        W, H = cameras[cam].model["resolution"]
        try:
            check_image(root / rel, size=(W, H), of=f"camera {cam}")
        except InputError as exc:
            why = str(exc.got) if exc.expected == "a readable image file" else f"{exc.expected}, got {exc.got}"
            bad.append(f"row {i + 2} {rel}: {why}")
    if bad:
        raise InputError(where, f"column path ({'; '.join(bad)})", "readable images of their camera's resolution",
                         f"{len(bad)} bad image file{'s' if len(bad) != 1 else ''} of {len(df)}")


def _method_column(df: pd.DataFrame, where: str) -> list[str]:
    """The optional ``method`` column (docs/FORMATS.md §2): ``[METHOD_COLUMN]`` when some render
    names a method (then every render names a valid one and no GT row does; the column is
    normalised to str), ``[]`` otherwise (a single-method scene, the column dropped)."""
    if not method_columns(df):
        return []
    df[METHOD_COLUMN] = method_values(df)
    check_table_methods(df, where=where)
    render = (df["source"] == "render").to_numpy()
    named = (df[METHOD_COLUMN] != "").to_numpy()
    for bad, expected in ((~render & named, "an empty method for a gt image (shared by every method)"),
                          (render & ~named, "a method name for every render (other renders name one)")):
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(where, f"row {i + 2}, column {METHOD_COLUMN}", expected,
                             repr(df[METHOD_COLUMN].iloc[i]))
    return [METHOD_COLUMN]


def _cameras(doc: dict, where: str) -> dict:
    """scene.json's ``cameras``, checked: name -> :class:`CameraCalib`."""
    cams_doc = _get(doc, "cameras", where, "")
    if not isinstance(cams_doc, dict) or not cams_doc:
        raise InputError(where, "cameras", "a non-empty object of cameras", repr(cams_doc))
    cameras = {}
    for name, cam in cams_doc.items():
        fld = f"cameras.{name}"
        T = check_rigid(_get(cam, "T_sensor_rig", where, fld), where, f"{fld}.T_sensor_rig")
        model = validate_camera_model(_get(cam, "model", where, fld), where, f"{fld}.model")
        cameras[name] = CameraCalib(name, T, model)
    return cameras


def _tracks(doc: dict, where: str) -> list[Track]:
    """scene.json's ``tracks``, checked: unique ids, a class, positive sizes, poses per timestamp."""
    tracks_doc = _get(doc, "tracks", where, "")
    if not isinstance(tracks_doc, list):
        raise InputError(where, "tracks", "a list of tracks", type(tracks_doc).__name__)
    tracks, seen = [], set()
    for i, tr in enumerate(tracks_doc):
        fld = f"tracks[{i}]"
        tid = str(_get(tr, "track_id", where, fld))
        if not tid or ":" in tid or tid in seen:
            raise InputError(where, f"{fld}.track_id", "a unique non-empty id without ':'", repr(tid))
        seen.add(tid)
        label = _get(tr, "label_class", where, fld)
        if not isinstance(label, str) or not label:
            raise InputError(where, f"{fld}.label_class", "a class name", repr(label))
        dims = _array(_get(tr, "dims_lwh", where, fld), (3,), where, f"{fld}.dims_lwh", "3 numbers [l, w, h]")
        if np.any(dims <= 0):
            raise InputError(where, f"{fld}.dims_lwh", "positive dimensions", dims.tolist())
        ts = _timestamps(_get(tr, "timestamps_us", where, fld), where, f"{fld}.timestamps_us")
        poses = _poses7(_get(tr, "poses", where, fld), len(ts), where, f"{fld}.poses")
        vis = tr.get("source_visibility")
        if vis is not None and (not isinstance(vis, list) or len(vis) != len(ts)
                                or not all(isinstance(v, str) for v in vis)):
            raise InputError(where, f"{fld}.source_visibility", f"a list of {len(ts)} strings (one per timestamp)",
                             repr(vis)[:60])
        tracks.append(Track(tid, label, dims, ts, poses, None if vis is None else tuple(vis)))
    return tracks


#: The folder inside a scene where ``nvrq import renders`` stages its files; a ``journal.json``
#: in it marks an import interrupted while it swapped them in (nvrq.sources.render_swap).
IMPORT_STAGING = ".nvrq-import"


def load_scene(root: str | os.PathLike, *, check_images: bool = True,
               follow_links: bool | None = None) -> Scene:
    """Load and validate the scene folder ``root`` (docs/FORMATS.md §2).

    ``check_images=False`` accepts an ``images.csv`` whose files do not exist yet (a scene
    imported for rendering); path safety is checked either way. ``follow_links``: whether image
    paths may lead out of the scene through symbolic links (default: yes, unless
    ``$NVRQ_NO_FOLLOW_LINKS`` is set; docs/FORMATS.md §7, :func:`data_schema.tables.inside_scene`).

    Parameters
    ----------
    root : str or path-like
        The scene folder.
    check_images : bool
        Whether the listed image files must exist.
    follow_links : bool or None
        Whether image paths may lead out of the scene through symbolic links; None: the default.

    Returns
    -------
    Scene
        The validated scene.
    """
    root = Path(root)
    path = root / "scene.json"
    where = str(path)
    if not root.is_dir():
        raise InputError(root, None, "a scene folder", "no such directory")
    if not path.is_file():
        raise InputError(where, None, "a scene.json file in the scene folder", "no such file")
    if (root / IMPORT_STAGING / "journal.json").is_file():
        raise InputError(root, None, "a scene without an unfinished `nvrq import renders` (run the same import "
                         "again: it finishes the interrupted one first)",
                         f"an import interrupted while it swapped its files in ({IMPORT_STAGING}/journal.json)")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(where, None, "valid JSON", str(exc)) from None
    parts = scene_parts(doc, where)
    images = _load_images(root, parts["cameras"], check_images, follow_links)
    return Scene(root, images=images, **parts)


def _check_header(doc, where: str) -> None:
    fmt = _get(doc, "format", where, "")
    if fmt != FORMAT:
        raise InputError(where, "format", repr(FORMAT), repr(fmt))
    version = _get(doc, "version", where, "")
    if version != VERSION:
        raise InputError(where, "version", str(VERSION), repr(version))


def scene_parts(doc, where: str) -> dict:
    """Check a parsed ``scene.json`` (docs/FORMATS.md §2) and return its typed parts.

    Parameters
    ----------
    doc : dict
        The parsed JSON document (``format`` and ``version`` included).
    where : str
        The file named in errors.

    Returns
    -------
    dict
        The :class:`Scene` fields but ``root`` and ``images``: ``clip_id``, ``attributes``,
        ``cameras``, ``rig_timestamps_us (F,)``, ``T_rig_world (F, 4, 4)``, ``tracks``,
        ``source_world``.

    Raises
    ------
    InputError
        The first field that breaks the format, named.
    """
    _check_header(doc, where)
    clip_id = str(_get(doc, "clip_id", where, ""))
    if not clip_id or ":" in clip_id:
        raise InputError(where, "clip_id", "a non-empty string without ':'", repr(clip_id))
    attributes = doc.get("attributes", {})
    if not isinstance(attributes, dict) or not all(isinstance(v, str) for v in attributes.values()):
        raise InputError(where, "attributes", "an object of string labels", repr(attributes))
    cameras = _cameras(doc, where)
    traj = _get(doc, "rig_trajectory", where, "")
    rig_ts = _timestamps(_get(traj, "timestamps_us", where, "rig_trajectory"), where, "rig_trajectory.timestamps_us")
    T_rw_raw = _get(traj, "T_rig_world", where, "rig_trajectory")
    T_rw = _array(T_rw_raw, (len(rig_ts), 4, 4), where, "rig_trajectory.T_rig_world",
                  f"{len(rig_ts)} 4x4 matrices (one per timestamp)")
    T_rw = check_rigid(T_rw, where, "rig_trajectory.T_rig_world")
    return dict(clip_id=clip_id, attributes={k: str(v) for k, v in attributes.items()}, cameras=cameras,
                rig_timestamps_us=rig_ts, T_rig_world=T_rw, tracks=_tracks(doc, where),
                source_world=_source_world(doc.get("source_world"), where))


def check_images_table(images: pd.DataFrame, root, cameras: dict, *, where: str) -> pd.DataFrame:
    """Check an images table as :func:`load_scene` checks ``images.csv`` (files need not exist).

    Parameters
    ----------
    images : pandas.DataFrame
        The rows, as :func:`write_images` would write them.
    root : str or os.PathLike
        The scene folder the paths are relative to.
    cameras : dict
        The scene's cameras (names are what matters).
    where : str
        The file named in errors.

    Returns
    -------
    pandas.DataFrame
        The rows as :func:`load_scene` reads them back.
    """
    import io

    buf = io.StringIO()
    extra = [c for c in EXTRA_PERTURBATION_COLUMNS if c in images.columns]
    images.loc[:, [c for c in (*IMAGES_COLUMNS, *extra, *method_columns(images)) if c in images.columns]] \
        .to_csv(buf, index=False)
    buf.seek(0)
    return _read_images(buf, Path(root), cameras, False, None, where)


def _source_world(value, where: str) -> SourceWorld | None:
    """The optional ``source_world`` key: ``{"name", "dataset", "T_world_source": rigid 4x4}``."""
    if value is None:
        return None
    for key in ("name", "dataset"):
        v = _get(value, key, where, "source_world")
        if not isinstance(v, str) or (key == "name" and not v):
            raise InputError(where, f"source_world.{key}", "a " + ("non-empty " if key == "name" else "") + "string",
                             repr(v))
    T = check_rigid(_get(value, "T_world_source", where, "source_world"), where, "source_world.T_world_source")
    return SourceWorld(value["name"], value["dataset"], T)


def _jsonable(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def save_scene(scene_doc: dict, images: pd.DataFrame, root: str | os.PathLike) -> Path:
    """Write ``scene_doc`` (the docs/FORMATS.md §2 dict; numpy arrays allowed) and ``images``.

    ``format`` and ``version`` are filled in when absent. Both files are written atomically.

    Parameters
    ----------
    scene_doc : dict
        The scene.json content.
    images : pandas.DataFrame
        The images.csv rows (:data:`data_schema.tables.IMAGES_COLUMNS`, then the optional
        perturbation and method columns, written only when used).
    root : str or os.PathLike
        The scene folder (created when missing).

    Returns
    -------
    pathlib.Path
        ``root``.

    Raises
    ------
    InputError
        ``images`` lacks a column of :data:`~data_schema.tables.IMAGES_COLUMNS`, or a file
        cannot be written.
    """
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    doc = {"format": FORMAT, "version": VERSION, **scene_doc}
    write_images(images, root)
    atomic_write_text(root / "scene.json", json.dumps(doc, indent=1, default=_jsonable) + "\n")
    return root


def write_images(images: pd.DataFrame, root: str | os.PathLike) -> Path:
    """Write ``images`` as ``root/images.csv`` (docs/FORMATS.md §2), atomically.

    Parameters
    ----------
    images : DataFrame
        The rows; written are the contract columns, then the optional perturbation columns
        (§9) it has when some view is not lateral, then ``method`` when some row names one.
    root : path
        The scene folder.

    Returns
    -------
    Path
        ``root / "images.csv"``.

    Raises
    ------
    InputError
        ``images`` lacks a column of :data:`~data_schema.tables.IMAGES_COLUMNS`, or the file
        cannot be written.
    """
    require_columns(images, IMAGES_COLUMNS, where=Path(root) / "images.csv")
    extra = [c for c in EXTRA_PERTURBATION_COLUMNS if c in images.columns]  # written only when used
    if is_lateral(perturbation_array(images)).all():
        extra = []
    path = Path(root) / "images.csv"
    write_table(images, path, columns=(*IMAGES_COLUMNS, *extra, *method_columns(images)))
    return path
