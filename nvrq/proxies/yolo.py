"""Optional detector backend: Ultralytics YOLO from a local weights file writes a DETS table.

Layer: nvrq core, proxies (downstream quality proxies).

Install with ``pip install 'nvrq[yolo]'``. ``ultralytics`` is imported lazily, only by
:func:`run_yolo`; nothing is downloaded (the weights file must exist). Settings as in the
paper's proxy: confidence >= 0.1, per-class NMS at IoU 0.45 (``agnostic_nms=False``).
Boxes are Ultralytics' ``xyxy`` (continuous pixel-edge coordinates, the DETS convention).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from data_schema.errors import InputError
from data_schema.tables import pair_image_paths

__all__ = ["CONF", "NMS_IOU", "results_to_table", "run_yolo"]

CONF = 0.1
NMS_IOU = 0.45


def results_to_table(paths: Sequence[str], boxes, scores, classes, names: dict) -> pd.DataFrame:
    """One image per entry: ``boxes[k] (n_k, 4)`` xyxy, ``scores[k] (n_k,)``, ``classes[k] (n_k,)``
    integer ids into ``names`` -> DETS table (path, x0, y0, x1, y1, score, coco_class).

    Parameters
    ----------
    paths : sequence of str
        One image path per entry.
    boxes : sequence of (n_k, 4) float
        ``[x0, y0, x1, y1]`` pixels.
    scores : sequence of (n_k,) float
        Confidences.
    classes : sequence of (n_k,) int
        Class ids.
    names : dict
        Class id -> COCO class name.

    Returns
    -------
    pandas.DataFrame
        A DETS table.

    >>> results_to_table(["a.png"], [np.array([[1.0, 2, 3, 4]])], [np.array([0.5])], [np.array([2])],
    ...                  {2: "car"}).values.tolist()
    [['a.png', 1.0, 2.0, 3.0, 4.0, 0.5, 'car']]
    """
    frames = []
    for p, b, s, c in zip(paths, boxes, scores, classes, strict=True):
        b = np.asarray(b, np.float64).reshape(-1, 4)
        frames.append(
            pd.DataFrame(
                {
                    "path": p,
                    "x0": b[:, 0],
                    "y0": b[:, 1],
                    "x1": b[:, 2],
                    "y1": b[:, 3],
                    "score": np.asarray(s, np.float64).reshape(-1),
                    "coco_class": [str(names[int(k)]) for k in np.asarray(c).reshape(-1)],
                }
            )
        )
    cols = ["path", "x0", "y0", "x1", "y1", "score", "coco_class"]
    return pd.concat(frames, ignore_index=True)[cols] if frames else pd.DataFrame(columns=cols)


def run_yolo(
    pairs: pd.DataFrame,
    weights: str | os.PathLike,
    *,
    scene_root=None,
    device: str = "cpu",
    imgsz: int = 640,
    progress: bool = True,
    where: str = "pairs",
) -> pd.DataFrame:
    """Detect on every distinct render image of ``pairs``; ``path`` is written as in the pairs
    table (``render_path``, relative to the scene folder).

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table.
    weights : str or PathLike
        A local YOLO weights file.
    scene_root : str or Path, optional
        Where image paths are resolved from.
    device : str, optional
        A torch device.
    imgsz : int, optional
        Inference size, pixels.
    progress : bool, optional
        Show a progress bar over the distinct render images.
    where : str, optional
        How errors name ``pairs``.

    Returns
    -------
    pandas.DataFrame
        The detections, one row per box (a DETS table).
    """
    weights = Path(weights)
    if not weights.is_file():
        raise InputError(
            param="weights",
            expected="a local Ultralytics weights file (.pt); nvrq never downloads",
            got=str(weights),
        )
    try:
        from ultralytics import YOLO
    except ImportError:
        raise InputError(
            param="weights", expected="the ultralytics package: pip install 'nvrq[yolo]'", got="not installed"
        ) from None
    model = YOLO(os.fspath(weights))
    rel = pairs["render_path"].astype(str).to_numpy(dtype=object)
    absolute = pair_image_paths(pairs, "render_path", scene_root=scene_root, where=where)
    uniq = dict(zip(rel, absolute, strict=True))
    paths, boxes, scores, classes = [], [], [], []
    for r, a in tqdm(
        uniq.items(), unit="image", file=sys.stderr, disable=not progress, desc="yolo"
    ):
        res = model.predict(
            a, conf=CONF, iou=NMS_IOU, agnostic_nms=False, imgsz=imgsz, device=device, verbose=False
        )[0]
        paths.append(r)
        boxes.append(res.boxes.xyxy.cpu().numpy())
        scores.append(res.boxes.conf.cpu().numpy())
        classes.append(res.boxes.cls.cpu().numpy().astype(int))
    return results_to_table(paths, boxes, scores, classes, model.names)
