"""``nvrq score``: NVRQ, NVRQ-CA and pixel metrics for every pair of a pairs table.

:func:`score_pairs` is a short driver over the one crop-scoring core:

1. :func:`~nvrq.scoring.batches.iter_crop_batches` groups pairs by GT image, decodes each batch's
   images once (:func:`nvrq.crops.read_rgb`) and cuts the crops: in a background thread when
   cores are left over beside the encoder, else between encoder passes on every core
   (:func:`~nvrq.scoring.batches.decode_schedule`).
2. :func:`~nvrq.scoring.core.score_crop_batch` computes the pixel metrics and, for
   ``nvrq``/``nvrq_ca``, embeds each GT crop once: the GT crop of an object at a frame is
   shared by every render offset (and method, docs/FORMATS.md §2), so a frame with 7 offsets
   needs 8 encoder images for 7 pairs, not 14 (3 methods: 22 for 21 pairs, not 24). The
   encoder runs ``batch_size`` crops at a time.
3. The columns are assembled in the pairs' order, with the timing table.

The formulas (paper Eq. 4, 5) are :mod:`nvrq.metrics.formulas`, the metric columns are
resolved by :mod:`nvrq.metrics.resolve`; the same core scores crops held in memory through the
Python API (:mod:`nvrq.api`).

Timing (``ScoreResult.timing``; ``METRICS.timing.csv``): per metric column, its own compute
seconds (pixel metric calls; for ``nvrq``/``nvrq_ca`` the encoder input preparation and
forward passes) plus the shared image decoding seconds -- roughly what that metric alone
would cost on these pairs.

>>> timing_table(["psnr"], {"decode": 1.0, "psnr": 0.5}, n_pairs=3, wall=2.0).to_dict("records")
[{'metric': 'psnr', 'seconds': 1.5, 'pairs': 3}]
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from tqdm import tqdm

from data_schema.tables import (
    PairsTable,
    pairs_table,
)
from nvrq.metrics.info import MetricKind
from nvrq.metrics.resolve import encoder_columns
from nvrq.scoring.batches import CROP_COLUMNS, decode_schedule, iter_crop_batches
from nvrq.scoring.core import (
    column_seconds,
    compute_columns,
    empty_column_warning,
)
from nvrq.scoring.plan import ScorePlan

__all__ = ["ScoreResult", "score_pairs", "timing_table", "runtime_timing",
           "empty_column_warning", "empty_column_warnings", "REQUIRED_COLUMNS"]

REQUIRED_COLUMNS = ("pair_id", *CROP_COLUMNS)


@dataclass
class ScoreResult:
    """``table``: ``pair_id`` + one column per metric, rows in the pairs' order.
    ``timing``: columns ``metric, seconds, pairs``. ``n_encoder_images``: crops embedded.
    ``undefined``: the NaN values per metric and reason (``metric, reason, pairs``).

    Attributes
    ----------
    table : pandas.DataFrame
        ``pair_id`` + one column per metric, rows in the pairs' order.
    timing : pandas.DataFrame
        Columns ``metric, seconds, pairs``.
    n_pairs : int
        Number of pairs scored.
    n_encoder_images : int
        Crops embedded by the encoder.
    n_images_decoded : int
        Images decoded.
    undefined : pandas.DataFrame or None
        NaN values per metric and reason (columns ``metric, reason, pairs``); None when not
        counted.
    features : tuple of two (N, D) float32 arrays or None
        ``(gt, render)``: the encoder's embedding of each pair's GT and render crop, rows in
        the pairs' order, when :func:`score_pairs` was asked to keep them.
    """

    table: pd.DataFrame
    timing: pd.DataFrame
    n_pairs: int
    n_encoder_images: int
    n_images_decoded: int
    undefined: pd.DataFrame | None = None
    features: tuple[np.ndarray, np.ndarray] | None = None


def empty_column_warnings(undefined: pd.DataFrame | None, n_pairs: int) -> list[str]:
    """:func:`empty_column_warning` for each metric of a run's ``undefined`` table
    (:attr:`ScoreResult.undefined`) that is NaN on all ``n_pairs`` pairs, with its reasons and
    counts.

    Parameters
    ----------
    undefined : pandas.DataFrame or None
        The NaN values per metric and reason (``metric, reason, pairs``); None for no warnings.
    n_pairs : int
        Number of pairs scored.

    Returns
    -------
    list of str
        One warning line per metric that is NaN on every pair.

    >>> u = pd.DataFrame({"metric": ["niqe", "psnr"], "reason": ["shorter crop side < 96 px", "undefined"],
    ...                   "pairs": [3, 1]})
    >>> empty_column_warnings(u, 3)
    ['warning: niqe is NaN on all 3 pairs: undefined for these crops, its column is empty (shorter crop side < 96 px: 3)']
    """
    if undefined is None or not n_pairs:
        return []
    return [empty_column_warning(metric, n_pairs, "; ".join(f"{r.reason}: {r.pairs}" for r in rows.itertuples()))
            for metric, rows in undefined.groupby("metric", sort=False) if rows["pairs"].sum() == n_pairs]


def timing_table(metrics: Sequence[str], times: dict, *, n_pairs: int, wall: float,
                 model_columns: Sequence[str] | None = None) -> pd.DataFrame:
    """The timing table of a run.

    Parameters
    ----------
    metrics : sequence of str
        The columns, in order.
    times : dict
        Seconds by key (:func:`nvrq.scoring.core.column_seconds`).
    n_pairs : int
        Pairs scored.
    wall : float
        The run's wall-clock seconds.
    model_columns : sequence of str, optional
        The columns a model computes (default: the encoder metrics; a proxy's otherwise).

    Returns
    -------
    pandas.DataFrame
        ``metric, seconds, pairs``: each column's own seconds (``times[column]`` for a pixel
        metric, ``prepare + forward`` for a model column) plus ``times['decode']``; the stage
        totals in ``.attrs`` (``wall_seconds``, ``forward_seconds``, ...).
    """
    decode, prepare, forward = (times.get(k, 0.0) for k in ("decode", "prepare", "forward"))
    model = set(encoder_columns(metrics) if model_columns is None else model_columns)
    timing = pd.DataFrame({
        "metric": list(metrics),
        "seconds": column_seconds(metrics, model, times),
        "pairs": n_pairs,
    })
    timing.attrs.update(wall_seconds=wall, forward_seconds=forward, decode_seconds=decode,
                        prepare_seconds=prepare)
    return timing


def runtime_timing(timing: pd.DataFrame, model, model_columns: Sequence[str]) -> pd.DataFrame:
    """How each column ran (docs/FORMATS.md §8).

    Parameters
    ----------
    timing : pandas.DataFrame
        A :func:`timing_table`.
    model : object or None
        An encoder or proxy model (its ``runtime``, ``precision``, ``threads``, ``device``).
    model_columns : sequence of str
        The rows ``model`` computed.

    Returns
    -------
    pandas.DataFrame
        ``timing`` plus ``runtime, precision, threads, device``: the model's on its rows;
        empty runtime and precision, 1 thread and ``cpu`` on the others (the decode thread's).

    >>> t = pd.DataFrame({"metric": ["psnr", "imagenet_drop"], "seconds": [1.0, 2.0], "pairs": 5})
    >>> m = type("M", (), {"runtime": "openvino", "threads": 2, "device": "cpu"})()
    >>> runtime_timing(t, m, ["imagenet_drop"]).iloc[:, 3:].to_dict("list")
    {'runtime': ['', 'openvino'], 'precision': ['', 'fp32'], 'threads': [1, 2], 'device': ['cpu', 'cpu']}
    """
    timing = timing.copy()
    on_model = timing["metric"].isin(list(model_columns))
    timing["runtime"] = on_model.map({True: getattr(model, "runtime", ""), False: ""})
    timing["precision"] = on_model.map({True: getattr(model, "precision", "fp32"), False: ""})
    timing["threads"] = on_model.map({True: getattr(model, "threads", 1), False: 1})
    timing["device"] = on_model.map({True: str(getattr(model, "device", "cpu")), False: "cpu"})
    return timing


def _sides(boxes: np.ndarray) -> np.ndarray:
    """Shorter sides (N,) of inclusive boxes (N, 4)."""
    return np.minimum(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]) + 1


def score_pairs(pairs: pd.DataFrame | PairsTable, plan: ScorePlan, *, encoder=None,
                scene_root: str | os.PathLike | None = None, base: str | os.PathLike | None = None,
                progress: bool = True, where: str = "pairs", keep_features: bool = False) -> ScoreResult:
    """Score every row of ``pairs`` by ``plan`` (the module docstring's three steps).

    Parameters
    ----------
    pairs : pandas.DataFrame or PairsTable
        docs/FORMATS.md §3 columns (:data:`REQUIRED_COLUMNS`), or a table read and checked once
        (:func:`data_schema.tables.pairs_table`).
    plan : ScorePlan
        What to compute (:func:`nvrq.scoring.plan.resolve_plan`, or
        :meth:`~nvrq.scoring.plan.ScorePlan.for_columns` with a loaded encoder), checked once there.
    encoder : Encoder, optional
        Loaded; needed for the plan's encoder columns.
    scene_root, base : path, optional
        Where image paths are relative to (else the ``scene_root`` column, relative to ``base``);
        a :class:`PairsTable`'s are its own.
    progress : bool
        A progress bar on stderr.
    where : str
        What errors name (the pairs file).
    keep_features : bool
        Keep the encoder's embedding of every GT and render crop (:attr:`ScoreResult.features`;
        the plan needs an encoder column).

    Returns
    -------
    ScoreResult

    Raises
    ------
    InputError
        For missing columns, bad boxes or images (naming ``where`` and the row), before anything
        is scored.
    """
    table = pairs if isinstance(pairs, PairsTable) else pairs_table(pairs, scene_root=scene_root, base=base, where=where)
    n, uses_encoder = len(table), bool(plan.encoder_specs)
    values = {m: np.full(n, np.nan) for m in plan.columns}
    times = {"decode": 0.0}
    counts = [0, 0]  # images decoded, crops encoded
    kept = {"gt": [], "render": [], "rows": []} if keep_features and uses_encoder else None
    t_start = time.perf_counter()
    background, decode_threads = decode_schedule(encoder if uses_encoder else None,
                                                 pixel_metrics=bool(plan.pixel_specs))
    batches = iter_crop_batches(table, max_pairs=plan.max_pairs, background=background,
                                decode_threads=decode_threads, where=table.where)
    with tqdm(total=n, unit="pair", file=sys.stderr, disable=not progress, desc="score",
              dynamic_ncols=True) as bar:
        for batch in batches:
            feats = {} if kept is not None else None
            cols = compute_columns(batch, plan.specs, encoder=encoder, tau=plan.tau,
                                   batch_size=plan.batch_size, timings=times, features=feats)
            if kept is not None:
                for side in ("gt", "render"):
                    kept[side].append(feats[side])
                kept["rows"].append(batch.rows)
            for m, v in cols.items():
                values[m][batch.rows] = v
            times["decode"] += batch.decode_seconds
            counts[0] += batch.n_images_decoded
            counts[1] += batch.n_crops if uses_encoder else 0
            bar.update(len(batch.rows))
    wall = time.perf_counter() - t_start
    frame = pd.DataFrame({"pair_id": table.frame["pair_id"].to_numpy(), **values})
    undefined = _undefined(plan, values, _sides(table.gt_boxes), _sides(table.render_boxes))
    timing = timing_table(plan.columns, times, n_pairs=n, wall=wall, model_columns=plan.model_columns)
    return ScoreResult(frame, timing, n, counts[1], counts[0], undefined, _in_order(kept, n))


def _in_order(kept: dict | None, n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The kept (gt, render) embeddings of the batches, back in the pairs' order."""
    if kept is None or not kept["rows"]:
        return None
    rows = np.concatenate(kept["rows"])
    out = []
    for side in ("gt", "render"):
        f = np.concatenate(kept[side])
        a = np.empty((n, f.shape[1]), f.dtype)
        a[rows] = f
        out.append(a)
    return out[0], out[1]


def _undefined(plan: ScorePlan, values: dict, gt_sides: np.ndarray, render_sides: np.ndarray) -> pd.DataFrame:
    """``metric, reason, pairs``: how many values of each column are NaN, and why.

    A value is NaN because its crop (the GT crop for a full-reference metric, the raw render
    crop for a no-reference one) is shorter than the metric's ``min_side``, or otherwise for the
    metric's ``undefined`` reason (:mod:`nvrq.metrics.registry`), read from the plan's specs.
    """
    rows = []
    for spec in plan.specs:
        nan = np.isnan(np.asarray(values[spec.name], np.float64))
        if not nan.any():
            continue
        sides = render_sides if spec.kind is MetricKind.RENDER else gt_sides
        small = nan & (sides < spec.min_side)
        if small.any():
            rows.append((spec.name, f"shorter crop side < {spec.min_side} px", int(small.sum())))
        if (nan & ~small).any():
            rows.append((spec.name, spec.undefined or "undefined", int((nan & ~small).sum())))
    return pd.DataFrame(rows, columns=["metric", "reason", "pairs"])
