"""NTA-IoU of a scene folder: every box projected into every render's camera, matched to the
render's detections (library layer; ``nvrq proxy nta-iou``, docs/FORMATS.md §3b).

The projection is ``nvrq pairs``' (:mod:`nvrq.scene_boxes`, which :mod:`nvrq.pairs` uses too:
the same box corners, rig poses and view perturbations), applied to the novel view alone. The
matching and the protocols are :mod:`nvrq.proxies.nta_iou`.
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN, method_values
from data_schema.perturbation import (
    EXTRA_PERTURBATION_COLUMNS,
    LABEL_COLUMN,
    PERTURBATION_COLUMNS,
    labels,
    perturbation_array,
)
from data_schema.scene import Scene
from data_schema.tables import pair_ids
from nvrq.proxies.detection import check_pixel_boxes
from nvrq.proxies.nta_iou import NTA_COLUMNS, SUMMARY_COLUMNS, Protocol, cluster_mean_ci, evaluate

__all__ = ["novel_boxes", "nta_table", "nta_summary", "check_detection_paths"]

VIEW_COLUMNS = ["y_offset_m", *EXTRA_PERTURBATION_COLUMNS, LABEL_COLUMN]


def _corners_in_views(scene: Scene, cam, renders: pd.DataFrame):
    """Sensor-frame corners ``(C, 8, 3)`` of every (render row, box of its frame) candidate and
    ``(row_index, track_index)`` of each (the boxes, views and transforms of :mod:`nvrq.scene_boxes`)."""
    from nvrq.scene_boxes import frame_boxes, frame_candidates, render_views, view_transforms

    frames = np.unique(renders.timestamp_us.to_numpy(np.int64))
    views, r_k = render_views(renders)
    fb = frame_boxes(scene, frames)
    row_idx, box_idx = frame_candidates(renders, frames, fb.frame_index)
    T_gt_world, T_view_gt = view_transforms(cam.T_sensor_rig, fb.T_rig_world, views)
    T = T_view_gt[r_k[row_idx]] @ T_gt_world[fb.frame_index[box_idx]]  # (C, 4, 4) world -> novel sensor
    pts = np.matmul(fb.corners[box_idx], np.swapaxes(T[:, :3, :3], 1, 2)) + T[:, None, :3, 3]
    return pts, row_idx, fb.track_index[box_idx]


def _project(model, pts: np.ndarray, protocol: Protocol) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-edge boxes ``(C, 4)`` of sensor-frame corners ``(C, 8, 3)`` and which are usable."""
    uv, ok = model.project(pts)
    front = pts[..., 2] > 0
    if protocol.behind == "all" and getattr(model, "type_name", "") == "pinhole":
        # DriveDreamer4D divides every corner by its depth, those behind the camera too
        (fx, fy), (cx, cy) = model.focal_length, model.principal_point
        with np.errstate(all="ignore"):
            uv = np.stack([fx * pts[..., 0] / pts[..., 2] + cx, fy * pts[..., 1] / pts[..., 2] + cy], axis=-1)
        usable = front.any(axis=-1) & np.isfinite(uv).all(axis=(-1, -2))
    else:
        usable = ok.all(axis=-1)
    uv = np.where(usable[:, None, None], uv, 0.0) + 0.5  # pixel index -> pixel edge
    return np.concatenate([uv.min(axis=1), uv.max(axis=1)], axis=1), usable


def novel_boxes(scene: Scene, protocol: Protocol) -> pd.DataFrame:
    """Every box of ``scene`` projected into every render's camera (before the protocol's rules).

    Parameters
    ----------
    scene : Scene
    protocol : Protocol
        Says which corners behind the camera a box may have.

    Returns
    -------
    pandas.DataFrame
        One row per (render image, box of its frame) with a usable projection: ``clip_id,
        camera, timestamp_us, track_id, label_class, render_path``, the view columns, ``method``
        (``''`` without methods), ``image_w, image_h`` and the pixel-edge box ``b_x0..b_y1``.
    """
    from nvrq.geometry.cameras import camera_from_model

    out = []
    for cam in scene.cameras.values():
        rows = scene.images[scene.images.camera == cam.name]
        renders = rows[rows.source == "render"]
        if renders.empty:
            continue
        model = camera_from_model(cam.model, where=str(scene.root / "scene.json"),
                                  field_prefix=f"cameras.{cam.name}.model.")
        pts, row_idx, tr = _corners_in_views(scene, cam, renders)
        box, usable = _project(model, pts, protocol)
        r = renders.iloc[row_idx[usable]]
        P = perturbation_array(r)
        df = pd.DataFrame({"clip_id": scene.clip_id, "camera": cam.name,
                           "timestamp_us": r.timestamp_us.to_numpy(np.int64),
                           "track_id": np.array([scene.tracks[k].track_id for k in tr[usable]], dtype=object),
                           "label_class": np.array([scene.tracks[k].label_class for k in tr[usable]], dtype=object),
                           "render_path": r.path.astype(str).map(os.path.normpath).to_numpy(dtype=object)})
        for c in PERTURBATION_COLUMNS:
            df[c] = P[:, PERTURBATION_COLUMNS.index(c)]
        df[LABEL_COLUMN] = labels(P)
        df[METHOD_COLUMN] = method_values(r)
        w, h = model.resolution
        df["image_w"], df["image_h"] = float(w), float(h)
        for k, name in enumerate(("b_x0", "b_y0", "b_x1", "b_y1")):
            df[name] = box[usable, k]
        out.append(df)
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame()


