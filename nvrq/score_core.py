"""The one crop-scoring core: pairs table -> crop batches -> metric columns.

Every command that compares crops (``nvrq score``, ``calibrate-tau``, ``stability``, the
``imagenet``/``clip`` proxies) and the distributed engines run through these functions:

- :func:`iter_crop_batches` turns a pairs table into :class:`CropBatch` es. It reads files:
  pairs are grouped by GT image, each image of a batch is decoded once
  (:func:`nvrq.crops.read_rgb`), one GT image's pairs (every view and method) never straddle
  two batches, and the GT crop shared by every render view and method of an object at a frame
  appears once in ``gt_crops`` (keyed by GT image and box: ``G + M·R`` encoder images for M
  methods, docs/FORMATS.md §4).
  With ``background=True`` one thread decodes ahead (bounded queue; its exceptions are
  re-raised in the caller); ``decode_threads`` decode a batch's images in parallel.
  :func:`decode_schedule` chooses both so that decoding does not stall a CPU encoder.
- :func:`score_crop_batch` is pure (no files, globals or CLI): it maps one batch to its metric
  columns. Full-reference pixel metrics compare the GT crop with the render crop
  bicubic-resized to the GT crop's size (docs/FORMATS.md §4); no-reference metrics
  (``reference=False`` in :mod:`nvrq.metrics`) score the raw render crop alone, so a batch of
  them needs no GT crops (``gt_crops=[]``, ``gt_index=None``); ``nvrq``/``nvrq_ca`` use encoder
  embeddings, each GT crop embedded once (paper Eq. 4, 5 in :mod:`nvrq.scoring`).
- :func:`encoder_inputs`, :func:`run_batched` and :func:`embed_crops` are the lower pieces:
  square-pad + bicubic resize of a crop list, and a model run over it ``batch_size`` at a time.

Timing keys accumulated into ``timings`` (seconds): one per pixel metric column (its own
calls), ``prepare`` (encoder inputs), ``forward`` (model passes); :attr:`CropBatch.decode_seconds`
holds a batch's decoding time.

>>> import numpy as np
>>> gt = np.zeros((4, 6, 3), np.uint8)
>>> b = CropBatch(np.array([0, 1]), [gt], np.array([0, 0]), [gt, np.full((2, 3, 3), 9, np.uint8)])
>>> score_crop_batch(b, metrics=["mse"])["mse"].tolist()
[0.0, 81.0]
>>> nr = CropBatch(np.array([0]), [], None, [np.full((4, 6, 3), 9, np.uint8)])  # no GT crops
>>> score_crop_batch(nr, metrics=["entropy"])["entropy"].tolist()
[0.0]
"""

from __future__ import annotations

import os
import queue
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import pandas as pd

from data_schema.errors import InputError, check_int
from data_schema.tables import GT_BOX_COLUMNS, RENDER_BOX_COLUMNS, pair_boxes, pair_image_paths
from nvrq.crops import cut_box, encoder_input, read_rgb, resize_to
from nvrq.metrics import REGISTRY, MetricInfo, split_column

__all__ = ["CropBatch", "iter_crop_batches", "score_crop_batch", "embed_crops", "encoder_inputs",
           "run_batched", "pair_outputs", "read_crops", "check_metric_args", "check_tau",
           "encoder_columns", "column_info", "reference_columns", "needs_tau", "column_seconds", "check_positive", "decode_schedule", "gt_groups", "pack_groups", "usable_cores", "nvrq_similarity", "nvrq_ca",
           "W_LOW", "CROP_COLUMNS"]

W_LOW = 0.1
#: the pairs-table columns :func:`iter_crop_batches` reads (besides ``scene_root``)
CROP_COLUMNS = ("gt_path", "render_path", *GT_BOX_COLUMNS, *RENDER_BOX_COLUMNS)


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
    """Paper Eq. 5, curve-adjusted NVRQ of ``s`` (N,) with knee ``tau`` in (0, 1).

    >>> nvrq_ca(np.array([0.0, 0.325, 0.65, 1.0]), tau=0.65).round(4).tolist()
    [0.0, 0.05, 0.1, 1.0]
    """
    check_tau(tau)
    s = np.asarray(s, np.float64)
    low = s / tau * w_low
    high = w_low + (1.0 - w_low) * ((s - tau) / (1.0 - tau)) ** 2
    return np.where(s < tau, low, high)


