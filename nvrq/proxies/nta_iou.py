"""NTA-IoU: how well a detector finds, in a novel-view render, the boxes the scene projects there
(library layer, :mod:`nvrq.proxies`; docs/FORMATS.md §3b).

Every box of the scene is projected into the render's camera (the novel view alone, not only
the boxes that also pass in the GT view); each projected box takes one detection of the
render (a DETS table, :mod:`nvrq.proxies.detection`) and scores its IoU, 0 when it has none.
NTA-IoU is the mean over the boxes of a view. Three protocols (:data:`PROTOCOLS`):

- ``recondreamer``: ReconDreamer's ``script/NTAIou`` scripts. Coordinates scaled to 480x320
  and truncated to integers; vehicles only; a box with a coordinate outside the image (``< 0``
  or beyond 480 / 320) dropped; detections of COCO ``car`` and ``bus`` with score ``> 0.5``;
  each box takes the detection whose centre is nearest, if closer than 10 px (the first of
  equal distances), with no one-to-one assignment; IoU without ``+1``.
- ``drivedreamer4d``: the same, except that detections of every COCO class are kept and a
  box is dropped only when all its corners are behind the camera (the corners behind are
  mirrored through the perspective division, as that script does; ``pinhole`` cameras only).
- ``nvrq`` (default): at the image's own resolution; every class of the scene; boxes clipped
  to the image (dropped only when the clipped box is smaller than ``min_side``); detections
  with score ``> 0.5`` whose COCO class the box's ``label_class`` maps to (the class map of
  ``nvrq proxy detection``); one-to-one matching maximising the summed IoU (Hungarian, run per
  image only where a box or a detection has two candidates).

Coordinates: continuous pixel-edge ``x0, y0, x1, y1`` (the image spans ``[0, W] x [0, H]``),
as DETS; a projected corner at pixel index ``u`` has edge coordinate ``u + 0.5``.

>>> boxes = [{"boxes": [[0, 0, 10, 10], [20, 0, 30, 10]], "labels": ["car", "car"]}]
>>> dets = [{"boxes": [[0, 0, 10, 5]], "scores": [0.9], "labels": ["car"]}]
>>> nta_iou(boxes, dets, image_size=(64, 48), min_side=1)
0.25
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from data_schema.errors import InputError

__all__ = ["PROTOCOLS", "NTA_COLUMNS", "SUMMARY_COLUMNS", "Protocol", "get_protocol", "nta_iou",
           "NTAIoU", "prepare_boxes", "match_boxes", "cluster_mean_ci"]

PEER_SIZE = (480, 320)
#: COCO classes of a projected box in the peers' protocols: their "vehicle" type
VEHICLE_COCO = ("car", "truck", "bus")


@dataclass(frozen=True)
class Protocol:
    """One NTA-IoU protocol (module docstring). ``size``: evaluation size ``(W, H)`` or None
    (the image's own); ``det_classes``: COCO classes kept (None: all; the class map for
    ``nvrq``); ``vehicles_only``: project only boxes whose class maps to a vehicle;
    ``truncate``: integer coordinates; ``clip``: clip to the image instead of dropping;
    ``behind``: ``'any'`` drops a box with any corner behind the camera, ``'all'`` only with all;
    ``hungarian``: one-to-one IoU matching, else the peers' nearest centre within ``radius``.

    Attributes
    ----------
    name : str
        Protocol name (a key of :data:`PROTOCOLS`).
    size : tuple of int (W, H) or None
        Evaluation size; None for the image's own.
    det_classes : tuple of str or None
        COCO classes kept; None for all.
    vehicles_only : bool
        Project only boxes whose class maps to a vehicle.
    truncate : bool
        Truncate box coordinates to integers.
    clip : bool
        Clip boxes to the image instead of dropping them.
    behind : str
        ``'any'`` drops a box with any corner behind the camera, ``'all'`` only with all.
    hungarian : bool
        One-to-one IoU matching; else nearest centre within ``radius``.
    class_map : bool
        Map detection classes with the class map (default False).
    min_score : float
        Smallest detection score kept (default 0.5).
    radius : float
        Centre-matching radius in pixels (default 10.0).
    """

    name: str
    size: tuple[int, int] | None
    det_classes: tuple[str, ...] | None
    vehicles_only: bool
    truncate: bool
    clip: bool
    behind: str
    hungarian: bool
    class_map: bool = False
    min_score: float = 0.5
    radius: float = 10.0


PROTOCOLS = {
    "nvrq": Protocol("nvrq", None, None, False, False, True, "any", True, class_map=True),
    "recondreamer": Protocol("recondreamer", PEER_SIZE, ("car", "bus"), True, True, False, "any", False),
    "drivedreamer4d": Protocol("drivedreamer4d", PEER_SIZE, None, True, True, False, "all", False),
}

#: per-box table (``nvrq proxy nta-iou --out``), before the view and method columns it adds
NTA_COLUMNS = ["pair_id", "clip_id", "camera", "timestamp_us", "track_id", "label_class", "render_path",
               "p_x0", "p_y0", "p_x1", "p_y1", "d_x0", "d_y0", "d_x1", "d_y1", "d_score", "d_class", "iou"]
#: summary table (``NTA.summary.csv``), after the method and view columns
SUMMARY_COLUMNS = ["protocol", "n_boxes", "n_tracks", "nta_iou", "ci_lo", "ci_hi", "reason"]


def get_protocol(name: str) -> Protocol:
    """The protocol called ``name``.

    Parameters
    ----------
    name : str
        One of :data:`PROTOCOLS`.

    Returns
    -------
    Protocol

    Raises
    ------
    InputError
        Naming ``protocol`` and the known ones.
    """
    if name not in PROTOCOLS:
        raise InputError(param="protocol", expected="one of " + ", ".join(PROTOCOLS), got=name)
    return PROTOCOLS[name]


def prepare_boxes(boxes: np.ndarray, sizes: np.ndarray, protocol: Protocol, *,
                  min_side: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Projected boxes in the protocol's evaluation frame.

    Parameters
    ----------
    boxes : numpy.ndarray
        (N, 4) continuous pixel-edge boxes in the image's own pixels (may extend outside it).
    sizes : numpy.ndarray
        (N, 2) each box's image ``(W, H)`` in pixels.
    protocol : Protocol
    min_side : float, optional
        With ``clip``: the shorter side (pixels) a clipped box needs to be kept.

    Returns
    -------
    boxes : numpy.ndarray
        (N, 4) float64 in evaluation pixels (scaled, truncated, clipped as the protocol says).
    keep : numpy.ndarray
        (N,) bool: the box is evaluated.
    """
    b = _scaled(np.asarray(boxes, np.float64).reshape(-1, 4), sizes, protocol)
    w, h = _eval_sizes(sizes, protocol)
    if protocol.clip:
        b = np.clip(b, 0.0, np.stack([w, h, w, h], axis=1))
        keep = np.minimum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]) >= min_side
    else:  # the peers' rule on (integer) coordinates: x1 <= W and y1 <= H are inside
        keep = (b >= 0).all(axis=1) & (b[:, 2] <= w) & (b[:, 3] <= h)
    return b, keep & np.isfinite(b).all(axis=1)


