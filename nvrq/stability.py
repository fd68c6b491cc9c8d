"""The stability study (``nvrq stability``): how far nuisances move a metric, relative to
how far true reconstruction artefacts move it (the paper's Fig. 4, measured).

Layer: nvrq core, metrics support (the stability study).

Samples: ``n_objects`` GT crops drawn (seeded) from a pairs table. Each is compared with
perturbed versions of itself -- the nuisances of :mod:`nvrq.nuisances` (box and scale
jitter, occlusion by another sampled object's crop, exposure, JPEG, the same track one or
two frames away) and the synthetic renderer's artefacts (:mod:`nvrq.synth.artefacts`) at
strengths 0.25-1. Every metric scores every (GT crop, perturbed crop) pair exactly as
``nvrq score`` does (pixel metrics on the raw crops, the other crop bicubic-resized to the
GT crop's size; NVRQ on square-padded encoder inputs).

Normalisation rule (so metrics of different scales and directions compare): a sample's
*change* is its pooled percentile drop -- the fraction of the metric's other samples
(all nuisances and artefacts of the study together) that the metric scores better, ties
counted half: 0 = judged better than everything in the study, 1 = worse than everything.
It is invariant to any monotone rescaling (PSNR and MSE give the same numbers), finite
where identical crops score infinity, and direction-aware. A metric's *artefact response*
``A`` is the mean change over all artefact samples; for a nuisance ``N``,
``snr = A / mean change over N's samples`` (``nuisance = 'all'``: over every nuisance
sample). ``snr > 1``: the metric is moved more by artefacts than by the nuisance.

>>> pooled_change(np.array([3.0, 1.0, 2.0, 2.0]), higher_better=True).tolist()
[0.0, 1.0, 0.5, 0.5]
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import rankdata
from tqdm import tqdm

from data_schema.errors import InputError
from data_schema.options import options_or_keywords
from data_schema.tables import (
    GT_BOX_COLUMNS,
    MIN_SIDE_PX,
    OBJECT_COLUMNS,
    atomic_path,
    pair_boxes,
    pair_image_paths,
)
from nvrq.crops import cut_box, read_rgb
from nvrq.metrics.resolve import direction
from nvrq.nuisances import (
    NUISANCE_STRENGTHS,
    expose,
    jpeg_roundtrip,
    occlude,
    scaled_box,
    shifted_box,
)
from nvrq.scoring.core import CropBatch, score_crop_batch
from nvrq.scoring.plan import ScorePlan
from nvrq.synth.artefacts import ARTEFACTS, apply_artefact

__all__ = [
    "StabilityOptions",
    "ARTEFACT_STRENGTHS",
    "Sample",
    "build_samples",
    "score_samples",
    "pooled_change",
    "summarise",
    "run_stability",
    "plot_stability",
    "stability_figure",
]

ARTEFACT_STRENGTHS = (0.25, 0.5, 0.75, 1.0)
_GT_BOX = list(GT_BOX_COLUMNS)


@dataclass
class Sample:
    """One GT-vs-perturbed crop pair: ``obj`` indexes the GT crop list.

    Attributes
    ----------
    obj : int
        Index into the GT crop list.
    perturbation : str
        The nuisance or artefact name.
    kind : str
        ``{'nuisance', 'artefact'}``.
    strength : float
        Its strength.
    crop : (h, w, 3) uint8
        The perturbed crop, RGB.
    """

    obj: int
    perturbation: str
    kind: str  # {'nuisance', 'artefact'}
    strength: float
    crop: np.ndarray  # (h, w, 3) uint8 RGB


def _objects(
    pairs: pd.DataFrame, *, n_objects: int, min_side: int, rng, where: str
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``(chosen, frames)``: every unique GT crop (clip, camera, track, frame) with its absolute
    image path and its frame rank within the track (``frames``), and ``n_objects`` of those with
    a shorter side >= ``min_side`` drawn at random (``chosen``). ``view_shift`` by k frames means
    k steps along the track's frames present in the pairs table."""
    df = pairs.copy()
    df["_gt_abs"] = pair_image_paths(pairs, "gt_path", where=where)
    b = pair_boxes(pairs, _GT_BOX, where=where)
    df[_GT_BOX] = b
    df["_short"] = np.minimum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]) + 1
    keys = list(OBJECT_COLUMNS)  # one GT crop per object and frame
    frames = df.drop_duplicates(keys).sort_values(keys, kind="stable").reset_index(drop=True)
    frames["_rank"] = frames.groupby(keys[:3]).cumcount()
    big = frames[frames["_short"] >= min_side]
    if len(big) < 2:
        raise InputError(
            where, "gt boxes", f"at least 2 GT crops with a shorter side >= {min_side} px", len(big)
        )
    pick = rng.choice(len(big), size=min(n_objects, len(big)), replace=False)
    chosen = big.iloc[np.sort(pick)].reset_index(drop=True)
    return chosen, frames