def check_tau(tau) -> None:
    """:class:`InputError` naming ``tau`` unless it is a number in (0, 1)."""
    if tau is None or isinstance(tau, bool) or not isinstance(tau, (int, float, np.integer, np.floating)) \
            or not 0.0 < tau < 1.0:
        raise InputError("tau", None, "a number strictly between 0 and 1 (NVRQ-CA knee; "
                         "`nvrq calibrate-tau` measures one)", tau)


@dataclass(frozen=True)
class CropBatch:
    """Crops of ``P`` pairs. ``rows`` (P,) int64: the pairs' positions in the pairs table;
    ``gt_crops``: K unique GT crops (h, w, 3) uint8 RGB; ``gt_index`` (P,) int64: pair k's GT
    crop is ``gt_crops[gt_index[k]]``; ``render_crops``: P render crops (h, w, 3) uint8 RGB.
    Without GT (no-reference metrics only): ``gt_crops=[]`` and ``gt_index=None``.
    ``n_images_decoded``/``decode_seconds``: image files read to build it and the time spent."""

    rows: np.ndarray
    gt_crops: list[np.ndarray]
    gt_index: np.ndarray
    render_crops: list[np.ndarray]
    n_images_decoded: int = 0
    decode_seconds: float = 0.0

    @property
    def n_crops(self) -> int:
        """Crops an encoder sees for this batch: K GT + P render crops."""
        return len(self.gt_crops) + len(self.render_crops)


# --- encoder inputs and model runs -------------------------------------------------------------

def encoder_inputs(crops: Sequence[np.ndarray], size: int) -> np.ndarray:
    """Encoder inputs (N, size, size, 3) uint8 of ``crops``: black square pad + bicubic resize
    (:func:`nvrq.crops.encoder_input`, docs/FORMATS.md §4)."""
    out = np.empty((len(crops), size, size, 3), np.uint8)
    for k, crop in enumerate(crops):
        out[k] = encoder_input(crop, size)
    return out


def run_batched(crops: Sequence[np.ndarray], fn: Callable[[np.ndarray], np.ndarray], *, size: int,
                batch_size: int = 32, timings: dict | None = None) -> np.ndarray:
    """``fn`` (uint8 (B, size, size, 3) -> (B, D)) over :func:`encoder_inputs` of ``crops``,
    ``batch_size`` crops at a time -> (N, D) (``(0, 0)`` for no crops). Adds ``prepare`` and
    ``forward`` seconds to ``timings``."""
    check_positive("batch_size", batch_size)
    times = timings if timings is not None else {}
    parts = []
    for k in range(0, len(crops), batch_size):
        t0 = time.perf_counter()
        inputs = encoder_inputs(crops[k:k + batch_size], size)
        t1 = time.perf_counter()
        parts.append(np.asarray(fn(inputs)))
        t2 = time.perf_counter()
        times["prepare"] = times.get("prepare", 0.0) + t1 - t0
        times["forward"] = times.get("forward", 0.0) + t2 - t1
    return np.concatenate(parts) if parts else np.zeros((0, 0), np.float32)