def check_detection_paths(scene: Scene, dets: pd.DataFrame, *, where: str) -> np.ndarray:
    """Each detection's path as the scene's relative image path; :class:`InputError` naming the
    first DETS row whose path is not an image of ``scene`` (relative, or absolute inside it).

    Parameters
    ----------
    scene : Scene
        The scene the detections belong to.
    dets : pandas.DataFrame
        A DETS table with a ``path`` column.
    where : str
        What errors name (the DETS table).

    Returns
    -------
    (N,) object numpy.ndarray of str
        Each detection's image path relative to the scene root, as in ``images.csv``.
    """
    root = os.path.normpath(str(scene.root.resolve()))
    known = set(scene.images.path.astype(str).map(os.path.normpath))
    paths = dets["path"].astype(str).to_numpy(dtype=object)
    uniq, inv = np.unique(paths, return_inverse=True)
    rel = np.array([os.path.relpath(p, root) if os.path.isabs(p) else os.path.normpath(p) for p in uniq],
                   dtype=object)
    bad = np.array([p not in known for p in rel], bool)
    if bad.any():
        i = int(np.flatnonzero(bad[inv])[0])
        raise InputError(where, f"row {i + 2}, column path", f"an image of the scene {scene.root} (as in images.csv)",
                         paths[i])
    return rel[inv]


def _image_sizes(scene: Scene, rel: np.ndarray) -> np.ndarray:
    """``(N, 2)`` camera resolution ``(W, H)`` of each image path ``rel`` (paths of ``images.csv``)."""
    camera_of = dict(zip(scene.images.path.astype(str).map(os.path.normpath), scene.images.camera, strict=True))
    res = {name: tuple(cam.model["resolution"]) for name, cam in scene.cameras.items()}
    uniq, inv = np.unique(np.asarray(rel, dtype=object).astype(str), return_inverse=True)
    return np.array([res[camera_of[p]] for p in uniq], np.float64).reshape(-1, 2)[inv]


def nta_table(scene: Scene, dets: pd.DataFrame, protocol: Protocol, *, class_map: dict | None = None,
              min_side: float = 1.0, where: str = "detections") -> pd.DataFrame:
    """The per-box NTA-IoU table of ``scene`` against a validated DETS table.

    Parameters
    ----------
    scene : Scene
    dets : pandas.DataFrame
        A validated DETS table (:func:`nvrq.proxies.detection.validate_detections`).
    protocol : Protocol
    class_map : dict, optional
        label_class -> COCO classes (default: the shipped class map).
    min_side : float, optional
        ``nvrq``: the shorter side (pixels) a clipped box needs.
    where : str, optional
        The DETS file, named in errors.

    Returns
    -------
    pandas.DataFrame
        :data:`NTA_COLUMNS` with the view columns and ``method`` (when the scene has methods)
        after ``label_class``, then ``protocol``. Boxes ``p_*`` and detections ``d_*`` are in the
        protocol's evaluation pixels; ``d_*`` empty for a box without a detection.
    """
    rel = check_detection_paths(scene, dets, where=where)
    check_pixel_boxes(dets, _image_sizes(scene, rel), where=where)
    boxes = novel_boxes(scene, protocol)
    if boxes.empty:
        raise InputError(scene.root, "images.csv", "renders whose camera sees some box", "no projected box")
    codes = pd.factorize(pd.Index(np.concatenate([boxes["render_path"].to_numpy(dtype=object), rel])))[0]
    nb = len(boxes)
    res = evaluate({"image": codes[:nb], "boxes": boxes[["b_x0", "b_y0", "b_x1", "b_y1"]].to_numpy(),
                    "labels": boxes["label_class"].to_numpy(dtype=object)},
                   {"image": codes[nb:], "boxes": dets[["x0", "y0", "x1", "y1"]].to_numpy(np.float64),
                    "scores": dets["score"].to_numpy(np.float64), "labels": dets["coco_class"].to_numpy(dtype=object)},
                   boxes[["image_w", "image_h"]].to_numpy(), protocol, class_map=class_map, min_side=min_side)
    return _table(boxes.iloc[res["index"]].reset_index(drop=True), res, dets, protocol)


