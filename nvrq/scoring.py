"""``nvrq score``: NVRQ, NVRQ-CA and pixel metrics for every pair of a pairs table.

Pipeline (encoder-bound by design):

1. Pairs are grouped by GT image; a background thread decodes each group's GT image and
   its render images once (:func:`nvrq.crops.read_rgb`), cuts the crops, computes the pixel
   metrics and prepares the encoder inputs (square pad + bicubic resize).
2. The GT crop of an object at a frame is shared by every render offset, so it is embedded
   once: a frame with 7 offsets needs 8 encoder images for 7 pairs, not 14.
3. The main thread batches encoder inputs (``batch_size``) and runs the model under
   ``torch.inference_mode()`` while the next groups are decoded.

NVRQ (paper Eq. 4): ``S = (cos(f_gt, f_render) + 1) / 2``. NVRQ-CA (Eq. 5):
``S / tau * w`` for ``S < tau``, else ``w + (1 - w) * ((S - tau) / (1 - tau))**2``, ``w = 0.1``.

Timing (``ScoreResult.timing``; ``METRICS.timing.csv``): per metric column, its own compute
seconds (pixel metric calls; for ``nvrq``/``nvrq_ca`` the encoder input preparation and
forward passes) plus the shared image decoding seconds -- roughly what that metric alone
would cost on these pairs.

>>> import numpy as np
>>> nvrq_ca(np.array([0.0, 0.325, 0.65, 1.0]), tau=0.65).round(4).tolist()
[0.0, 0.05, 0.1, 1.0]
"""

from __future__ import annotations

import os
import queue
import sys
import threading
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from tqdm import tqdm

from data_schema.errors import InputError
from data_schema.tables import GT_BOX_COLUMNS, RENDER_BOX_COLUMNS, pair_boxes, pair_image_paths
from nvrq.crops import cut_box, encoder_input, read_rgb, resize_to
from nvrq.metrics import REGISTRY, split_column

__all__ = ["nvrq_similarity", "nvrq_ca", "W_LOW", "resolve_metrics", "ScoreResult",
           "score_pairs", "embed_crops", "REQUIRED_COLUMNS"]

W_LOW = 0.1
REQUIRED_COLUMNS = ("pair_id", "gt_path", "render_path", *GT_BOX_COLUMNS, *RENDER_BOX_COLUMNS)


def nvrq_similarity(f_gt: np.ndarray, f_render: np.ndarray) -> np.ndarray:
    """Paper Eq. 4: ``(cos + 1) / 2`` row-wise for embeddings (N, D) -> (N,) in [0, 1].

    >>> nvrq_similarity(np.array([[1.0, 0.0], [1.0, 0.0]]), np.array([[2.0, 0.0], [-1.0, 0.0]])).tolist()
    [1.0, 0.0]
    """
    a = np.asarray(f_gt, np.float64)
    b = np.asarray(f_render, np.float64)
    denom = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.einsum("nd,nd->n", a, b) / denom
    return np.clip((cos + 1.0) / 2.0, 0.0, 1.0)


def nvrq_ca(s: np.ndarray, *, tau: float, w_low: float = W_LOW) -> np.ndarray:
    """Paper Eq. 5, curve-adjusted NVRQ of ``s`` (N,) with knee ``tau`` in (0, 1)."""
    if not 0.0 < tau < 1.0:
        raise InputError("--tau", None, "a number strictly between 0 and 1", tau)
    s = np.asarray(s, np.float64)
    low = s / tau * w_low
    high = w_low + (1.0 - w_low) * ((s - tau) / (1.0 - tau)) ** 2
    return np.where(s < tau, low, high)


