"""Crops from a pairs table: read each image once, group pairs by GT image, schedule decoding.

- :func:`iter_crop_batches` turns a pairs table into :class:`~nvrq.scoring.core.CropBatch` es
  for the in-memory core (:func:`nvrq.scoring.core.score_crop_batch`): pairs are grouped by GT
  image, each image of a batch is decoded once (:func:`nvrq.crops.read_rgb`), one GT image's
  pairs (every view and method) never straddle two batches, and the GT crop shared by every
  render view and method of an object at a frame appears once in ``gt_crops`` (keyed by GT
  image and box: ``G + M·R`` encoder images for M methods, docs/FORMATS.md §4). With ``background=True`` one thread decodes
  ahead (bounded queue; its exceptions are re-raised in the caller); ``decode_threads``
  decode a batch's images in parallel. :func:`decode_schedule` chooses both so that decoding
  does not stall a CPU encoder.
- :func:`gt_groups` and :func:`pack_groups` are the grouping rule (crop batches here, Ray
  shards in :mod:`nvrq.engines.shards`); :func:`read_crops` cuts a GT-only crop set.
"""

from __future__ import annotations

import os
import queue
import threading
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import pandas as pd

from data_schema.errors import InputError, check_int
from data_schema.tables import (
    GT_BOX_COLUMNS,
    RENDER_BOX_COLUMNS,
    PairsTable,
    pair_boxes,
    pair_image_paths,
    require_columns,
)
from nvrq.crops import cut_box, read_rgb
from nvrq.scoring.core import CropBatch

__all__ = ["CROP_COLUMNS", "iter_crop_batches", "read_crops", "gt_groups", "pack_groups",
           "decode_schedule", "usable_cores"]

#: the pairs-table columns :func:`iter_crop_batches` reads (besides ``scene_root``)
CROP_COLUMNS = ("gt_path", "render_path", *GT_BOX_COLUMNS, *RENDER_BOX_COLUMNS)


@dataclass(frozen=True)
class _Plan:
    """Absolute image paths (N,) and inclusive boxes (N, 4) of every pair."""

    gt_paths: np.ndarray
    r_paths: np.ndarray
    gt_boxes: np.ndarray
    r_boxes: np.ndarray


def _plan(pairs, *, scene_root, base, where: str, follow: bool | None = None) -> _Plan:
    if isinstance(pairs, PairsTable):  # checked once (data_schema.tables.pairs_table)
        return _Plan(pairs.gt_paths, pairs.render_paths, pairs.gt_boxes, pairs.render_boxes)
    require_columns(pairs, CROP_COLUMNS, where=where)
    paths = {c: pair_image_paths(pairs, c, scene_root=scene_root, base=base, where=where, follow=follow)
             for c in ("gt_path", "render_path")}
    return _Plan(paths["gt_path"], paths["render_path"], pair_boxes(pairs, GT_BOX_COLUMNS, where=where),
                 pair_boxes(pairs, RENDER_BOX_COLUMNS, where=where))


def gt_groups(gt_paths: np.ndarray) -> list[np.ndarray]:
    """The rows of each GT image, images in first-appearance order.

    Parameters
    ----------
    gt_paths : (N,) array
        Each row's GT image.

    Returns
    -------
    list of int64 arrays
        Row positions per image.

    >>> [g.tolist() for g in gt_groups(np.array(list("abab")))]
    [[0, 2], [1, 3]]
    """
    codes, _ = pd.factorize(np.asarray(gt_paths))
    order = np.argsort(codes, kind="stable")
    return np.split(order.astype(np.int64), np.flatnonzero(np.diff(codes[order])) + 1) if len(order) else []


