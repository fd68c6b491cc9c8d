"""The tracks of a drivestudio scene: ``instances/instances_info.json`` + ``frame_instances.json``.

Conventions (drivestudio ``datasets/<d>/<d>_preprocess.py`` ``save_objects`` writes them,
``<d>_sourceloader.py`` ``load_objects`` reads them; see :mod:`nvrq.sources.drivestudio`):
``instances_info = {key: {id, class_name, frame_annotations: {frame_idx: [t], obj_to_world:
[4x4 box centre -> world], box_size: [[l, w, h]]}}}`` (extents along the box's own x, y, z,
metres) and ``frame_instances = {frame: [key, ...]}``. An annotation counts only where its frame
lists the object (the loader's ``per_frame_instance_mask``); an object gets the mean
``box_size`` of those frames; an object listed in no frame is dropped (``ins_frame_cnt > 0``).

Checks (each one line naming the file and field): JSON of the right shape, ``frame_instances``
naming only objects of ``instances_info`` and frames of the layout, a listed object annotated in
that frame, ``frame_idx`` distinct frames of the layout, rigid and finite ``obj_to_world`` with a
translation within :data:`MAX_TRANSLATION_M`, ``box_size`` 3 positive numbers of at most
:data:`MAX_BOX_SIZE_M`, ``id`` distinct, non-empty and without ``:`` (it is the scene's ``track_id``).
Everything after the per-object parsing is vectorised over all annotations.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from data_schema.errors import InputError
from data_schema.scene import check_rigid
from nvrq.geometry.poses import matrix_to_pose7

__all__ = ["read_instances", "check_translation", "RZ90", "MAX_TRANSLATION_M", "MAX_BOX_SIZE_M"]

#: The largest translation (metres, each of x, y, z) of a pose the importer accepts: a city-sized
#: world is kilometres across, so a larger value is a unit or export error.
MAX_TRANSLATION_M = 1e6
#: The largest box extent (metres) the importer accepts; the longest road vehicles are about 30 m.
MAX_BOX_SIZE_M = 1e3

#: A +90 deg turn about z (PandaSet's box x is across the object: ``obj_to_world @ RZ90``).
RZ90 = np.array([[0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def _json(path: Path):
    if not path.is_file():
        raise InputError(path, None, "a drivestudio instances file", "no such file")
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, None, "valid JSON", str(exc)) from None


def _listed(path: Path, frame_instances, index: dict, n_frames: int) -> np.ndarray:
    """Codes ``object_index * n_frames + frame`` of every (frame, object) ``frame_instances`` lists."""
    if not isinstance(frame_instances, dict):
        raise InputError(path, None, "an object {frame: [object keys]}", type(frame_instances).__name__)
    codes = []
    for f, objs in frame_instances.items():
        if not str(f).isdigit() or int(f) >= n_frames:
            raise InputError(path, f"frame {f!r}", f"a frame of the layout (0-{n_frames - 1})", f)
        if not isinstance(objs, list):
            raise InputError(path, f"frame {f}", "a list of object keys", type(objs).__name__)
        for k in objs:
            i = index.get(str(k))
            if i is None:
                raise InputError(path, f"frame {f}", "objects of instances_info.json", f"unknown object {k!r}")
            codes.append(i * n_frames + int(f))
    return np.unique(np.asarray(codes, np.int64))


def check_translation(T: np.ndarray, where, field_of: Callable[[int], str]) -> None:
    """Refuse a matrix with a non-finite entry or a translation beyond :data:`MAX_TRANSLATION_M`.

    Parameters
    ----------
    T : (N, 4, 4) numpy.ndarray
        The matrices.
    where : path or str
        The file named in the error.
    field_of : callable
        ``field_of(i)`` is the field (or row) the error names for matrix ``i``.

    Raises
    ------
    InputError
        The first bad matrix, with its values.

    >>> check_translation(np.eye(4)[None], "pose.txt", lambda i: "row 1")
    >>> T = np.eye(4)[None].copy(); T[0, 1, 3] = 1e308
    >>> check_translation(T, "pose.txt", lambda i: "row 2")
    Traceback (most recent call last):
    data_schema.errors.InputError: pose.txt: row 2: expected a translation of at most 1e+06 m in each of x, y, z, got 1e+308
    """
    flat = np.asarray(T, np.float64).reshape(-1, 4, 4)
    finite = np.isfinite(flat).all(axis=(1, 2))
    if not finite.all():
        i = int(np.argmin(finite))
        raise InputError(where, field_of(i), "finite numbers", "NaN or infinity")
    big = np.abs(flat[:, :3, 3]) > MAX_TRANSLATION_M
    if big.any():
        i = int(np.argmax(big.any(axis=1)))
        raise InputError(where, field_of(i), f"a translation of at most {MAX_TRANSLATION_M:g} m in each of x, y, z",
                         f"{np.abs(flat[i, :3, 3]).max():g}")


def _box_sizes(path: Path, fld: str, sizes: list) -> np.ndarray:
    """``box_size`` entries -> ``(n, 3)``; an error names the first that is not 3 positive numbers
    of at most :data:`MAX_BOX_SIZE_M`."""
    try:
        arr = np.asarray(sizes)
    except ValueError:  # ragged
        arr = np.zeros(0)
    if arr.ndim == 2 and arr.shape[1] == 3 and np.issubdtype(arr.dtype, np.number) \
            and np.isfinite(arr).all() and (arr > 0).all() and (arr <= MAX_BOX_SIZE_M).all():
        return arr.astype(np.float64)
    if not sizes:
        return np.zeros((0, 3))
    for i, s in enumerate(sizes):
        good = isinstance(s, list) and len(s) == 3 and all(
            isinstance(x, int | float) and not isinstance(x, bool) and np.isfinite(x) and 0 < x <= MAX_BOX_SIZE_M
            for x in s)
        if not good:
            raise InputError(path, f"{fld}.box_size[{i}]",
                             f"3 positive numbers [l, w, h] of at most {MAX_BOX_SIZE_M:g} m", s)
    return np.asarray(sizes, dtype=np.float64)  # e.g. a bool among the numbers


def _instance(path: Path, key: str, inst, n_frames: int) -> tuple:
    """One instance's ``(id, class_name, frames (n,), obj_to_world (n, 4, 4), box_size (n, 3))``, checked."""
    if not isinstance(inst, dict):
        raise InputError(path, key, "an object with id, class_name, frame_annotations", type(inst).__name__)
    for name in ("id", "class_name", "frame_annotations"):
        if name not in inst:
            raise InputError(path, f"{key}.{name}", "this field", "missing")
    tid, cls, ann = str(inst["id"]), inst["class_name"], inst["frame_annotations"]
    if not tid or ":" in tid:
        raise InputError(path, f"{key}.id", "a non-empty id without ':'", repr(tid))
    if not isinstance(cls, str) or not cls:
        raise InputError(path, f"{key}.class_name", "a class name", repr(cls))
    fld = f"{key}.frame_annotations"
    cols = {}
    for name in ("frame_idx", "obj_to_world", "box_size"):
        v = ann.get(name) if isinstance(ann, dict) else None
        if not isinstance(v, list):
            raise InputError(path, f"{fld}.{name}", "a list", type(v).__name__)
        cols[name] = v
    n = len(cols["frame_idx"])
    for name in ("obj_to_world", "box_size"):
        if len(cols[name]) != n:
            raise InputError(path, f"{fld}.{name}", f"{n} entries (one per frame_idx)", len(cols[name]))
    frames = np.asarray(cols["frame_idx"]).reshape(-1)
    if (n and not np.issubdtype(frames.dtype, np.integer)) or np.any(frames < 0) or np.any(frames >= n_frames) \
            or len(np.unique(frames)) != n:
        raise InputError(path, f"{fld}.frame_idx", f"distinct frames of the layout (0-{n_frames - 1})",
                         cols["frame_idx"])
    sizes = _box_sizes(path, fld, cols["box_size"])
    try:
        T = np.asarray(cols["obj_to_world"], dtype=np.float64) if n else np.zeros((0, 4, 4))
    except (TypeError, ValueError):
        T = None
    if T is None or T.shape != (n, 4, 4):
        raise InputError(path, f"{fld}.obj_to_world", "4x4 matrices of numbers",
                         "other values" if T is None else f"shape {T.shape}")
    return tid, cls, frames.astype(np.int64), T, sizes