class _Images:
    """Decoded images by path, the 9 most recently added kept (view shifts revisit neighbours)."""

    def __init__(self):
        self._cache: dict[str, np.ndarray] = {}

    def __call__(self, path: str) -> np.ndarray:
        if path not in self._cache:
            if len(self._cache) > 8:
                self._cache.pop(next(iter(self._cache)))
            self._cache[path] = read_rgb(path)
        return self._cache[path]


def _view_shift(row, track: pd.DataFrame, s, image: _Images) -> np.ndarray | None:
    """The same track's GT crop ``s`` frames later (else earlier), or ``None``."""
    for k in (int(row["_rank"] + s), int(row["_rank"] - s)):
        if k in track.index:
            nb = track.loc[k]
            return cut_box(image(nb["_gt_abs"]), nb[_GT_BOX].to_numpy(np.int64)).copy()
    return None


def _nuisance_crop(name: str, s, *, o: int, row, gts: list, r, image: _Images, by_track: dict):
    """Object ``o``'s crop under nuisance ``name`` at strength ``s`` (``None``: not available);
    ``r`` is the object's generator, drawn in a fixed order per nuisance."""
    img = image(row["_gt_abs"])
    size = (img.shape[1], img.shape[0])
    box = row[_GT_BOX].to_numpy(np.int64)
    if name == "box_jitter":
        return cut_box(img, shifted_box(box, s, r.uniform(0, 2 * math.pi), size))
    if name == "scale_jitter":
        return cut_box(img, scaled_box(box, 1 + s * r.choice([-1.0, 1.0]), size))
    if name == "occlusion":
        other = (o + 1 + int(r.integers(len(gts) - 1))) % len(gts)
        return occlude(gts[o], gts[other], s, int(r.integers(4)))
    if name == "exposure":
        return expose(gts[o], 1 + s * r.choice([-1.0, 1.0]))
    if name == "jpeg":
        return jpeg_roundtrip(gts[o], int(round(100 - s)))
    if name == "view_shift":
        return _view_shift(row, by_track[(row["clip_id"], row["camera"], row["track_id"])], s, image)
    raise InputError(param="nuisances", field=name, expected=f"one of {', '.join(NUISANCE_STRENGTHS)}", got=name)


def _object_samples(o: int, row, *, seed: int, gts: list, nuisances: dict, artefact_strengths,
                    image: _Images, by_track: dict) -> list[Sample]:
    """Every nuisance and artefact :class:`Sample` of object ``o`` (generator ``[seed, o]``)."""
    r = np.random.default_rng([seed, o])
    out = []
    for name, strengths in nuisances.items():
        for s in strengths:
            crop = _nuisance_crop(name, s, o=o, row=row, gts=gts, r=r, image=image, by_track=by_track)
            if crop is not None:
                out.append(Sample(o, name, "nuisance", float(s), np.ascontiguousarray(crop)))
    for name in ARTEFACTS:
        for s in artefact_strengths:
            out.append(Sample(o, name, "artefact", float(s), apply_artefact(gts[o], name, s, rng=r)))
    return out


