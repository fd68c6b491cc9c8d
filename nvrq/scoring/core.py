"""The one crop-scoring core, in memory: crops -> metric columns.

Every command that compares crops (``nvrq score``, ``calibrate-tau``, ``stability``, the
``imagenet``/``clip`` proxies), the distributed engines and the Python API
(:mod:`nvrq.api`) run through these functions; none of them reads a file (reading crops
from a pairs table is :mod:`nvrq.scoring.batches`). Which columns need what (an encoder, the GT
crop, tau) is :mod:`nvrq.metrics.resolve`'s to say, once, in the run's plan
(:mod:`nvrq.scoring.plan`):

- :func:`compute_columns` is the core: one :class:`CropBatch` and the plan's column specs ->
  the columns, dispatched on each column's kind (``pair``, ``render``, ``encoder``), with no
  check and no name comparison; the driver, the engines and the Python API call it;
- :func:`score_crop_batch` is its public wrapper: one :class:`CropBatch` and a plan (checked when
  it was made) -> its metric columns. Full-reference
  pixel metrics compare the GT crop with the render crop bicubic-resized to the GT crop's size
  (docs/FORMATS.md §4); no-reference metrics (``reference=False`` in :mod:`nvrq.metrics.registry`)
  score the raw render crop alone, so a batch of them needs no GT crops (``gt_crops=[]``,
  ``gt_index=None``); ``nvrq``/``nvrq_ca`` use encoder embeddings, each GT crop embedded once
  (paper Eq. 4, 5 in :mod:`nvrq.metrics.formulas`).
- :func:`encoder_inputs`, :func:`run_batched` and :func:`embed_crops` are the lower pieces:
  square-pad + bicubic resize of a crop list, and a model run over it ``batch_size`` at a time.

Timing keys accumulated into ``timings`` (seconds): one per pixel metric column (its own
calls), ``prepare`` (encoder inputs), ``forward`` (model passes); :attr:`CropBatch.decode_seconds`
holds a batch's decoding time.

>>> import numpy as np
>>> gt = np.zeros((4, 6, 3), np.uint8)
>>> b = CropBatch(np.array([0, 1]), [gt], np.array([0, 0]), [gt, np.full((2, 3, 3), 9, np.uint8)])
>>> from nvrq.scoring.plan import resolve_plan
>>> score_crop_batch(b, resolve_plan("mse"))["mse"].tolist()
[0.0, 81.0]
>>> nr = CropBatch(np.array([0]), [], None, [np.full((4, 6, 3), 9, np.uint8)])  # no GT crops
>>> score_crop_batch(nr, resolve_plan("entropy"))["entropy"].tolist()
[0.0]
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from data_schema.errors import InputError, check_int
from nvrq.crops import encoder_input, resize_to
from nvrq.metrics.formulas import nvrq_similarity
from nvrq.metrics.info import MetricKind

__all__ = ["CropBatch", "score_crop_batch", "compute_columns", "embed_crops", "encoder_inputs",
           "run_batched", "pair_outputs", "column_seconds", "empty_column_warning"]


@dataclass(frozen=True)
class CropBatch:
    """Crops of ``P`` pairs.

    Attributes
    ----------
    rows : (P,) int64
        The pairs' positions in the pairs table.
    gt_crops : list of K (h, w, 3) uint8 RGB
        The unique GT crops (``[]`` without GT: no-reference metrics only).
    gt_index : (P,) int64 or None
        Pair k's GT crop is ``gt_crops[gt_index[k]]`` (``None`` without GT).
    render_crops : list of P (h, w, 3) uint8 RGB
        The render crops.
    n_images_decoded, decode_seconds
        Image files read to build it and the time spent.
    """

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
    """Encoder inputs of ``crops``: black square pad + bicubic resize (:func:`nvrq.crops.encoder_input`,
    docs/FORMATS.md §4).

    Parameters
    ----------
    crops : sequence of (h, w, 3) uint8
        RGB crops of any sizes.
    size : int
        The encoder's input side.

    Returns
    -------
    (N, size, size, 3) uint8
    """
    out = np.empty((len(crops), size, size, 3), np.uint8)
    for k, crop in enumerate(crops):
        out[k] = encoder_input(crop, size)
    return out


def run_batched(crops: Sequence[np.ndarray], fn: Callable[[np.ndarray], np.ndarray], *, size: int,
                batch_size: int = 32, timings: dict | None = None) -> np.ndarray:
    """A model over the encoder inputs of ``crops``, ``batch_size`` crops at a time.

    Parameters
    ----------
    crops : sequence of (h, w, 3) uint8
        The crops, in order.
    fn : callable
        uint8 (B, size, size, 3) -> (B, D), e.g. an encoder's ``embed``.
    size : int
        The side :func:`encoder_inputs` resizes to.
    batch_size : int
        Crops per call of ``fn``.
    timings : dict, optional
        Gains ``prepare`` (input building) and ``forward`` (``fn``) seconds.

    Returns
    -------
    (N, D) array
        ``(0, 0)`` for no crops.

    Raises
    ------
    InputError
        Naming ``batch_size`` unless it is a positive integer.
    """
    check_int("batch_size", batch_size)
    return _run_batched(crops, fn, size, batch_size, timings)


def _run_batched(crops, fn, size: int, batch_size: int, timings: dict | None) -> np.ndarray:
    """:func:`run_batched` without the check (the plan checked ``batch_size``)."""
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
    """The model outputs of each pair's GT crop and render crop; every GT crop of the batch is
    run once (then indexed by ``batch.gt_index``).

    Parameters
    ----------
    batch : CropBatch
        Crops with GT.
    fn, size, batch_size, timings
        As :func:`run_batched`.

    Returns
    -------
    tuple of two (P, D) arrays
        ``(out_gt, out_render)``: row k for pair k.
    """
    check_int("batch_size", batch_size)
    return _pair_outputs(batch, fn, size, batch_size, timings)


def _pair_outputs(batch: CropBatch, fn, size: int, batch_size: int, timings: dict | None):
    """:func:`pair_outputs` without the check."""
    k = len(batch.gt_crops)
    out = _run_batched([*batch.gt_crops, *batch.render_crops], fn, size, batch_size, timings)
    return out[:k][np.asarray(batch.gt_index, np.int64)], out[k:]


def embed_crops(crops: Sequence[np.ndarray], encoder, *, batch_size: int = 32,
                timings: dict | None = None) -> np.ndarray:
    """Embeddings of ``crops`` by ``encoder`` (:func:`run_batched` of ``encoder.embed``).

    Parameters
    ----------
    crops : sequence of (h, w, 3) uint8 RGB
        Crops of any sizes.
    encoder : Encoder
        ``encoder.embed(uint8 (B, S, S, 3)) -> (B, D)``, ``S = encoder.spec.input_size``.
    batch_size : int
        Crops per forward pass.
    timings : dict, optional
        See :func:`run_batched`.

    Returns
    -------
    (N, D) float array

    Raises
    ------
    InputError
        Naming ``encoder`` when it is None, or ``batch_size``.
    """
    if encoder is None:
        raise InputError(param="encoder", expected="a loaded encoder", got=None)
    return run_batched(crops, encoder.embed, size=encoder.spec.input_size, batch_size=batch_size,
                       timings=timings)


# --- the pure per-batch scorer -----------------------------------------------------------------

def column_seconds(columns: Sequence[str], model_columns, timings: dict) -> list[float]:
    """Seconds per column: the shared decode plus the column's own calls, or, for one of
    ``model_columns``, all model input preparation and passes (``prepare + forward``).

    Parameters
    ----------
    columns : sequence of str
        The columns, in the order wanted.
    model_columns : collection of str
        The columns a model computes.
    timings : dict
        Seconds by key (the keys in the module docstring, plus ``decode``).

    Returns
    -------
    list of float

    >>> column_seconds(["psnr", "nvrq:e"], {"nvrq:e"}, {"decode": 1.0, "psnr": 0.5, "forward": 2.0})
    [1.5, 3.0]
    """
    decode = float(timings.get("decode", 0.0))
    model = float(timings.get("prepare", 0.0)) + float(timings.get("forward", 0.0))
    return [decode + (model if c in model_columns else float(timings.get(c, 0.0))) for c in columns]


def _pixel_columns(batch: CropBatch, specs, times: dict) -> dict[str, np.ndarray]:
    """Encoder-free columns (P,) per spec: a ``pair`` one compares the GT crop with the render
    crop resized to the GT crop's size (pair by pair, or, with a ``batch`` kernel, the whole
    batch in one call); a ``render`` one scores the raw render crop."""
    out = {spec.name: np.empty(len(batch.render_crops)) for spec in specs}
    full = {s.name: s.kernel for s in specs if s.kind is MetricKind.PAIR and s.batch is None}
    whole = {s.name: s.batch for s in specs if s.kind is MetricKind.PAIR and s.batch is not None}
    blind = {s.name: s.kernel for s in specs if s.kind is MetricKind.RENDER}
    resized = [] if whole else None
    for k, crop in enumerate(batch.render_crops):
        for name, fn in blind.items():
            t0 = time.perf_counter()
            out[name][k] = fn(crop)
            times[name] = times.get(name, 0.0) + time.perf_counter() - t0
        if full or whole:
            gt = batch.gt_crops[batch.gt_index[k]]
            rs = resize_to(crop, gt.shape[0], gt.shape[1])
            if whole:
                resized.append(rs)
        for name, fn in full.items():
            t0 = time.perf_counter()
            out[name][k] = fn(gt, rs)
            times[name] = times.get(name, 0.0) + time.perf_counter() - t0
    for name, fn in whole.items() if resized else ():  # a network over the batch: each GT crop run once
        t0 = time.perf_counter()
        out[name] = fn(batch.gt_crops, batch.gt_index, resized)
        times[name] = times.get(name, 0.0) + time.perf_counter() - t0
    return out


def compute_columns(batch: CropBatch, specs: Sequence, *, encoder=None, tau: float | None = None,
                    batch_size: int = 32, timings: dict | None = None,
                    features: dict | None = None) -> dict[str, np.ndarray]:
    """The core: the columns of ``specs`` for one :class:`CropBatch`, with no check.

    Parameters
    ----------
    batch : CropBatch
        The crops (GT crops for ``pair`` and ``encoder`` columns).
    specs : sequence of ColumnSpec
        The plan's columns (:attr:`nvrq.scoring.plan.ScorePlan.specs`), already checked.
    encoder : Encoder, optional
        For ``encoder`` columns: each GT crop embedded once, ``batch_size`` crops per pass; the
        similarity ``S`` (paper Eq. 4) is computed once and each column's ``from_similarity``
        maps it.
    tau : float, optional
        The plan's tau, for the columns that use it.
    batch_size : int
        Crops per encoder pass.
    timings : dict, optional
        Gains the per-stage seconds (module docstring).
    features : dict, optional
        With encoder columns, gains ``gt`` and ``render``: the (P, D) embeddings of each pair's
        GT and render crop (``nvrq score --save-crop-features``).

    Returns
    -------
    dict
        ``{column: (P,) float64}`` in ``specs`` order.
    """
    times = timings if timings is not None else {}
    out = _pixel_columns(batch, [s for s in specs if s.kind is not MetricKind.ENCODER], times)
    enc = [s for s in specs if s.kind is MetricKind.ENCODER]
    if enc:
        f_gt, f_render = _pair_outputs(batch, encoder.embed, encoder.spec.input_size, batch_size, times)
        if features is not None:
            features["gt"], features["render"] = f_gt, f_render
        sim = nvrq_similarity(f_gt, f_render)
        for spec in enc:
            out[spec.name] = spec.from_similarity(sim, tau)
    return {s.name: np.asarray(out[s.name], np.float64) for s in specs}


def score_crop_batch(batch: CropBatch, plan, *, encoder=None,
                     timings: dict | None = None) -> dict[str, np.ndarray]:
    """The metric columns of one :class:`CropBatch` by ``plan`` (checked when it was made),
    through :func:`compute_columns`.

    Parameters
    ----------
    batch : CropBatch
        The crops. A batch without GT crops (``gt_crops=[]``) takes only no-reference metrics.
    plan : ScorePlan
        What to compute (:func:`nvrq.scoring.plan.resolve_plan`, or
        :meth:`~nvrq.scoring.plan.ScorePlan.for_columns` for columns and a loaded encoder).
    encoder : Encoder, optional
        For the plan's ``nvrq:*``/``nvrq_ca:*`` columns: GT crops embedded once each,
        ``plan.batch_size`` crops per pass.
    timings : dict, optional
        As for :func:`compute_columns`.

    Returns
    -------
    dict
        ``{column: (P,) float64}`` in the plan's column order.

    Raises
    ------
    InputError
        Naming ``gt_crops`` when reference metrics get none.
    """
    if len(batch.render_crops) and not len(batch.gt_crops if batch.gt_crops is not None else ()):
        if plan.reference_columns:
            raise InputError(param="gt_crops", expected="GT crops for the reference metrics "
                             f"{', '.join(plan.reference_columns)}", got="none")
    return compute_columns(batch, plan.specs, encoder=encoder, tau=plan.tau, batch_size=plan.batch_size,
                           timings=timings)


def empty_column_warning(metric: str, n_pairs: int, why: str = "") -> str:
    """The one ``warning:`` line of a metric that is NaN on every one of ``n_pairs`` pairs
    (``why``: the reasons, when known), printed wherever a run's summary is.

    Parameters
    ----------
    metric : str
        The metric column.
    n_pairs : int
        Number of pairs scored.
    why : str, optional
        The reasons it is undefined (default: none given).

    Returns
    -------
    str
        The warning line (no trailing newline).
    """
    return (f"warning: {metric} is NaN on all {n_pairs} pairs: undefined for these crops, its column "
            f"is empty" + (f" ({why})" if why else ""))