def _eval_sizes(sizes: np.ndarray, protocol: Protocol) -> tuple[np.ndarray, np.ndarray]:
    sizes = np.asarray(sizes, np.float64).reshape(-1, 2)
    if protocol.size is None:
        return sizes[:, 0], sizes[:, 1]
    return np.full(len(sizes), float(protocol.size[0])), np.full(len(sizes), float(protocol.size[1]))


def _scaled(b: np.ndarray, sizes: np.ndarray, protocol: Protocol) -> np.ndarray:
    """Boxes (N, 4) scaled to the evaluation size and truncated toward 0 if the protocol says."""
    if protocol.size is not None:
        sizes = np.asarray(sizes, np.float64).reshape(-1, 2)
        sx, sy = protocol.size[0] / sizes[:, 0], protocol.size[1] / sizes[:, 1]
        b = b * np.stack([sx, sy, sx, sy], axis=1)
    return np.trunc(b) if protocol.truncate else b


def _image_ranges(img_b: np.ndarray, img_d: np.ndarray):
    """Every (box, detection) of one image: flat index arrays ``(i, j)`` (box-major, detections
    in their input order within an image)."""
    order = np.argsort(img_d, kind="stable")
    sorted_img = img_d[order]
    lo = np.searchsorted(sorted_img, img_b, side="left")
    hi = np.searchsorted(sorted_img, img_b, side="right")
    n = hi - lo
    i = np.repeat(np.arange(len(img_b)), n)
    start = np.repeat(lo - np.cumsum(n) + n, n)
    j = order[start + np.arange(len(i))] if len(i) else np.zeros(0, np.int64)
    return i, j


