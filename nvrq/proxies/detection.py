"""Detection confidence on the render box (paper Eq. 6-8): ``s_det`` per pair.

Layer: nvrq core, proxies (downstream quality proxies).

For each pair's render box ``b`` and the detections ``D`` of the render image (any
detector; confidence ``>= MIN_SCORE`` only):

- Eq. 7: ``d* = argmax_{d in D_c} IoU(b, d)`` over the *class-valid* detections ``D_c``
  (COCO class in the pair's ``label_class`` map) if that IoU is ``>= IOU_MIN``; otherwise
  ``d* = argmax_{d in D} IoU(b, d)`` over detections of any class.
- Eq. 8: ``s_det = score(d*)`` if ``IoU(b, d*) >= IOU_MIN``, else 0 (also 0 with no detections).
- Ties in IoU go to the detection of higher score.

Convention:
    Detection boxes ``x0, y0, x1, y1`` are continuous pixel-edge coordinates, the image
    spanning ``[0, W] x [0, H]`` (Ultralytics, torchvision and COCO use this). A pair's
    render box is inclusive pixel indices (docs/FORMATS.md §3), so it covers
    ``[r_x0, r_x1 + 1] x [r_y0, r_y1 + 1]``: the box ``[0, 0, 9, 9]`` is the 10 x 10 square
    ``[0, 10] x [0, 10]``.

DETS table columns: ``path`` (as in ``images.csv``, i.e. relative to the scene folder, or
absolute), ``x0, y0, x1, y1, score, coco_class``.

>>> iou_matrix(np.array([[0.0, 0, 10, 10]]), np.array([[0.0, 0, 10, 3], [5, 0, 15, 10]])).tolist()
[[0.3, 0.3333333333333333]]
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from data_schema.errors import InputError, check_number
from data_schema.tables import RENDER_BOX_COLUMNS, read_table, require_columns
from nvrq.proxies import mapped_labels
from nvrq.proxies.coco import check_coco_classes

__all__ = [
    "DETS_COLUMNS",
    "IOU_MIN",
    "MIN_SCORE",
    "iou_matrix",
    "iou_pairs",
    "read_detections",
    "render_boxes_xyxy",
    "detection_confidence",
    "check_pixel_boxes",
    "NORMALISED_MIN_SIDE",
]

DETS_COLUMNS = ("path", "x0", "y0", "x1", "y1", "score", "coco_class")
IOU_MIN = 0.3
MIN_SCORE = 0.1
#: Images whose shorter side has at least this many pixels cannot hold only boxes inside
#: ``[0, 1]``: such a table has normalised coordinates (:func:`check_pixel_boxes`).
NORMALISED_MIN_SIDE = 100


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of every box ``a: (N, 4)`` with every box ``b: (M, 4)`` (continuous xyxy) -> (N, M).

    Parameters
    ----------
    a : (N, 4) float64
        Boxes ``[x0, y0, x1, y1]``, continuous pixels.
    b : (M, 4) float64
        Boxes, same convention.

    Returns
    -------
    (N, M) float64
        IoU in [0, 1].
    """
    return iou_pairs(np.asarray(a, np.float64)[:, None, :], np.asarray(b, np.float64)[None, :, :])