def pack_groups(groups: Sequence[np.ndarray], max_pairs: int) -> list[np.ndarray]:
    """Whole ``groups`` packed in order (crop batches here, Ray shards in :mod:`nvrq.engines.shards`).

    Parameters
    ----------
    groups : sequence of int arrays
        Row groups, kept whole.
    max_pairs : int
        Rows per pack; a group with more rows than that is a pack of its own.

    Returns
    -------
    list of int64 arrays

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
    try:
        images = dict(zip(paths, pool.map(read_rgb, paths) if pool is not None else map(read_rgb, paths), strict=True))
    except InputError:  # an image that cannot be read: every one is then looked for
        raise _Unreadable from None
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


class _Unreadable(Exception):
    """A batch met an unreadable image (:func:`_all_unreadable` then names every one)."""


def _unreadable(path: str) -> str | None:
    """Why the image ``path`` cannot be read (``None`` when it can)."""
    try:
        read_rgb(path)
    except InputError as exc:
        return str(exc.got)
    return None


def _all_unreadable(plan: _Plan, chunks: list[np.ndarray], where: str) -> InputError:
    """One error naming every unreadable image of ``chunks`` (all bad files in one
    pass, with their count, rather than the first alone), grouped by reason, relative to the
    folder they share."""
    rows = np.concatenate(chunks) if chunks else np.zeros(0, np.int64)
    paths = [str(p) for p in pd.unique(np.concatenate([plan.gt_paths[rows], plan.r_paths[rows]]))]
    bad: dict[str, list[str]] = {}
    for p in paths:
        why = _unreadable(p)
        if why is not None:
            bad.setdefault(why, []).append(p)
    found = [p for ps in bad.values() for p in ps]
    root = os.path.commonpath([os.path.dirname(p) for p in found]) if found else ""
    listed = "; ".join(f"{why}: {', '.join(os.path.relpath(p, root) for p in ps)}" for why, ps in bad.items())
    n = len(found)
    return InputError(where, f"images under {root} ({listed})", "readable image files",
                      f"{n} unreadable image{'s' if n != 1 else ''} of {len(paths)}")


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


def iter_crop_batches(pairs: pd.DataFrame | PairsTable, *, scene_root: str | os.PathLike | None = None,
                      base: str | os.PathLike | None = None, max_pairs: int = 256,
                      background: bool = True, decode_threads: int = 1,
                      where: str = "pairs", follow_links: bool | None = None) -> Iterator[CropBatch]:
    """:class:`CropBatch` es covering every row of ``pairs`` once (see the module docstring).

    Parameters
    ----------
    pairs : pandas.DataFrame or PairsTable
        docs/FORMATS.md §3 columns (:data:`CROP_COLUMNS`; image paths relative to
        ``scene_root`` or the ``scene_root`` column, itself relative to ``base``), or a
        :class:`~data_schema.tables.PairsTable` read and checked once (``scene_root``, ``base``
        and ``follow_links`` are then its own).
    scene_root, base : path, optional
        Where the image paths are relative to.
    max_pairs : int
        A batch holds whole GT images up to this many pairs (more only when one image has more).
    background : bool
        Decode one thread ahead of the caller.
    decode_threads : int
        > 1: a batch's images are decoded that many at a time (OpenCV releases the GIL while
        decoding); :func:`decode_schedule` picks this and ``background`` for an encoder.
    where : str
        What errors name (the pairs file).
    follow_links : bool, optional
        The link rule of :func:`data_schema.tables.inside_scene` (default: the environment's).

    Returns
    -------
    iterator of CropBatch

    Raises
    ------
    InputError
        For bad columns, boxes and paths, naming ``where`` and the row; naming ``max_pairs`` or
        ``decode_threads``; for unreadable images, one error listing every one of them from
        the first batch that has one on, with their count.
    """
    check_int("max_pairs", max_pairs)
    check_int("decode_threads", decode_threads)
    plan = _plan(pairs, scene_root=scene_root, base=base, where=where, follow=follow_links)

    def batches() -> Iterator[CropBatch]:
        pool = ThreadPoolExecutor(decode_threads, thread_name_prefix="nvrq-decode") if decode_threads > 1 else None
        chunks = _chunks(plan.gt_paths, max_pairs)
        try:
            for k, rows in enumerate(chunks):
                try:
                    batch = _load_batch(rows, plan, where, pool)
                except _Unreadable:
                    raise _all_unreadable(plan, chunks[k:], where) from None
                yield batch
        finally:
            if pool is not None:
                pool.shutdown(wait=True, cancel_futures=True)
    return _in_background(batches()) if background else batches()


def usable_cores() -> int:
    """CPU cores this process may run on.

    Returns
    -------
    int
        Its affinity mask's size where the OS has one, else the machine's cores.
    """
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # no affinity API (macOS, Windows)
        return os.cpu_count() or 1


def decode_schedule(encoder=None, *, pixel_metrics: bool = False, cores: int | None = None) -> tuple[bool, int]:
    """How :func:`iter_crop_batches` decodes beside ``encoder``.

    Parameters
    ----------
    encoder : Encoder, optional
        Its ``device`` and ``threads`` count; ``None`` without an encoder.
    pixel_metrics : bool
        Whether encoder-free metrics run in the caller's thread too.
    cores : int, optional
        Default: :func:`usable_cores`.

    Returns
    -------
    tuple of (bool, int)
        ``(background, decode_threads)``.

    Notes
    -----

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
    if encoder is None or not str(encoder.device).startswith("cpu"):
        return True, max(1, cores - 1)
    threads = int(encoder.threads or cores)
    if threads < cores:
        return True, cores - threads
    return (True, 1) if pixel_metrics else (False, cores)


def read_crops(paths: Sequence[str | os.PathLike], boxes: np.ndarray, *,
               where: str = "crops") -> list[np.ndarray]:
    """Crops of images, each image decoded once (for GT-only crop sets, e.g. ``calibrate-tau``).

    Parameters
    ----------
    paths : sequence of path
        The image of each crop (N,).
    boxes : (N, 4) int
        Inclusive ``[x0, y0, x1, y1]``.
    where : str
        What errors name.

    Returns
    -------
    list of (h, w, 3) uint8
        Copies, in order.

    Raises
    ------
    InputError
        For an unreadable image or a box outside it, naming ``where`` and the row.
    """
    paths = [os.fspath(p) for p in paths]
    boxes = np.asarray(boxes, np.int64).reshape(-1, 4)
    crops: list = [None] * len(paths)
    by_image = pd.Series(np.arange(len(paths))).groupby(np.asarray(paths, dtype=object), sort=False).groups
    for path, rows in by_image.items():
        image = read_rgb(path)
        for i in rows:
            crops[i] = cut_box(image, boxes[i], where=f"{where}: row {i + 2}").copy()
    return crops