def _iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Element-wise IoU without ``+1`` (as both peers' ``calculate_iou``); 0 for an empty union."""
    iw = np.maximum(0.0, np.minimum(a[:, 2], b[:, 2]) - np.maximum(a[:, 0], b[:, 0]))
    ih = np.maximum(0.0, np.minimum(a[:, 3], b[:, 3]) - np.maximum(a[:, 1], b[:, 1]))
    inter = iw * ih
    union = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1]) + (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1]) - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(union != 0, inter / np.where(union != 0, union, 1.0), 0.0)


def match_boxes(img_b: np.ndarray, box_b: np.ndarray, img_d: np.ndarray, box_d: np.ndarray, *,
                protocol: Protocol, allowed: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The detection each box takes and its IoU (vectorised over all images).

    Parameters
    ----------
    img_b, box_b : numpy.ndarray
        (N,) int image code and (N, 4) evaluation-frame box of each projected box.
    img_d, box_d : numpy.ndarray
        (M,) int image code and (M, 4) evaluation-frame box of each (kept) detection.
    protocol : Protocol
    allowed : callable, optional
        ``allowed(i, j) -> (K,) bool``: box ``i`` may take detection ``j`` (the class map);
        None: any.

    Returns
    -------
    det : numpy.ndarray
        (N,) int64 index into the detections, -1 for none.
    iou : numpy.ndarray
        (N,) float64, 0 for a box without a detection.
    """
    i, j = _image_ranges(np.asarray(img_b, np.int64), np.asarray(img_d, np.int64))
    if allowed is not None and len(i):
        ok = allowed(i, j)
        i, j = i[ok], j[ok]
    det = np.full(len(img_b), -1, np.int64)
    iou = np.zeros(len(img_b))
    if not len(i):
        return det, iou
    if protocol.hungarian:
        v = _iou(box_b[i], box_d[j])
        pos = v > 0
        _assign(i[pos], j[pos], v[pos], np.asarray(img_b, np.int64), det)
    else:
        cb = (box_b[i, :2] + box_b[i, 2:]) / 2
        cd = (box_d[j, :2] + box_d[j, 2:]) / 2
        dx, dy = cb[:, 0] - cd[:, 0], cb[:, 1] - cd[:, 1]
        dist = np.sqrt(dx * dx + dy * dy)
        near = dist < protocol.radius
        i, j, dist = i[near], j[near], dist[near]
        first = np.lexsort((j, dist, i))  # per box: nearest, then the first in input order
        keep = np.r_[True, i[first][1:] != i[first][:-1]] if len(first) else np.zeros(0, bool)
        det[i[first][keep]] = j[first][keep]
    has = det >= 0
    iou[has] = _iou(box_b[has], box_d[det[has]])
    return det, iou


def _assign(i: np.ndarray, j: np.ndarray, v: np.ndarray, img_b: np.ndarray, det: np.ndarray) -> None:
    """One-to-one matches of candidate pairs ``(i, j)`` with IoU ``v`` into ``det`` (in place): a
    pair whose box and detection have no other candidate is taken as is; the images with a
    conflict are solved by the Hungarian algorithm (maximum summed IoU)."""
    if not len(i):
        return
    nb = np.bincount(i)[i]
    nd = np.bincount(j)[j]
    single = (nb == 1) & (nd == 1)
    det[i[single]] = j[single]
    if single.all():
        return
    from scipy.optimize import linear_sum_assignment

    ci, cj, cv = i[~single], j[~single], v[~single]
    img = img_b[ci]
    rows, row_ids, row_start = _dense_rank(img, ci)
    cols, col_ids, col_start = _dense_rank(img, cj)
    order = np.argsort(img, kind="stable")
    cv, img, rows, cols = cv[order], img[order], rows[order], cols[order]
    bounds = np.flatnonzero(np.r_[True, img[1:] != img[:-1], True]).tolist()
    n_rows, n_cols = np.diff(row_start).tolist(), np.diff(col_start).tolist()
    r0s, c0s = row_start.tolist(), col_start.tolist()
    for g, (a, b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
        m = np.zeros((n_rows[g], n_cols[g]))
        m[rows[a:b], cols[a:b]] = cv[a:b]
        rr, cc = linear_sum_assignment(m, maximize=True)
        good = m[rr, cc] > 0
        det[row_ids[r0s[g] + rr[good]]] = col_ids[c0s[g] + cc[good]]


def _dense_rank(group: np.ndarray, key: np.ndarray):
    """Dense ranks of ``key`` within each ``group`` (vectorised over all groups).

    Returns ``(rank (K,), ids (U,), start (G + 1,))``: each entry's 0-based rank, the distinct
    keys by group (groups ascending) then rank, and where each group's keys start in ``ids``.
    """
    order = np.lexsort((key, group))
    g, k = group[order], key[order]
    new_group = np.r_[True, g[1:] != g[:-1]]
    new_key = new_group | np.r_[True, k[1:] != k[:-1]]
    dense = np.cumsum(new_key) - 1
    start = np.maximum.accumulate(np.where(new_group, dense, 0))
    out = np.empty(len(key), np.int64)
    out[order] = dense - start
    ids = k[new_key]
    starts = np.r_[dense[new_group], len(ids)]
    return out, ids, starts


def _as_arrays(items, name: str, keys: tuple[str, ...]) -> list[dict]:
    """A list of per-image dicts checked: each key an array of one length per image."""
    if not isinstance(items, (list, tuple)):
        raise InputError(param=name, expected="a list with one dict per image", got=type(items).__name__)
    out = []
    for k, item in enumerate(items):
        if not isinstance(item, dict) or "boxes" not in item:
            raise InputError(param=f"{name}[{k}]", expected="a dict with 'boxes'", got=type(item).__name__)
        boxes = np.asarray(item["boxes"], np.float64).reshape(-1, 4) if len(item["boxes"]) else np.zeros((0, 4))
        row = {"boxes": boxes}
        for key in keys:
            default = np.ones(len(boxes)) if key == "scores" else np.full(len(boxes), "", dtype=object)
            value = np.asarray(item.get(key, default))
            if len(value) != len(boxes):
                raise InputError(param=f"{name}[{k}].{key}", expected=f"{len(boxes)} values", got=len(value))
            row[key] = value
        bad = ~np.isfinite(boxes).all(axis=1) | (boxes[:, 2] < boxes[:, 0]) | (boxes[:, 3] < boxes[:, 1])
        if bad.any():
            raise InputError(param=f"{name}[{k}].boxes", field=f"row {int(np.flatnonzero(bad)[0])}",
                             expected="finite x0, y0, x1, y1 with x1 >= x0 and y1 >= y0",
                             got=boxes[bad][0].tolist())
        out.append(row)
    return out


def _flatten(items: list[dict], keys: tuple[str, ...]) -> dict:
    n = [len(x["boxes"]) for x in items]
    out = {"image": np.repeat(np.arange(len(items)), n),
           "boxes": np.concatenate([x["boxes"] for x in items]) if items else np.zeros((0, 4))}
    for key in keys:
        out[key] = np.concatenate([x[key] for x in items]) if items else np.zeros(0)
    return out


def _class_rule(protocol: Protocol, class_map: dict | None):
    """``(box_keep(labels) -> bool (N,), det_keep(classes) -> bool (M,), allowed(labels, classes))``."""
    if class_map is None:
        from nvrq.proxies import load_class_maps

        class_map = load_class_maps()["coco"]
    lower = {str(k).lower(): [c.lower() for c in v] for k, v in class_map.items()}

    def box_keep(labels):
        if not protocol.vehicles_only:
            return np.ones(len(labels), bool)
        codes, uniq = pd.factorize(np.asarray(labels, dtype=object))
        ok = np.array([bool(set(lower.get(str(x).lower(), ())) & set(VEHICLE_COCO)) for x in uniq], bool)
        return ok[codes] if len(uniq) else np.zeros(len(labels), bool)

    def det_keep(classes):
        if protocol.det_classes is None:
            return np.ones(len(classes), bool)
        codes, uniq = pd.factorize(np.asarray(classes, dtype=object))
        ok = np.array([str(x).lower() in protocol.det_classes for x in uniq], bool)
        return ok[codes] if len(uniq) else np.zeros(len(classes), bool)

    return box_keep, det_keep, lower


def _allowed(labels: np.ndarray, classes: np.ndarray, lower: dict, *, where: str = "boxes"):
    """``allowed(i, j)`` of the class map: box ``i``'s label maps to detection ``j``'s COCO class."""
    from nvrq.proxies import mapped_labels

    lab_codes, lab_uniq = pd.factorize(np.asarray(labels, dtype=object))
    lab_names = mapped_labels(lab_uniq, lower, "coco", where=where)
    cls_codes, cls_uniq = pd.factorize(np.asarray(classes, dtype=object))
    cls_names = [str(c).lower() for c in cls_uniq]
    table = np.zeros((len(lab_names), len(cls_names) + 1), bool)
    for a, lab in enumerate(lab_names):
        table[a, :len(cls_names)] = np.isin(np.asarray(cls_names, dtype=object), lower[lab])
    return lambda i, j: table[lab_codes[i], cls_codes[j]]


def evaluate(boxes: dict, dets: dict, sizes: np.ndarray, protocol: Protocol, *,
             class_map: dict | None = None, min_side: float = 1.0) -> dict:
    """Match flat boxes and detections of many images (the core of every entry point).

    Parameters
    ----------
    boxes : dict
        ``image`` (N,) int codes, ``boxes`` (N, 4) pixel-edge boxes, ``labels`` (N,) label_class.
    dets : dict
        ``image`` (M,), ``boxes`` (M, 4), ``scores`` (M,), ``labels`` (M,) COCO classes.
    sizes : numpy.ndarray
        (N, 2) each box's image ``(W, H)``; detections share their image's size.
    protocol : Protocol
    class_map : dict, optional
        label_class -> COCO classes (default: the shipped class map).
    min_side : float, optional
        As :func:`prepare_boxes`.

    Returns
    -------
    dict
        ``keep`` (N,) bool (evaluated boxes), then over the kept boxes: ``index`` (K,) into the
        input, ``box`` (K, 4) evaluation boxes, ``det`` (K,) into the detections (-1: none),
        ``det_box`` (M, 4) evaluation detection boxes, ``iou`` (K,).
    """
    box_keep, det_keep, lower = _class_rule(protocol, class_map)
    b, keep = prepare_boxes(boxes["boxes"], sizes, protocol, min_side=min_side)
    keep &= box_keep(boxes["labels"])
    d_ok = (np.asarray(dets["scores"], np.float64) > protocol.min_score) & det_keep(dets["labels"])
    img_size = np.ones((int(max(boxes["image"].max(initial=-1), dets["image"].max(initial=-1))) + 1, 2))
    img_size[boxes["image"]] = sizes
    d_box = _scaled(np.asarray(dets["boxes"], np.float64).reshape(-1, 4), img_size[dets["image"]], protocol)
    kb = np.flatnonzero(keep)
    kd = np.flatnonzero(d_ok)
    allowed = None
    if protocol.class_map:
        rule = _allowed(np.asarray(boxes["labels"])[kb], np.asarray(dets["labels"])[kd], lower)
        allowed = rule
    det, iou = match_boxes(boxes["image"][kb], b[kb], dets["image"][kd], d_box[kd], protocol=protocol,
                           allowed=allowed)
    return {"keep": keep, "index": kb, "box": b[kb], "det": np.where(det >= 0, kd[np.maximum(det, 0)], -1) if len(kd) else np.full(len(kb), -1),
            "det_box": d_box, "iou": iou}


def nta_iou(boxes, detections, *, protocol: str = "nvrq", image_size=None, class_map: dict | None = None,
            min_side: float = 1.0) -> float:
    """NTA-IoU of projected boxes against detections, image by image.

    Parameters
    ----------
    boxes : list of dict
        One per image: ``boxes`` (N, 4) projected boxes, continuous pixel-edge ``x0, y0, x1, y1``
        in the image's pixels (they may extend outside it), and ``labels`` (N,) their
        ``label_class`` (``nvrq``: mapped to COCO by ``class_map``; the peers keep vehicles).
    detections : list of dict
        One per image, in the same order: ``boxes`` (M, 4) as DETS, ``scores`` (M,) in [0, 1],
        ``labels`` (M,) COCO class names.
    protocol : {'nvrq', 'recondreamer', 'drivedreamer4d'}, optional
        :data:`PROTOCOLS` (module docstring).
    image_size : tuple of int or sequence of tuple
        ``(W, H)`` of every image, or one per image.
    class_map : dict, optional
        label_class -> COCO classes (default: the shipped ``class_maps.json``).
    min_side : float, optional
        ``nvrq``: the shorter side (pixels) a clipped box needs.

    Returns
    -------
    float
        The mean IoU over the evaluated boxes (NaN when there are none).
    """
    return NTAIoU(protocol=protocol, class_map=class_map, min_side=min_side).update(
        boxes, detections, image_size=image_size).compute()


class NTAIoU:
    """NTA-IoU accumulated over batches, torchmetrics-style (``update``, ``compute``, ``reset``).

    Parameters
    ----------
    protocol : str, optional
        One of :data:`PROTOCOLS` (default ``nvrq``).
    class_map : dict, optional
        label_class -> COCO classes (default: the shipped class map).
    min_side : float, optional
        As :func:`nta_iou`.

    >>> m = NTAIoU(min_side=1)
    >>> _ = m.update([{"boxes": [[0, 0, 10, 10]], "labels": ["car"]}],
    ...              [{"boxes": [[0, 0, 10, 10]], "scores": [0.9], "labels": ["car"]}], image_size=(32, 32))
    >>> m.compute(), m.ious.tolist()
    (1.0, [1.0])
    """

    def __init__(self, *, protocol: str = "nvrq", class_map: dict | None = None, min_side: float = 1.0):
        self.protocol = get_protocol(protocol)
        self.class_map = class_map
        self.min_side = float(min_side)
        self.reset()

    def reset(self) -> NTAIoU:
        """Forget every update. Returns the metric itself."""
        self._ious: list[np.ndarray] = []
        return self

    @property
    def ious(self) -> np.ndarray:
        """(K,) the IoU of every evaluated box so far, in update order."""
        return np.concatenate(self._ious) if self._ious else np.zeros(0)

    def update(self, boxes, detections, *, image_size) -> NTAIoU:
        """Add a batch of images (arguments as :func:`nta_iou`). Returns the metric itself."""
        b = _as_arrays(boxes, "boxes", ("labels",))
        d = _as_arrays(detections, "detections", ("scores", "labels"))
        if len(b) != len(d):
            raise InputError(param="detections", expected=f"one dict per image ({len(b)})", got=len(d))
        sizes = np.asarray(image_size, np.float64)
        sizes = np.broadcast_to(sizes.reshape(-1, 2), (len(b), 2)) if sizes.size == 2 else sizes.reshape(-1, 2)
        if len(sizes) != len(b) or not (sizes > 0).all():
            raise InputError(param="image_size", expected="(W, H) > 0, or one per image", got=image_size)
        fb, fd = _flatten(b, ("labels",)), _flatten(d, ("scores", "labels"))
        res = evaluate(fb, fd, sizes[fb["image"]], self.protocol, class_map=self.class_map,
                       min_side=self.min_side)
        self._ious.append(res["iou"])
        return self

    def compute(self) -> float:
        """The mean IoU over every evaluated box so far (NaN before any box)."""
        v = self.ious
        return float(v.mean()) if len(v) else float("nan")


def cluster_mean_ci(values: np.ndarray, groups: np.ndarray, clusters: np.ndarray, *, n_boot: int = 1000,
                    seed: int = 0, min_clusters: int = 5) -> pd.DataFrame:
    """Per-group mean with a 95% percentile interval from a cluster bootstrap over tracks (the
    leaderboard's rule, :mod:`analysis.methods`: every group shares one set of track draws; no
    interval below ``min_clusters`` tracks).

    Parameters
    ----------
    values : numpy.ndarray
        (N,) finite values.
    groups, clusters : numpy.ndarray
        (N,) int group codes 0..G-1 and track codes 0..K-1.
    n_boot, seed : int, optional
        Replicates (0: no intervals) and their seed.
    min_clusters : int, optional
        The fewest tracks of a group with an interval.

    Returns
    -------
    pandas.DataFrame
        One row per group code: ``n``, ``n_tracks``, ``mean``, ``ci_lo``, ``ci_hi``, ``reason``.
    """
    g, c, x = (np.asarray(a) for a in (groups, clusters, values))
    n_g = int(g.max()) + 1 if len(g) else 0
    k = int(c.max()) + 1 if len(c) else 0
    n = np.bincount(g, minlength=n_g).astype(np.float64)
    mean = np.bincount(g, weights=x, minlength=n_g) / np.maximum(n, 1)
    cell = g.astype(np.int64) * max(k, 1) + c
    s = np.bincount(cell, weights=x, minlength=n_g * k).reshape(n_g, k)
    w = np.bincount(cell, minlength=n_g * k).reshape(n_g, k).astype(np.float64)
    tracks = (w > 0).sum(axis=1)
    lo, hi = np.full(n_g, np.nan), np.full(n_g, np.nan)
    reason = np.full(n_g, "", dtype=object)
    if n_boot and k:
        rng = np.random.default_rng(seed)  # as analysis.stats.bootstrap.draw_cluster_counts
        draws = rng.integers(0, k, size=(n_boot, k))
        counts = np.zeros((n_boot, k))
        np.add.at(counts, (np.repeat(np.arange(n_boot), k), draws.ravel()), 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            reps = (counts @ s.T) / (counts @ w.T)
        for gi in range(n_g):
            r = reps[:, gi][np.isfinite(reps[:, gi])]
            if len(r) >= n_boot / 2:
                lo[gi], hi[gi] = np.quantile(r, [0.025, 0.975])
    few = tracks < min_clusters
    reason[few] = [f"{t} track{'s' if t != 1 else ''}, fewer than the {min_clusters} an interval needs"
                   for t in tracks[few]]
    lo[few] = hi[few] = np.nan
    if not n_boot:
        reason[~few] = "no bootstrap"
    return pd.DataFrame({"n": n.astype(np.int64), "n_tracks": tracks, "mean": mean, "ci_lo": lo, "ci_hi": hi,
                         "reason": reason})