def iou_pairs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Element-wise IoU of broadcastable box arrays ``(..., 4)`` (continuous xyxy); 0 for empty unions.

    Parameters
    ----------
    a, b : (..., 4) float64
        Boxes ``[x0, y0, x1, y1]``, continuous pixels, broadcastable.

    Returns
    -------
    (...,) float64
        IoU in [0, 1].
    """
    iw = np.clip(np.minimum(a[..., 2], b[..., 2]) - np.maximum(a[..., 0], b[..., 0]), 0, None)
    ih = np.clip(np.minimum(a[..., 3], b[..., 3]) - np.maximum(a[..., 1], b[..., 1]), 0, None)
    inter = iw * ih
    area_a = (a[..., 2] - a[..., 0]) * (a[..., 3] - a[..., 1])
    area_b = (b[..., 2] - b[..., 0]) * (b[..., 3] - b[..., 1])
    union = area_a + area_b - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def render_boxes_xyxy(pairs: pd.DataFrame) -> np.ndarray:
    """Inclusive render boxes ``r_x0..r_y1`` (N, 4) -> continuous ``[x0, y0, x1 + 1, y1 + 1]``.

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table with ``r_x0, r_y0, r_x1, r_y1`` (inclusive pixels).

    Returns
    -------
    (N, 4) float64
        Continuous pixel boxes.
    """
    box = pairs[["r_x0", "r_y0", "r_x1", "r_y1"]].to_numpy(np.float64)
    return box + np.array([0.0, 0.0, 1.0, 1.0])


def read_detections(path: str | os.PathLike) -> pd.DataFrame:
    """Read and validate a DETS table (:data:`DETS_COLUMNS`); ``coco_class`` lower-cased.

    Parameters
    ----------
    path : str or PathLike
        A DETS table (CSV or Parquet).

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    InputError
        A missing column or an invalid value.
    """
    dets = read_table(path, required=DETS_COLUMNS, what="detections table")
    return validate_detections(dets, where=str(path))


def check_pixel_boxes(dets: pd.DataFrame, sizes: np.ndarray, *, where: str = "detections") -> None:
    """Refuse a DETS table whose boxes are normalised (every one inside ``[0, 1]``) instead of in pixels.

    Parameters
    ----------
    dets : pandas.DataFrame
        A validated DETS table (:func:`validate_detections`), ``N`` rows.
    sizes : (N, 2) numpy.ndarray
        The ``(W, H)`` in pixels of each detection's image.
    where : str, optional
        The DETS table, named in the error.

    Raises
    ------
    InputError
        Some detection exists, every box coordinate lies in ``[0, 1]`` and every image's
        shorter side has at least :data:`NORMALISED_MIN_SIDE` pixels.

    >>> dets = pd.DataFrame({"x0": [0.1], "y0": [0.2], "x1": [0.4], "y1": [0.5]})
    >>> check_pixel_boxes(dets, np.array([[640, 480]]), where="d.csv")
    Traceback (most recent call last):
    data_schema.errors.InputError: d.csv: columns x0, y0, x1, y1: expected pixel-edge coordinates on images of 640x480 pixels or more, got every box inside [0, 1] (normalised coordinates: multiply x0, x1 by the image width and y0, y1 by its height)
    >>> check_pixel_boxes(dets.assign(x1=[40.0]), np.array([[640, 480]]))  # one box in pixels: fine
    """
    if not len(dets):
        return
    xy = dets[["x0", "y0", "x1", "y1"]].to_numpy(np.float64)
    sizes = np.asarray(sizes, np.float64).reshape(-1, 2)
    if ((xy >= 0) & (xy <= 1)).all() and sizes.min() >= NORMALISED_MIN_SIDE:
        w, h = sizes[np.argmin(sizes.min(axis=1))].astype(int)
        raise InputError(where, "columns x0, y0, x1, y1",
                         f"pixel-edge coordinates on images of {w}x{h} pixels or more",
                         "every box inside [0, 1] (normalised coordinates: multiply x0, x1 by the image "
                         "width and y0, y1 by its height)")


def validate_detections(dets: pd.DataFrame, *, where: str = "detections") -> pd.DataFrame:
    """Check the numeric columns (finite, ``x1 >= x0``, ``y1 >= y0``, score in [0, 1])."""
    require_columns(dets, DETS_COLUMNS, where=where)
    out = dets.loc[:, list(DETS_COLUMNS)].copy()
    for col in ("x0", "y0", "x1", "y1", "score"):
        vals = pd.to_numeric(out[col], errors="coerce").to_numpy(np.float64)
        bad = ~np.isfinite(vals)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                where, f"row {i + 2}, column {col}", "a finite number", dets[col].iloc[i]
            )
        out[col] = vals
    for lo, hi in (("x0", "x1"), ("y0", "y1")):
        bad = out[hi].to_numpy() < out[lo].to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                where,
                f"row {i + 2}, columns {lo}, {hi}",
                f"{hi} >= {lo}",
                f"{lo}={out[lo].iloc[i]}, {hi}={out[hi].iloc[i]}",
            )
    s = out["score"].to_numpy()
    bad = (s < 0) | (s > 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(where, f"row {i + 2}, column score", "a confidence in [0, 1]", s[i])
    out["path"] = out["path"].astype(str).map(os.path.normpath)
    out["coco_class"] = out["coco_class"].astype(str).str.strip().str.lower()
    check_coco_classes(out["coco_class"].to_numpy(dtype=object), where=where,
                       field_of=lambda i: f"row {i + 2}, column coco_class")
    return out.reset_index(drop=True)


def _pair_paths(pairs: pd.DataFrame, dets_paths: np.ndarray) -> np.ndarray:
    """Render paths of the pairs in the detections' spelling (relative, or absolute if DETS is)."""
    rel = pairs["render_path"].astype(str).map(os.path.normpath).to_numpy(dtype=object)
    if (
        len(dets_paths)
        and all(os.path.isabs(p) for p in dets_paths[:100])
        and "scene_root" in pairs
    ):
        roots = pairs["scene_root"].astype(str).to_numpy(dtype=object)
        return np.array(
            [os.path.normpath(os.path.join(r, p)) for r, p in zip(roots, rel, strict=True)],
            dtype=object,
        )
    return rel