def resolve_metrics(names: Sequence[str], encoder: str) -> list[str]:
    """Output column names for ``--metrics`` entries: ``nvrq`` -> ``nvrq:ENCODER``.

    >>> resolve_metrics(["psnr", "nvrq", "nvrq_ca"], "dinov2-small")
    ['psnr', 'nvrq:dinov2-small', 'nvrq_ca:dinov2-small']
    """
    known = sorted(n for n, i in REGISTRY.items() if i.kind == "metric")
    columns: list[str] = []
    for raw in names:
        family, enc = split_column(raw.strip())
        info = REGISTRY.get(family)
        if info is None or info.kind != "metric" or (enc is not None and not info.needs_encoder):
            raise InputError("--metrics", None, f"metric names among {', '.join(known)}", raw)
        if info.needs_encoder and enc not in (None, encoder):
            raise InputError("--metrics", raw, f"the encoder given by --encoder ({encoder})", enc)
        col = f"{family}:{encoder}" if info.needs_encoder else family
        if col not in columns:
            columns.append(col)
    if not columns:
        raise InputError("--metrics", None, "at least one metric", "none")
    return columns


@dataclass
class ScoreResult:
    """``table``: ``pair_id`` + one column per metric, rows in the pairs' order.
    ``timing``: columns ``metric, seconds, pairs``. ``n_encoder_images``: crops embedded."""

    table: pd.DataFrame
    timing: pd.DataFrame
    n_pairs: int
    n_encoder_images: int
    n_images_decoded: int
    tau: float | None = None