def _table(kept: pd.DataFrame, res: dict, dets: pd.DataFrame, protocol: Protocol) -> pd.DataFrame:
    methods = kept[METHOD_COLUMN].to_numpy(dtype=object)
    with_method = bool((methods != "").any())
    kept.insert(0, "pair_id", pair_ids(kept, methods if with_method else None))
    det = res["det"]
    has = det >= 0
    if not has.any():  # no detection at all (or none passed the score filter): every box a miss
        det = np.zeros(len(det), np.int64)
        res = {**res, "det_box": np.full((1, 4), np.nan)}
        dets = pd.DataFrame({"score": [np.nan], "coco_class": [""]})
    for k, name in enumerate(("x0", "y0", "x1", "y1")):
        kept[f"p_{name}"] = res["box"][:, k]
        kept[f"d_{name}"] = np.where(has, res["det_box"][np.maximum(det, 0), k], np.nan)
    kept["d_score"] = np.where(has, dets["score"].to_numpy(np.float64)[np.maximum(det, 0)], np.nan)
    kept["d_class"] = np.where(has, dets["coco_class"].to_numpy(dtype=object)[np.maximum(det, 0)], "")
    kept["iou"] = res["iou"]
    kept["protocol"] = protocol.name
    front = NTA_COLUMNS[:NTA_COLUMNS.index("label_class") + 1]
    cols = [*front, *VIEW_COLUMNS, *([METHOD_COLUMN] if with_method else []),
            *NTA_COLUMNS[len(front):], "protocol"]
    return kept.loc[:, cols].sort_values(["camera", "timestamp_us", "track_id", *VIEW_COLUMNS[:-1],
                                          *([METHOD_COLUMN] if with_method else [])], kind="stable").reset_index(drop=True)


def nta_summary(table: pd.DataFrame, *, n_boot: int = 1000, seed: int = 0, min_clusters: int = 5) -> pd.DataFrame:
    """NTA-IoU per method and view of a per-box table, with its cluster-bootstrap interval.

    Parameters
    ----------
    table : pandas.DataFrame
        A :func:`nta_table` output (``iou``, ``clip_id``, ``track_id``, the view columns and
        ``method`` if any).
    n_boot, seed, min_clusters : int, optional
        As :func:`nvrq.proxies.nta_iou.cluster_mean_ci` (no interval below ``min_clusters`` tracks).

    Returns
    -------
    pandas.DataFrame
        ``method`` (if any), the view columns, then :data:`SUMMARY_COLUMNS`, one row per
        method and view (views in increasing order).
    """
    keys = [*([METHOD_COLUMN] if METHOD_COLUMN in table.columns else []), *VIEW_COLUMNS]
    grp = table.groupby(keys, sort=True, dropna=False).ngroup().to_numpy()
    first = table.groupby(keys, sort=True, dropna=False).head(1).assign(_g=grp[table.groupby(
        keys, sort=True, dropna=False).head(1).index]).sort_values("_g")
    tracks = pd.MultiIndex.from_arrays([table["clip_id"].astype(str), table["track_id"].astype(str)]).factorize()[0]
    stats = cluster_mean_ci(table["iou"].to_numpy(np.float64), grp, tracks, n_boot=n_boot, seed=seed,
                            min_clusters=min_clusters)
    out = first[keys].reset_index(drop=True)
    out["protocol"] = table["protocol"].iloc[0] if len(table) else ""
    out["n_boxes"], out["n_tracks"] = stats["n"], stats["n_tracks"]
    out["nta_iou"], out["ci_lo"], out["ci_hi"], out["reason"] = stats["mean"], stats["ci_lo"], stats["ci_hi"], stats["reason"]
    return out.loc[:, [*keys, *SUMMARY_COLUMNS]]