def detection_confidence(
    pairs: pd.DataFrame,
    dets: pd.DataFrame,
    *,
    coco_map: dict[str, list[str]],
    iou_min: float = IOU_MIN,
    min_score: float = MIN_SCORE,
    where: str = "pairs",
) -> pd.DataFrame:
    """``s_det`` (paper Eq. 7-8) of every pair -> DataFrame ``pair_id, s_det`` (pairs' order).

    ``pairs``: docs/FORMATS.md §3 columns (``pair_id, label_class, render_path, r_x0..r_y1``).
    ``dets``: a validated DETS table (:func:`validate_detections`). ``coco_map``: lower-cased
    ``label_class`` -> allowed COCO classes (a class absent from the map is an error).

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table.
    dets : pandas.DataFrame
        A validated DETS table.
    coco_map : dict
        Lower-cased label class -> allowed COCO classes.
    iou_min : float, optional
        Smallest IoU of a match, in (0, 1].
    min_score : float, optional
        Smallest detection confidence considered, in [0, 1].
    where : str, optional
        The table named in errors.

    Returns
    -------
    pandas.DataFrame
        ``pair_id, s_det``.
    """
    check_number("iou_min", iou_min, low=0, high=1, low_open=True)
    check_number("min_score", min_score, low=0, high=1)
    require_columns(pairs, ("pair_id", "label_class", "render_path", *RENDER_BOX_COLUMNS),
                    where=where)
    labels = mapped_labels(pairs["label_class"], coco_map, "coco", where=where)
    dets = dets[dets["score"].to_numpy() >= min_score]
    n = len(pairs)
    s_det = np.zeros(n)
    det_paths = dets["path"].to_numpy(dtype=object)
    paths = _pair_paths(pairs, det_paths)
    # every (pair, detection) combination of the same image, as flat index arrays
    codes = pd.factorize(pd.Index(np.concatenate([paths, det_paths])))[0]
    pair_codes, det_codes = codes[:n], codes[n:]
    if len(dets) and not np.isin(pair_codes, det_codes).any():
        raise InputError(
            param="detections", field="path", expected="paths that match the pairs' render_path (as in images.csv)", got=f"e.g. {det_paths[0]!r} vs {paths[0]!r}" if n else "no pairs",
        )
    left = pd.DataFrame({"code": pair_codes, "i": np.arange(n)})
    right = pd.DataFrame({"code": det_codes, "j": np.arange(len(dets))})
    combo = left.merge(right, on="code", how="inner")
    i, j = combo["i"].to_numpy(np.int64), combo["j"].to_numpy(np.int64)
    if len(i):
        r_box = render_boxes_xyxy(pairs)
        d_box = dets[["x0", "y0", "x1", "y1"]].to_numpy(np.float64)
        iou = iou_pairs(r_box[i], d_box[j])  # (K,)
        # class validity through integer codes: allowed[label, coco]
        label_codes, label_names = pd.factorize(pd.Index(labels))
        coco_codes, coco_names = pd.factorize(dets["coco_class"])
        coco_pos = {c: k for k, c in enumerate(coco_names)}
        allowed = np.zeros((len(label_names), len(coco_names) + 1), bool)
        for a, lab in enumerate(label_names):
            for c in coco_map[lab]:
                if c in coco_pos:
                    allowed[a, coco_pos[c]] = True
        valid = allowed[label_codes[i], coco_codes[j]]
        score = dets["score"].to_numpy(np.float64)[j]
        best_valid = _best_per_pair(i, np.where(valid, iou, -1.0), score, n)
        best_any = _best_per_pair(i, iou, score, n)
        use_valid = best_valid[0] >= iou_min
        best_iou = np.where(use_valid, best_valid[0], best_any[0])
        best_score = np.where(use_valid, best_valid[1], best_any[1])
        s_det = np.where(best_iou >= iou_min, best_score, 0.0)
    return pd.DataFrame({"pair_id": pairs["pair_id"].to_numpy(), "s_det": s_det})


def _best_per_pair(i: np.ndarray, iou: np.ndarray, score: np.ndarray, n: int):
    """Per pair (n,): the highest IoU and the score of that detection (higher score wins ties);
    IoU -inf and score 0 for pairs without candidates."""
    order = np.lexsort((score, iou, i))  # by pair, then IoU, then score: the last of a pair wins
    last = np.ones(len(order), bool)
    last[:-1] = i[order][1:] != i[order][:-1]
    pick = order[last]
    best_iou = np.full(n, -np.inf)
    best_score = np.zeros(n)
    best_iou[i[pick]] = iou[pick]
    best_score[i[pick]] = score[pick]
    return best_iou, best_score