def _unique_ids(paths: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ids (N,) of unique (path, box) crops and the first row of each unique crop."""
    key = pd.DataFrame({"p": paths, "x0": boxes[:, 0], "y0": boxes[:, 1],
                        "x1": boxes[:, 2], "y1": boxes[:, 3]})
    ids = key.groupby(list(key.columns), sort=False).ngroup().to_numpy()
    _, first = np.unique(ids, return_index=True)
    return ids, first


class _Stop:
    pass


def _producer(groups, out_q, stop, *, gt_paths, r_paths, gt_boxes, r_boxes, gt_ids, r_ids,
              pixel_fns, input_size, stats, where):
    """Decode/crop/prepare one group (pairs sharing a GT image) at a time into ``out_q``."""
    try:
        seen_gt: set[int] = set()
        seen_r: set[int] = set()
        for rows in groups:
            if stop.is_set():
                break
            t0 = time.perf_counter()
            images = {}
            for p in [gt_paths[rows[0]], *pd.unique(r_paths[rows])]:
                if p not in images:
                    images[p] = read_rgb(p)
            stats["decode"] += time.perf_counter() - t0
            stats["decoded"] += len(images)
            enc_ids, enc_inputs = [], []
            pixel = {name: np.empty(len(rows)) for name in pixel_fns}
            for k, i in enumerate(rows):
                gt = cut_box(images[gt_paths[i]], gt_boxes[i], where=f"{where}: pair {i + 2} GT box")
                rc = cut_box(images[r_paths[i]], r_boxes[i], where=f"{where}: pair {i + 2} render box")
                if pixel_fns:
                    rs = resize_to(rc, gt.shape[0], gt.shape[1])
                    for name, fn in pixel_fns.items():
                        t1 = time.perf_counter()
                        pixel[name][k] = fn(gt, rs)
                        stats[name] += time.perf_counter() - t1
                if input_size:
                    t1 = time.perf_counter()
                    if gt_ids[i] not in seen_gt:
                        seen_gt.add(gt_ids[i])
                        enc_ids.append(("g", gt_ids[i]))
                        enc_inputs.append(encoder_input(gt, input_size))
                    if r_ids[i] not in seen_r:
                        seen_r.add(r_ids[i])
                        enc_ids.append(("r", r_ids[i]))
                        enc_inputs.append(encoder_input(rc, input_size))
                    stats["prepare"] += time.perf_counter() - t1
            out_q.put((rows, pixel, enc_ids, enc_inputs))
    except BaseException as exc:  # handed to the main thread, re-raised there
        out_q.put(exc)
    out_q.put(_Stop)


def score_pairs(
    pairs: pd.DataFrame,
    *,
    metrics: Sequence[str] = ("psnr", "ssim", "nvrq", "nvrq_ca"),
    encoder=None,
    tau: float | None = None,
    scene_root: str | os.PathLike | None = None,
    base: str | os.PathLike | None = None,
    batch_size: int = 32,
    progress: bool = True,
    where: str = "pairs",
) -> ScoreResult:
    """Score every row of ``pairs`` (SPEC section 3 columns; ``scene_root`` column or argument).

    ``metrics``: column names from :func:`resolve_metrics`. ``encoder``: a loaded
    :class:`nvrq.encoders.Encoder`, needed for ``nvrq:*``/``nvrq_ca:*``; ``tau`` for NVRQ-CA.
    """
    missing = [c for c in REQUIRED_COLUMNS if c not in pairs.columns]
    if missing:
        raise InputError(where, f"column {missing[0]!r}", f"the columns {', '.join(REQUIRED_COLUMNS)}",
                         f"columns {', '.join(map(str, pairs.columns))}")
    if batch_size < 1:
        raise InputError("--batch-size", None, "a positive integer", batch_size)
    metrics = list(metrics)
    enc_cols = [m for m in metrics if REGISTRY[split_column(m)[0]].needs_encoder]
    pixel_fns = {m: REGISTRY[m].fn for m in metrics if m not in enc_cols}
    if enc_cols and encoder is None:
        raise ValueError("encoder metrics requested without an encoder")
    if any(split_column(c)[0] == "nvrq_ca" for c in enc_cols) and tau is None:
        raise InputError("--tau", None, f"a tau for encoder {encoder.spec.name} (run `nvrq calibrate-tau` "
                         "or pass --tau)", "none in the registry or the user config")
    n = len(pairs)
    gt_paths = pair_image_paths(pairs, "gt_path", scene_root=scene_root, base=base, where=where)
    r_paths = pair_image_paths(pairs, "render_path", scene_root=scene_root, base=base, where=where)
    gt_boxes = pair_boxes(pairs, GT_BOX_COLUMNS, where=where)
    r_boxes = pair_boxes(pairs, RENDER_BOX_COLUMNS, where=where)
    gt_ids, _ = _unique_ids(gt_paths, gt_boxes)
    r_ids, _ = _unique_ids(r_paths, r_boxes)
    groups = [np.asarray(g) for g in pd.Series(np.arange(n)).groupby(gt_paths, sort=False).groups.values()]

    stats = {name: 0.0 for name in pixel_fns} | {"decode": 0.0, "prepare": 0.0, "forward": 0.0,
                                                  "decoded": 0}
    input_size = encoder.spec.input_size if enc_cols else 0
    out_q: queue.Queue = queue.Queue(maxsize=8)
    stop = threading.Event()
    worker = threading.Thread(target=_producer, args=(groups, out_q, stop), daemon=True, kwargs=dict(
        gt_paths=gt_paths, r_paths=r_paths, gt_boxes=gt_boxes, r_boxes=r_boxes, gt_ids=gt_ids,
        r_ids=r_ids, pixel_fns=pixel_fns, input_size=input_size, stats=stats, where=where))


    pixel_vals = {name: np.full(n, np.nan) for name in pixel_fns}
    emb_gt = emb_r = None
    buf_ids: list = []
    buf_inputs: list = []
    waiting: deque = deque()  # (end position in the input stream, n pairs) per group
    done_pos = 0
    n_encoded = 0

    def run_batch(k: int) -> None:
        """Embed the first ``k`` buffered encoder inputs."""
        nonlocal emb_gt, emb_r, done_pos, n_encoded, buf_ids, buf_inputs
        t0 = time.perf_counter()
        feats = encoder.embed(np.stack(buf_inputs[:k]))
        stats["forward"] += time.perf_counter() - t0
        if emb_gt is None:
            emb_gt = np.full((gt_ids.max() + 1, feats.shape[1]), np.nan, np.float32)
            emb_r = np.full((r_ids.max() + 1, feats.shape[1]), np.nan, np.float32)
        for (kind, idx), f in zip(buf_ids[:k], feats, strict=True):
            (emb_gt if kind == "g" else emb_r)[idx] = f
        done_pos += k
        n_encoded += k
        buf_ids, buf_inputs = buf_ids[k:], buf_inputs[k:]

    def advance(bar) -> None:
        """Count the pairs whose crops are all embedded."""
        while waiting and waiting[0][0] <= done_pos:
            bar.update(waiting.popleft()[1])

    t_start = time.perf_counter()
    worker.start()
    submitted = 0
    with tqdm(total=n, unit="pair", file=sys.stderr, disable=not progress, desc="score",
              dynamic_ncols=True) as bar:
        try:
            while True:
                item = out_q.get()
                if item is _Stop:
                    break
                if isinstance(item, BaseException):
                    raise item
                rows, pixel, enc_ids, enc_inputs = item
                for name, vals in pixel.items():
                    pixel_vals[name][rows] = vals
                buf_ids.extend(enc_ids)
                buf_inputs.extend(enc_inputs)
                submitted += len(enc_inputs)
                waiting.append((submitted, len(rows)))
                while len(buf_inputs) >= batch_size:
                    run_batch(batch_size)
                advance(bar)
            if buf_inputs:
                run_batch(len(buf_inputs))
            advance(bar)
        finally:
            stop.set()
            while worker.is_alive():  # unblock the producer if we stop early
                try:
                    out_q.get(timeout=0.1)
                except queue.Empty:
                    pass
    wall = time.perf_counter() - t_start

    table = pd.DataFrame({"pair_id": pairs["pair_id"].to_numpy()})
    s = None
    if enc_cols:
        s = nvrq_similarity(emb_gt[gt_ids], emb_r[r_ids]) if n else np.zeros(0)
    for col in metrics:
        family, _ = split_column(col)
        if col in pixel_fns:
            table[col] = pixel_vals[col]
        elif family == "nvrq":
            table[col] = s
        else:
            table[col] = nvrq_ca(s, tau=tau)
    enc_seconds = stats["prepare"] + stats["forward"]
    timing = pd.DataFrame({
        "metric": metrics,
        "seconds": [stats["decode"] + (stats[m] if m in pixel_fns else enc_seconds) for m in metrics],
        "pairs": n,
    })
    timing.attrs.update(wall_seconds=wall, forward_seconds=stats["forward"],
                        decode_seconds=stats["decode"], prepare_seconds=stats["prepare"])
    return ScoreResult(table, timing, n, n_encoded, int(stats["decoded"]), tau)


def embed_crops(paths: Sequence[str], boxes: np.ndarray, encoder, *, batch_size: int = 32,
                progress: bool = True, where: str = "crops") -> np.ndarray:
    """Embeddings (N, D) float32 of the crops ``boxes`` (N, 4) (inclusive ``[x0, y0, x1, y1]``)
    of the images ``paths`` (N,); each image is decoded once. Used by ``calibrate-tau``."""
    paths = np.asarray([os.fspath(p) for p in paths], dtype=object)
    boxes = np.asarray(boxes, np.int64).reshape(-1, 4)
    size = encoder.spec.input_size
    inputs = np.empty((len(paths), size, size, 3), np.uint8)
    by_image = pd.Series(np.arange(len(paths))).groupby(paths, sort=False).groups
    for path, rows in tqdm(by_image.items(), total=len(by_image), unit="image", file=sys.stderr,
                           disable=not progress, desc="crops"):
        image = read_rgb(path)
        for i in rows:
            inputs[i] = encoder_input(cut_box(image, boxes[i], where=f"{where}: row {i + 2}"), size)
    feats = [encoder.embed(inputs[k:k + batch_size]) for k in
             tqdm(range(0, len(paths), batch_size), unit="batch", file=sys.stderr,
                  disable=not progress, desc="embed")]
    return np.concatenate(feats) if feats else np.zeros((0, 0), np.float32)