def pair_outputs(batch: CropBatch, fn: Callable[[np.ndarray], np.ndarray], *, size: int,
                 batch_size: int = 32, timings: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(out_gt, out_render)``, each (P, D): ``fn`` (see :func:`run_batched`) of pair k's GT crop
    and render crop; every GT crop of the batch is run once."""
    k = len(batch.gt_crops)
    out = run_batched([*batch.gt_crops, *batch.render_crops], fn, size=size, batch_size=batch_size,
                      timings=timings)
    return out[:k][np.asarray(batch.gt_index, np.int64)], out[k:]


def embed_crops(crops: Sequence[np.ndarray], encoder, *, batch_size: int = 32,
                timings: dict | None = None) -> np.ndarray:
    """Embeddings (N, D) of ``crops`` (each (h, w, 3) uint8 RGB) by ``encoder``
    (``encoder.embed(uint8 (B, S, S, 3)) -> (B, D)``, ``S = encoder.spec.input_size``)."""
    if encoder is None:
        raise InputError("encoder", None, "a loaded encoder", None)
    return run_batched(crops, encoder.embed, size=encoder.spec.input_size, batch_size=batch_size,
                       timings=timings)


# --- the pure per-batch scorer -----------------------------------------------------------------

def check_positive(name: str, value) -> None:
    """:class:`InputError` naming ``name`` unless ``value`` is a positive integer (not a bool;
    :func:`data_schema.errors.check_int`)."""
    check_int(name, value, low=1)


def column_info(column: str) -> MetricInfo:
    """The registry entry computing metric column ``column`` (a ``members`` family resolves its
    member, e.g. ``pyiqa:lpips``); :class:`InputError` naming ``metrics`` when there is none."""
    family, member = split_column(str(column))
    info = REGISTRY.get(family)
    if info is None or info.kind != "metric":
        known = ", ".join(sorted(n for n, i in REGISTRY.items() if i.kind == "metric"))
        raise InputError("metrics", None, f"metric columns among {known}", column)
    if info.members is not None:
        if member is None:
            raise InputError("metrics", column, f"{family}:NAME", column)
        return info.members(member)
    return info


def reference_columns(metrics: Sequence[str]) -> list[str]:
    """The columns of ``metrics`` that need the GT crop (full-reference and encoder metrics).

    >>> reference_columns(["psnr", "niqe", "nvrq:e", "entropy"])
    ['psnr', 'nvrq:e']
    """
    return [m for m in metrics if column_info(m).needs_encoder or column_info(m).reference]


def encoder_columns(metrics: Sequence[str]) -> list[str]:
    """The columns of ``metrics`` that need an encoder (``nvrq:*``, ``nvrq_ca:*``)."""
    return [m for m in metrics if REGISTRY[split_column(m)[0]].needs_encoder]


def column_seconds(columns: Sequence[str], model_columns, timings: dict) -> list[float]:
    """Seconds per column of ``timings`` (the keys in the module docstring, plus ``decode``):
    the shared decode plus the column's own calls, or, for one of ``model_columns``, all
    model input preparation and passes (``prepare + forward``).

    >>> column_seconds(["psnr", "nvrq:e"], {"nvrq:e"}, {"decode": 1.0, "psnr": 0.5, "forward": 2.0})
    [1.5, 3.0]
    """
    decode = float(timings.get("decode", 0.0))
    model = float(timings.get("prepare", 0.0)) + float(timings.get("forward", 0.0))
    return [decode + (model if c in model_columns else float(timings.get(c, 0.0))) for c in columns]


def needs_tau(metrics: Sequence[str]) -> bool:
    """Whether ``metrics`` hold an NVRQ-CA column (which needs the knee ``tau``).

    >>> needs_tau(["psnr", "nvrq:e"]), needs_tau(["nvrq_ca:e"])
    (False, True)
    """
    return any(split_column(m)[0] == "nvrq_ca" for m in metrics)


def check_metric_args(metrics: Sequence[str], *, encoder=None, tau=None, batch_size: int = 32) -> None:
    """Validate :func:`score_crop_batch`'s arguments; :class:`InputError` names the parameter."""
    for m in metrics:
        column_info(m)
    if not metrics:
        raise InputError("metrics", None, "at least one metric", "none")
    check_positive("batch_size", batch_size)
    enc_cols = encoder_columns(metrics)
    if enc_cols and encoder is None:
        raise InputError("encoder", None, f"a loaded encoder for {', '.join(enc_cols)}", None)
    if needs_tau(metrics):
        check_tau(tau)


def _pixel_columns(batch: CropBatch, names: list[str], times: dict) -> dict[str, np.ndarray]:
    """Encoder-free metrics (P,) per name: a full-reference one compares the GT crop with the
    render crop resized to the GT crop's size; a no-reference one scores the raw render crop."""
    out = {name: np.empty(len(batch.render_crops)) for name in names}
    infos = {name: column_info(name) for name in names}
    full = {n: i.fn for n, i in infos.items() if i.reference}
    blind = {n: i.fn for n, i in infos.items() if not i.reference}
    for k, crop in enumerate(batch.render_crops):
        for name, fn in blind.items():
            t0 = time.perf_counter()
            out[name][k] = fn(crop)
            times[name] = times.get(name, 0.0) + time.perf_counter() - t0
        if full:
            gt = batch.gt_crops[batch.gt_index[k]]
            rs = resize_to(crop, gt.shape[0], gt.shape[1])
        for name, fn in full.items():
            t0 = time.perf_counter()
            out[name][k] = fn(gt, rs)
            times[name] = times.get(name, 0.0) + time.perf_counter() - t0
    return out


def score_crop_batch(batch: CropBatch, *, metrics: Sequence[str], encoder=None, tau=None,
                     batch_size: int = 32, timings: dict | None = None) -> dict[str, np.ndarray]:
    """Metric columns ``{column: (P,) float64}`` of one :class:`CropBatch`, in ``metrics`` order.

    ``metrics``: column names as :func:`nvrq.scoring.resolve_metrics` gives them; ``encoder``
    for ``nvrq:*``/``nvrq_ca:*`` (GT crops embedded once each, ``batch_size`` crops per pass);
    ``tau`` in (0, 1) for ``nvrq_ca:*``. Per-stage seconds are added to ``timings``. A batch
    without GT crops (``gt_crops=[]``) takes only no-reference metrics.
    """
    metrics = list(metrics)
    check_metric_args(metrics, encoder=encoder, tau=tau, batch_size=batch_size)
    if len(batch.render_crops) and not len(batch.gt_crops if batch.gt_crops is not None else ()):
        needs_gt = reference_columns(metrics)
        if needs_gt:
            raise InputError("gt_crops", None, f"GT crops for the reference metrics {', '.join(needs_gt)}",
                             "none")
    times = timings if timings is not None else {}
    enc_cols = encoder_columns(metrics)
    out = _pixel_columns(batch, [m for m in metrics if m not in enc_cols], times)
    if enc_cols:
        f_gt, f_render = pair_outputs(batch, encoder.embed, size=encoder.spec.input_size,
                                      batch_size=batch_size, timings=times)
        s = nvrq_similarity(f_gt, f_render)
        for col in enc_cols:
            out[col] = s if split_column(col)[0] == "nvrq" else nvrq_ca(s, tau=tau)
    return {m: np.asarray(out[m], np.float64) for m in metrics}


# --- reading crops from a pairs table ----------------------------------------------------------

@dataclass(frozen=True)
class _Plan:
    """Absolute image paths (N,) and inclusive boxes (N, 4) of every pair."""

    gt_paths: np.ndarray
    r_paths: np.ndarray
    gt_boxes: np.ndarray
    r_boxes: np.ndarray


def _plan(pairs: pd.DataFrame, *, scene_root, base, where: str, follow: bool | None = None) -> _Plan:
    missing = [c for c in CROP_COLUMNS if c not in pairs.columns]
    if missing:
        raise InputError(where, f"column {missing[0]!r}", f"the columns {', '.join(CROP_COLUMNS)}",
                         f"columns {', '.join(map(str, pairs.columns))}")
    paths = {c: pair_image_paths(pairs, c, scene_root=scene_root, base=base, where=where, follow=follow)
             for c in ("gt_path", "render_path")}
    return _Plan(paths["gt_path"], paths["render_path"], pair_boxes(pairs, GT_BOX_COLUMNS, where=where),
                 pair_boxes(pairs, RENDER_BOX_COLUMNS, where=where))


def gt_groups(gt_paths: np.ndarray) -> list[np.ndarray]:
    """Positions (int64) of each GT image's rows, images in first-appearance order.

    >>> [g.tolist() for g in gt_groups(np.array(list("abab")))]
    [[0, 2], [1, 3]]
    """
    codes, _ = pd.factorize(np.asarray(gt_paths))
    order = np.argsort(codes, kind="stable")
    return np.split(order.astype(np.int64), np.flatnonzero(np.diff(codes[order])) + 1) if len(order) else []


def pack_groups(groups: Sequence[np.ndarray], max_pairs: int) -> list[np.ndarray]:
    """Whole ``groups`` packed in order, up to ``max_pairs`` rows each; a group with more rows
    than that is a pack of its own (crop batches here, Ray shards in :mod:`nvrq.engines.shards`).

    >>> [p.tolist() for p in pack_groups([np.array([0, 1]), np.array([2]), np.array([3, 4, 5])], 3)]
    [[0, 1, 2], [3, 4, 5]]
    """
    packs, cur, size = [], [], 0
    for g in groups:
        if cur and size + len(g) > max_pairs:
            packs.append(np.concatenate(cur))
            cur, size = [], 0
        cur.append(np.asarray(g, np.int64))
        size += len(g)
    if cur:
        packs.append(np.concatenate(cur))
    return packs


def _chunks(gt_paths: np.ndarray, max_pairs: int) -> list[np.ndarray]:
    """Row groups: whole GT images (first-appearance order) packed up to ``max_pairs`` rows
    (:func:`pack_groups`). The first chunk is the first image alone, so the encoder waits for
    one image's files rather than a full chunk's.

    >>> [c.tolist() for c in _chunks(np.array(list("aabbccd")), 4)]
    [[0, 1], [2, 3, 4, 5], [6]]
    """
    groups = gt_groups(gt_paths)
    return [groups[0], *pack_groups(groups[1:], max_pairs)] if groups else []


def _load_batch(rows: np.ndarray, plan: _Plan, where: str, pool: ThreadPoolExecutor | None) -> CropBatch:
    """Decode the images of ``rows`` once each (on ``pool`` when given) and cut their crops (copies)."""
    t0 = time.perf_counter()
    paths = pd.unique(np.concatenate([plan.gt_paths[rows], plan.r_paths[rows]]))
    images = dict(zip(paths, pool.map(read_rgb, paths) if pool is not None else map(read_rgb, paths), strict=True))
    seconds = time.perf_counter() - t0
    gt_keys: dict[tuple, int] = {}
    gt_crops, gt_index, r_crops = [], np.empty(len(rows), np.int64), []
    for k, i in enumerate(rows):
        key = (plan.gt_paths[i], *plan.gt_boxes[i].tolist())
        if key not in gt_keys:
            gt_keys[key] = len(gt_crops)
            gt = cut_box(images[plan.gt_paths[i]], plan.gt_boxes[i], where=f"{where}: pair {i + 2} GT box")
            gt_crops.append(gt.copy())
        gt_index[k] = gt_keys[key]
        rc = cut_box(images[plan.r_paths[i]], plan.r_boxes[i], where=f"{where}: pair {i + 2} render box")
        r_crops.append(rc.copy())
    return CropBatch(np.asarray(rows, np.int64), gt_crops, gt_index, r_crops, len(images), seconds)


_DONE = object()


def _in_background(items: Iterator, *, maxsize: int = 2) -> Iterator:
    """Run ``items`` in one daemon thread, ``maxsize`` ahead; its exceptions re-raise here."""
    out_q: queue.Queue = queue.Queue(maxsize=maxsize)
    stop = threading.Event()

    def produce() -> None:
        try:
            for item in items:
                if stop.is_set():
                    return
                out_q.put((item, None))
        except BaseException as exc:  # handed to the consumer
            out_q.put((None, exc))
        out_q.put((_DONE, None))

    worker = threading.Thread(target=produce, daemon=True, name="nvrq-crop-decode")
    worker.start()
    try:
        while True:
            item, exc = out_q.get()
            if exc is not None:
                raise exc
            if item is _DONE:
                return
            yield item
    finally:
        stop.set()
        while worker.is_alive():  # unblock a producer waiting on a full queue
            try:
                out_q.get(timeout=0.1)
            except queue.Empty:
                pass


def iter_crop_batches(pairs: pd.DataFrame, *, scene_root: str | os.PathLike | None = None,
                      base: str | os.PathLike | None = None, max_pairs: int = 256,
                      background: bool = True, decode_threads: int = 1,
                      where: str = "pairs", follow_links: bool | None = None) -> Iterator[CropBatch]:
    """:class:`CropBatch` es covering every row of ``pairs`` once (see the module docstring).

    ``pairs``: docs/FORMATS.md §3 columns (:data:`CROP_COLUMNS`; image paths relative to
    ``scene_root`` or the ``scene_root`` column, itself relative to ``base``). A batch holds
    whole GT images up to ``max_pairs`` pairs (more only when one image has more pairs).
    ``background``: decode one thread ahead of the caller; ``decode_threads`` > 1: a batch's
    images are decoded that many at a time (OpenCV releases the GIL while decoding);
    :func:`decode_schedule` picks both for an encoder.
    Bad columns, boxes and paths raise :class:`InputError` naming ``where`` and the row;
    ``follow_links``: the link rule of :func:`data_schema.tables.inside_scene` (default: the
    environment's).
    """
    check_positive("max_pairs", max_pairs)
    check_positive("decode_threads", decode_threads)
    plan = _plan(pairs, scene_root=scene_root, base=base, where=where, follow=follow_links)

    def batches() -> Iterator[CropBatch]:
        pool = ThreadPoolExecutor(decode_threads, thread_name_prefix="nvrq-decode") if decode_threads > 1 else None
        try:
            for rows in _chunks(plan.gt_paths, max_pairs):
                yield _load_batch(rows, plan, where, pool)
        finally:
            if pool is not None:
                pool.shutdown(wait=True, cancel_futures=True)
    return _in_background(batches()) if background else batches()


def usable_cores() -> int:
    """CPU cores this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # no affinity API (macOS, Windows)
        return os.cpu_count() or 1


def decode_schedule(encoder=None, *, pixel_metrics: bool = False, cores: int | None = None) -> tuple[bool, int]:
    """``(background, decode_threads)`` for :func:`iter_crop_batches` beside ``encoder``.

    A CPU encoder whose threads take every core, alone: decode *between* encoder passes, on
    every core. Decoding beside such an encoder takes a core its thread pool waits on at each
    layer, which costs it more than the decoding itself (efficientnet-lite0, 2 cores, 1280x720
    PNG: torch at 0.80-0.86 of its encoder-alone rate overlapped, 0.85-0.92 in phases;
    ``benchmarks/bench_score.py``). With ``pixel_metrics`` (computed in the caller's thread,
    one core) one background thread decodes while they run (measured as fast as phases, or a
    little faster). Otherwise (a GPU encoder, spare cores, no encoder): decode in the
    background on the cores the encoder or the caller's thread leaves free.

    >>> class Cpu:  # an encoder on the CPU with 2 threads
    ...     device, threads = "cpu", 2
    >>> decode_schedule(Cpu(), cores=2), decode_schedule(Cpu(), pixel_metrics=True, cores=2)
    ((False, 2), (True, 1))
    >>> decode_schedule(Cpu(), cores=16), decode_schedule(None, cores=4)
    ((True, 14), (True, 3))
    """
    cores = cores or usable_cores()
    if encoder is None or not str(getattr(encoder, "device", "cpu")).startswith("cpu"):
        return True, max(1, cores - 1)
    threads = int(getattr(encoder, "threads", None) or cores)
    if threads < cores:
        return True, cores - threads
    return (True, 1) if pixel_metrics else (False, cores)


def read_crops(paths: Sequence[str | os.PathLike], boxes: np.ndarray, *,
               where: str = "crops") -> list[np.ndarray]:
    """Crops ``boxes`` (N, 4) inclusive ``[x0, y0, x1, y1]`` of images ``paths`` (N,), as copies;
    each image decoded once (used for GT-only crop sets, e.g. ``calibrate-tau``)."""
    paths = [os.fspath(p) for p in paths]
    boxes = np.asarray(boxes, np.int64).reshape(-1, 4)
    crops: list = [None] * len(paths)
    by_image = pd.Series(np.arange(len(paths))).groupby(np.asarray(paths, dtype=object), sort=False).groups
    for path, rows in by_image.items():
        image = read_rgb(path)
        for i in rows:
            crops[i] = cut_box(image, boxes[i], where=f"{where}: row {i + 2}").copy()
    return crops
