"""A simulated detector for synthetic scenes (``nvrq proxy simulate-detect``).

Layer: nvrq core, synth (synthetic scenes).

No detector ships offline, so the demo (docs/guides/compare-reconstructions.md) runs NTA-IoU on the
detections of this simulation, as it runs the study on ``annotate simulate``'s raters. Its
numbers follow how ``nvrq synth`` drew the artefacts, not how any real detector behaves; with a
real one, use ``nvrq proxy detect --yolo`` (or any detector writing the DETS table).

Model, per render image of a scene that ``nvrq synth`` wrote (its ``degradation.csv`` gives the
artefact ``severity`` s in [0, 1] of every object, camera, frame, view and method):

- every box the scene projects into the render (:func:`nvrq.proxies.nta_scene.novel_boxes`,
  the ``nvrq`` protocol's corners), clipped to the image, with a shorter side of at least
  ``min_side`` px and a severity row, is a true object;
- it is missed with probability ``s / 2``; otherwise detected as the first COCO class of its
  ``label_class`` in the class map, with score ``1 - s / 2``, each edge moved by a normal draw
  of standard deviation ``JITTER * s`` times the box's width (x edges) or height (y edges),
  and clipped to the image;
- each image gets one false positive with probability the mean severity of its true objects:
  a box of 5-25 % of the image's width and height at a uniform position, class ``train``
  (no synthetic class maps to it), score uniform in [0.3, 0.6].

Deterministic: one ``numpy.random.default_rng(seed)`` stream over the boxes in the order of
``novel_boxes``, then over the images in sorted path order.

Convention:
    DETS boxes are continuous pixel edges, the image spanning ``[0, W] x [0, H]``
    (:mod:`nvrq.proxies.detection`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.scene import Scene

__all__ = ["JITTER", "simulate_detections"]

#: standard deviation of each edge's shift, as a share of the box side, at severity 1
JITTER = 0.25


def _severity(scene: Scene, boxes: pd.DataFrame) -> np.ndarray:
    """Each box's severity from the scene's ``degradation.csv`` (NaN without a row)."""
    path = scene.root / "degradation.csv"
    if not path.is_file():
        raise InputError(scene.root, "degradation.csv", "a scene written by nvrq synth (its degradation.csv)",
                         "no such file")
    try:
        deg = pd.read_csv(path, dtype={"track_id": str}, keep_default_na=False, na_values=[""])
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise InputError(path, None, "a degradation table written by nvrq synth",
                         "an empty file" if isinstance(exc, pd.errors.EmptyDataError) else str(exc)) from None
    for col in ("camera", "timestamp_us", "track_id", "y_offset_m", "severity"):
        if col not in deg.columns:
            raise InputError(path, f"column {col}", "the columns nvrq synth writes", "missing")
    for col in ("timestamp_us", "y_offset_m", "x_offset_m", "z_offset_m", "roll_deg", "pitch_deg", "yaw_deg",
                "severity"):
        if col in deg.columns:
            num = pd.to_numeric(deg[col], errors="coerce")
            bad = (num.isna() & deg[col].notna()) | ~np.isfinite(num.fillna(0).to_numpy(np.float64))
            if bad.any():
                i = int(np.argmax(bad.to_numpy()))
                raise InputError(path, f"row {i + 2}, column {col}", "a finite number", repr(deg[col].iloc[i]))
            deg[col] = num
    keys = [c for c in ("camera", "timestamp_us", "track_id", "y_offset_m", "x_offset_m", "z_offset_m",
                        "roll_deg", "pitch_deg", "yaw_deg", "method") if c in deg.columns]
    dup = deg.duplicated(keys)
    if dup.any():
        i = int(np.argmax(dup.to_numpy()))
        raise InputError(path, f"row {i + 2}", "one row per box and view", "a duplicate")
    deg["timestamp_us"] = deg["timestamp_us"].astype(np.int64)
    if "method" in keys:
        deg["method"] = deg["method"].fillna("").astype(str)
    left = boxes[keys].astype({"track_id": str})
    return left.merge(deg[[*keys, "severity"]], on=keys, how="left", validate="many_to_one")["severity"].to_numpy()


def _true_boxes(scene: Scene, min_side: float) -> tuple[pd.DataFrame, np.ndarray]:
    """The clipped projected boxes with a severity row, and their severity ``(B,)``."""
    from nvrq.proxies.nta_iou import get_protocol
    from nvrq.proxies.nta_scene import novel_boxes

    b = novel_boxes(scene, get_protocol("nvrq"))
    if b.empty:
        raise InputError(scene.root, "images.csv", "renders whose camera sees some box", "no projected box")
    for name, size in (("b_x0", "image_w"), ("b_x1", "image_w"), ("b_y0", "image_h"), ("b_y1", "image_h")):
        b[name] = b[name].clip(0, b[size])
    sev = _severity(scene, b)
    keep = (np.minimum(b.b_x1 - b.b_x0, b.b_y1 - b.b_y0).to_numpy() >= min_side) & np.isfinite(sev)
    return b[keep].reset_index(drop=True), np.clip(sev[keep], 0.0, 1.0)


def _false_positives(b: pd.DataFrame, sev: np.ndarray, rng: np.random.Generator) -> pd.DataFrame:
    """One ``train`` box per image with probability the mean severity of its objects."""
    per_image = pd.DataFrame({"path": b.render_path, "s": sev, "w": b.image_w, "h": b.image_h}).groupby(
        "path", sort=True).agg(s=("s", "mean"), w=("w", "first"), h=("h", "first"))
    n = len(per_image)
    hit = rng.random(n) < per_image["s"].to_numpy()
    size = rng.uniform(0.05, 0.25, (n, 2)) * per_image[["w", "h"]].to_numpy()
    x0 = rng.random(n) * (per_image["w"].to_numpy() - size[:, 0])
    y0 = rng.random(n) * (per_image["h"].to_numpy() - size[:, 1])
    score = rng.uniform(0.3, 0.6, n)
    return pd.DataFrame({"path": per_image.index.to_numpy(dtype=object), "x0": x0, "y0": y0,
                         "x1": x0 + size[:, 0], "y1": y0 + size[:, 1], "score": score,
                         "coco_class": "train"})[hit]


def simulate_detections(scene: Scene, *, seed: int = 0, class_map: dict | None = None,
                        min_side: float = 1.0) -> pd.DataFrame:
    """Detections of every render of a synthetic scene by the simulated detector (module doc).

    Parameters
    ----------
    scene : Scene
        A scene written by ``nvrq synth`` (with its ``degradation.csv``).
    seed : int, optional
        The random stream's seed.
    class_map : dict, optional
        label_class -> COCO classes; a box takes the first (default: the shipped class map).
    min_side : float, optional
        The shorter side (pixels) a clipped box needs to be a true object.

    Returns
    -------
    pandas.DataFrame
        The DETS table (:data:`nvrq.proxies.detection.DETS_COLUMNS`): ``path`` (as in
        ``images.csv``), ``x0, y0, x1, y1`` (pixel edges), ``score``, ``coco_class``; true
        detections in box order, then the false positives.
    """
    from nvrq.proxies import load_class_maps

    cmap = load_class_maps()["coco"] if class_map is None else class_map
    b, sev = _true_boxes(scene, min_side)
    rng = np.random.default_rng(seed)
    found = rng.random(len(b)) >= sev / 2
    w = (b.b_x1 - b.b_x0).to_numpy()
    h = (b.b_y1 - b.b_y0).to_numpy()
    shift = rng.normal(0.0, 1.0, (len(b), 4)) * (JITTER * sev)[:, None] * np.stack([w, h, w, h], axis=1)
    box = b[["b_x0", "b_y0", "b_x1", "b_y1"]].to_numpy() + shift
    wh = b[["image_w", "image_h", "image_w", "image_h"]].to_numpy()
    box = np.clip(box, 0.0, wh)
    lo, hi = np.minimum(box[:, :2], box[:, 2:]), np.maximum(box[:, :2], box[:, 2:])
    coco = b.label_class.astype(str).str.lower().map(lambda c: (cmap.get(c) or [""])[0]).to_numpy(dtype=object)
    found &= (coco != "") & (hi - lo > 0).all(axis=1)
    true = pd.DataFrame({"path": b.render_path.to_numpy(dtype=object), "x0": lo[:, 0], "y0": lo[:, 1],
                         "x1": hi[:, 0], "y1": hi[:, 1], "score": 1.0 - sev / 2, "coco_class": coco})[found]
    return pd.concat([true, _false_positives(b, sev, rng)], ignore_index=True)