def read_instances(folder: Path, *, n_frames: int, frame_us: np.ndarray, hold_us: int,
                   label_of: Callable[[str], str], turn_z90: bool = False) -> list[dict]:
    """scene.json tracks of ``folder`` (``instances/``), as the module docstring says.

    Parameters
    ----------
    folder : Path
        The ``instances/`` folder.
    n_frames : int
        Frames of the layout; ``frame_us (n_frames,)`` their timestamps (microseconds).
    hold_us : int
        When > 0, each track's last sample is repeated ``hold_us`` later (the latest camera).
    label_of : callable
        ``class_name`` -> ``label_class``.
    turn_z90 : bool
        PandaSet's boxes: ``T_box = obj_to_world @ RZ90`` and ``dims = [w, l, h]`` of the box_size.

    Returns
    -------
    list of dict
        ``{track_id, label_class, dims_lwh, timestamps_us, poses}`` per kept object.

    Raises
    ------
    InputError
        A check of the module docstring fails.
    """
    info_path, fi_path = folder / "instances_info.json", folder / "frame_instances.json"
    info, frame_instances = _json(info_path), _json(fi_path)
    if not isinstance(info, dict):
        raise InputError(info_path, None, "an object {key: instance}", type(info).__name__)
    keys = [str(k) for k in info]
    parsed = [_instance(info_path, k, v, n_frames) for k, v in zip(keys, info.values(), strict=True)]
    listed = _listed(fi_path, frame_instances, {k: i for i, k in enumerate(keys)}, n_frames)
    counts = np.array([len(p[2]) for p in parsed], np.int64)
    obj = np.repeat(np.arange(len(parsed)), counts)
    frames = np.concatenate([p[2] for p in parsed]) if parsed else np.zeros(0, np.int64)
    codes = obj * n_frames + frames
    missing = np.setdiff1d(listed, codes)
    if len(missing):  # listed in a frame the object has no annotation of
        k, f = divmod(int(missing[0]), n_frames)
        raise InputError(fi_path, f"frame {f}", f"objects annotated in that frame in {info_path.name}",
                         f"object {keys[k]!r}")
    T = np.concatenate([p[3] for p in parsed]) if parsed else np.zeros((0, 4, 4))
    where = [(k, j) for k, p in zip(keys, parsed, strict=True) for j in range(len(p[2]))]
    check_translation(T, info_path, lambda i: f"{where[i][0]}.frame_annotations.obj_to_world[{where[i][1]}]")
    try:
        check_rigid(T, str(info_path), "obj_to_world")
    except InputError:  # name the object and annotation
        for key, p in zip(keys, parsed, strict=True):
            check_rigid(p[3], str(info_path), f"{key}.frame_annotations.obj_to_world")
    sizes = np.concatenate([p[4] for p in parsed]) if parsed else np.zeros((0, 3))
    keep = np.isin(codes, listed)
    obj, frames, T, sizes = obj[keep], frames[keep], T[keep], sizes[keep]
    order = np.lexsort((frames, obj))
    obj, frames, T, sizes = obj[order], frames[order], T[order], sizes[order]
    n_kept = np.bincount(obj, minlength=len(parsed))
    dims = np.stack([np.bincount(obj, sizes[:, j], minlength=len(parsed)) for j in range(3)], axis=1) \
        / np.maximum(n_kept, 1)[:, None]
    if turn_z90:
        T, dims = T @ RZ90, dims[:, [1, 0, 2]]
    poses = matrix_to_pose7(T)
    ids = [p[0] for i, p in enumerate(parsed) if n_kept[i]]
    if len(set(ids)) != len(ids):
        dup = next(i for i in ids if ids.count(i) > 1)
        raise InputError(info_path, "id", "a distinct id per object", f"{dup!r} twice")
    starts = np.concatenate([[0], np.cumsum(n_kept)])
    tracks = []
    for i, p in enumerate(parsed):
        if not n_kept[i]:
            continue  # listed in no frame: drivestudio drops it too
        sl = slice(starts[i], starts[i + 1])
        ts, ps = frame_us[frames[sl]], poses[sl]
        if hold_us:  # every camera's image of the last frame shows the box
            ts, ps = np.append(ts, ts[-1] + hold_us), np.concatenate([ps, ps[-1:]])
        tracks.append({"track_id": p[0], "label_class": label_of(p[1]), "dims_lwh": dims[i].tolist(),
                       "timestamps_us": ts.tolist(), "poses": ps.tolist()})
    return tracks