def build_samples(
    pairs: pd.DataFrame,
    *,
    n_objects: int = 60,
    seed: int = 0,
    min_side: int = MIN_SIDE_PX,
    nuisances: dict | None = None,
    artefact_strengths=ARTEFACT_STRENGTHS,
    progress: bool = True,
    where: str = "pairs",
) -> tuple[list[np.ndarray], list[Sample]]:
    """GT crops (list of (h, w, 3)) and every perturbed :class:`Sample` of them (see module doc).

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table (docs/FORMATS.md §3).
    n_objects : int, optional
        GT crops drawn.
    seed : int, optional
        Seed of the draw and of the perturbations.
    min_side : int, pixels, optional
        Smallest GT box side drawn.
    nuisances : dict, optional
        Nuisance name -> strengths (default ``NUISANCE_STRENGTHS``).
    artefact_strengths : sequence of float, optional
        Strengths of each artefact, in [0, 1].
    progress : bool, optional
        Show a progress bar.
    where : str, optional
        The table named in errors.

    Returns
    -------
    gts : list of (h, w, 3) uint8
        GT crops, RGB.
    samples : list of Sample
    """
    nuisances = NUISANCE_STRENGTHS if nuisances is None else nuisances
    rng = np.random.default_rng(seed)
    chosen, frames = _objects(pairs, n_objects=n_objects, min_side=min_side, rng=rng, where=where)
    by_track = {
        k: g.set_index("_rank") for k, g in frames.groupby(["clip_id", "camera", "track_id"])
    }
    image = _Images()
    gts = [
        cut_box(image(r["_gt_abs"]), r[_GT_BOX].to_numpy(np.int64), where=f"{where}: GT box").copy()
        for _, r in chosen.iterrows()
    ]
    samples: list[Sample] = []
    rows = tqdm(list(chosen.iterrows()), desc="perturb", unit="object", file=sys.stderr,
                disable=not progress)
    for o, row in rows:
        samples += _object_samples(o, row, seed=seed, gts=gts, nuisances=nuisances,
                                   artefact_strengths=artefact_strengths, image=image,
                                   by_track=by_track)
    return gts, samples


def _sample_batches(gts: list[np.ndarray], samples: list[Sample], *, max_pairs: int) -> list[CropBatch]:
    """The samples as :class:`CropBatch` es of whole objects, about ``max_pairs`` samples each;
    ``rows`` index ``samples``; each GT crop appears once in the batch of its object."""
    objs = np.array([s.obj for s in samples], np.int64)
    batches, start = [], 0
    while start < len(samples):
        stop = min(start + max_pairs, len(samples))
        while stop < len(samples) and objs[stop] == objs[stop - 1]:  # keep an object whole
            stop += 1
        used = np.unique(objs[start:stop])
        batches.append(CropBatch(np.arange(start, stop), [gts[o] for o in used],
                                 np.searchsorted(used, objs[start:stop]),
                                 [s.crop for s in samples[start:stop]]))
        start = stop
    return batches


def score_samples(gts: list[np.ndarray], samples: list[Sample], plan: ScorePlan, *, encoder=None,
                  progress: bool = True) -> dict[str, np.ndarray]:
    """Metric values (N,) for every ``(gts[sample.obj], sample.crop)``, through the one scoring
    core (:func:`nvrq.scoring.core.score_crop_batch`), exactly as ``nvrq score`` computes them.

    Parameters
    ----------
    gts : list of (h, w, 3) uint8
        GT crops, RGB.
    samples : list of Sample
        The perturbed crops.
    plan : ScorePlan
        The metric columns, tau, crops per forward pass and pairs per scoring batch
        (:meth:`nvrq.scoring.plan.ScorePlan.for_columns`, checked once there).
    encoder : Encoder, optional
        Needed by encoder metrics.
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    dict
        Metric name -> ``(N,)`` float64 values, one per sample.
    """
    values = {m: np.full(len(samples), np.nan) for m in plan.columns}
    with tqdm(total=len(samples), desc="score", unit="sample", file=sys.stderr,
              disable=not progress) as bar:
        for batch in _sample_batches(gts, samples, max_pairs=plan.max_pairs):
            cols = score_crop_batch(batch, plan, encoder=encoder)
            for m, v in cols.items():
                values[m][batch.rows] = v
            bar.update(len(batch.rows))
    return values


def pooled_change(values: np.ndarray, *, higher_better: bool) -> np.ndarray:
    """Pooled percentile drop (N,) of ``values`` (N,): the fraction of the other finite samples the
    metric scores better (ties half); NaN stays NaN. See the module docstring.

    Parameters
    ----------
    values : (N,) float64
        One metric's values over all samples.
    higher_better : bool
        The metric's direction.

    Returns
    -------
    (N,) float64
        In [0, 1]; NaN where ``values`` is NaN.
    """
    v = np.asarray(values, np.float64)
    q = v if higher_better else -v
    ok = ~np.isnan(q)
    out = np.full(len(v), np.nan)
    n = int(ok.sum())
    if n >= 2:
        r = rankdata(q[ok], method="average")  # 1 = worst
        out[ok] = (n - r) / (n - 1)
    return out


def summarise(samples: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``samples`` (metric, nuisance_or_artefact, kind, strength, object, value, change) ->
    (stability table, snr table) -- the two CSVs of ``nvrq stability``.

    Parameters
    ----------
    samples : pandas.DataFrame
        One row per sample and metric.

    Returns
    -------
    stability : pandas.DataFrame
        Mean change per metric, nuisance or artefact, kind and strength.
    snr : pandas.DataFrame
        ``metric, nuisance, snr, nuisance_change, artefact_change``.
    """
    ok = samples.dropna(subset=["change"])
    stab = (
        ok.groupby(["metric", "nuisance_or_artefact", "kind", "strength"], sort=False)["change"]
        .agg(mean_abs_change="mean", n="size")
        .reset_index()
    )
    rows = []
    for metric, g in ok.groupby("metric", sort=False):
        a = g.loc[g.kind == "artefact", "change"].mean()
        nz = g[g.kind == "nuisance"]
        parts = [
            (name, d["change"].mean()) for name, d in nz.groupby("nuisance_or_artefact", sort=False)
        ]
        parts.append(("all", nz["change"].mean()))
        for name, c in parts:
            snr = math.inf if c == 0 and a > 0 else (a / c if c > 0 else math.nan)
            rows.append(
                dict(metric=metric, nuisance=name, snr=snr, nuisance_change=c, artefact_change=a)
            )
    return stab, pd.DataFrame(
        rows, columns=["metric", "nuisance", "snr", "nuisance_change", "artefact_change"]
    )


def _check_study_args(*, n_objects: int, min_side: int) -> None:
    """``n_objects >= 2`` (occlusion borrows another object), ``min_side >= 1``; else InputError."""
    for name, value, low in (("n_objects", n_objects, 2), ("min_side", min_side, 1)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise InputError(param=name, expected=f"an integer >= {low}", got=value)


@dataclass(frozen=True)
class StabilityOptions:
    """How :func:`run_stability` samples objects and perturbs them (``nvrq stability``'s options).

    Parameters
    ----------
    n_objects : int
        Objects sampled from the pairs table.
    seed : int
        Seeds the sample and every perturbation.
    min_side : int
        The shortest GT box side (pixels) of a sampled object.
    nuisances : dict, optional
        Nuisance name -> strengths (default :data:`nvrq.nuisances` defaults).
    artefact_strengths : sequence of float
        Strengths (0-1) of each render artefact.
    batch_size : int
        Crop pairs per scoring batch.

    """

    n_objects: int = 60
    seed: int = 0
    min_side: int = MIN_SIDE_PX
    nuisances: dict | None = None
    artefact_strengths: tuple = ARTEFACT_STRENGTHS
    batch_size: int = 32


def run_stability(pairs: pd.DataFrame, options: StabilityOptions | None = None, *, metrics: list[str],
                  encoder=None, tau: float | None = None, progress: bool = True, where: str = "pairs",
                  **keywords) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The whole study -> ``(samples, stability, snr)`` tables (see :func:`summarise`).

    Parameters
    ----------
    pairs : pandas.DataFrame
        The pairs table (GT paths and boxes).
    options : StabilityOptions, optional
        Objects, seed, smallest box, nuisances, artefact strengths, batch size.
    metrics : list of str
        The metric columns scored.
    encoder : Encoder, optional
        The embedding model of the encoder metrics.
    tau : float, optional
        The NVRQ threshold.
    progress, where : bool, str
        Show progress bars; the input named in errors.
    **keywords
        The former spelling (deprecated): :class:`StabilityOptions`' fields as keywords.

    Returns
    -------
    samples, stability, snr : pandas.DataFrame
        Every scored sample, the change per nuisance and strength, the signal-to-nuisance ratios.
    """
    o = options_or_keywords(StabilityOptions, options, keywords, who="run_stability")
    _check_study_args(n_objects=o.n_objects, min_side=o.min_side)
    plan = ScorePlan.for_columns(metrics, encoder=encoder, tau=tau, batch_size=o.batch_size)
    gts, samples = build_samples(pairs, n_objects=o.n_objects, seed=o.seed, min_side=o.min_side,
                                 nuisances=o.nuisances, artefact_strengths=o.artefact_strengths,
                                 progress=progress, where=where)
    gt_index = np.array([s.obj for s in samples], np.int64)
    values = score_samples(gts, samples, plan, encoder=encoder, progress=progress)
    meta = pd.DataFrame(
        {
            "nuisance_or_artefact": [s.perturbation for s in samples],
            "kind": [s.kind for s in samples],
            "strength": [s.strength for s in samples],
            "object": gt_index,
        }
    )
    frames = []
    for m, v in values.items():
        d = meta.copy()
        d.insert(0, "metric", m)
        d["value"] = v
        d["change"] = pooled_change(v, higher_better=direction(m))
        frames.append(d)
    table = pd.concat(frames, ignore_index=True)
    stab, snr = summarise(table)
    return table, stab, snr


def plot_stability(stab: pd.DataFrame, snr: pd.DataFrame, out_stem) -> list:
    """Two panels -> ``out_stem.png`` and ``out_stem.svg``: (a) SNR per nuisance and metric (log
    scale), (b) mean change vs strength under box jitter (solid) and artefacts (dashed).

    Parameters
    ----------
    stab : pandas.DataFrame
        The stability table of :func:`run_stability`.
    snr : pandas.DataFrame
        The signal-to-nuisance table of :func:`run_stability`.
    out_stem : str or os.PathLike
        Output path without extension.

    Returns
    -------
    list of pathlib.Path
        The files written (``.png`` and ``.svg``).
    """
    fig = stability_figure(stab, snr)
    written = []
    for ext in ("png", "svg"):
        target = Path(f"{out_stem}.{ext}")
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=ext, dpi=120)
        written.append(target)
    return written


def _snr_ticks(axis, values: np.ndarray) -> None:
    """Log-axis labels at 1-2-5 x 10^k when the values span under two decades (else at powers
    of ten), written plainly (0.5, 1, 2): a span inside one decade was labelled at 1 only."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    v = values[np.isfinite(values) & (values > 0)]
    span = np.log10(v.max() / v.min()) if len(v) else 0.0
    axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0) if span < 2 else (1.0,),
                                      numticks=12))
    axis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    axis.set_minor_formatter(NullFormatter())


def stability_figure(stab: pd.DataFrame, snr: pd.DataFrame):
    """The figure of :func:`plot_stability` (a matplotlib ``Figure``, not drawn): each panel's
    legend sits beside it, outside the data.

    Parameters
    ----------
    stab, snr : pandas.DataFrame
        ``stability.csv`` and ``snr.csv`` (docs/FORMATS.md §8).

    Returns
    -------
    matplotlib.figure.Figure
        Two axes: SNR bars (log y) and mean change against strength.
    """
    from matplotlib.figure import Figure

    metrics = list(dict.fromkeys(snr["metric"]))
    names = list(dict.fromkeys(snr["nuisance"]))
    fig = Figure(figsize=(15, 4.8), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    width = 0.8 / max(len(metrics), 1)
    for k, m in enumerate(metrics):
        g = snr[snr.metric == m].set_index("nuisance").reindex(names)
        vals = g["snr"].to_numpy(np.float64)
        ax1.bar(
            np.arange(len(names)) + (k - (len(metrics) - 1) / 2) * width,
            np.where(np.isfinite(vals), vals, np.nan),
            width,
            label=m,
        )
    ax1.axhline(1.0, color="grey", lw=0.8, ls=":")
    ax1.set_yscale("log")
    _snr_ticks(ax1.yaxis, snr["snr"].to_numpy(np.float64))
    ax1.set_xticks(np.arange(len(names)), names, rotation=30, ha="right")
    ax1.set_ylabel("signal-to-nuisance ratio (artefact / nuisance change)")
    ax1.set_title("(a) SNR per nuisance (higher = more stable)")
    ax1.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    for k, m in enumerate(metrics):
        g = stab[stab.metric == m]
        color = f"C{k}"
        j = g[g.nuisance_or_artefact == "box_jitter"]
        ax2.plot(j["strength"], j["mean_abs_change"], "o-", color=color, label=f"{m} box jitter")
        a = g[g.kind == "artefact"].groupby("strength")["mean_abs_change"].mean()
        ax2.plot(a.index, a.to_numpy(), "s--", color=color, label=f"{m} artefacts (mean)")
    ax2.set_xlabel("strength (box jitter: fraction of box; artefacts: 0-1)")
    ax2.set_ylabel("mean change (pooled percentile drop)")
    ax2.set_title("(b) response vs strength")
    ax2.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return fig
