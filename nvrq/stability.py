"""The stability study (``nvrq stability``): how far nuisances move a metric, relative to
how far true reconstruction artefacts move it (the paper's Fig. 4, measured).

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
from data_schema.tables import GT_BOX_COLUMNS, atomic_path, pair_boxes, pair_image_paths
from nvrq.crops import cut_box, encoder_input, read_rgb, resize_to
from nvrq.metrics import REGISTRY, metric_info, split_column
from nvrq.nuisances import (
    NUISANCE_STRENGTHS,
    expose,
    jpeg_roundtrip,
    occlude,
    scaled_box,
    shifted_box,
)
from nvrq.scoring import nvrq_ca, nvrq_similarity
from nvrq.synth.artefacts import ARTEFACTS, apply_artefact

__all__ = [
    "ARTEFACT_STRENGTHS",
    "Sample",
    "build_samples",
    "score_crop_pairs",
    "pooled_change",
    "summarise",
    "run_stability",
    "plot_stability",
]

ARTEFACT_STRENGTHS = (0.25, 0.5, 0.75, 1.0)


@dataclass
class Sample:
    """One GT-vs-perturbed crop pair: ``obj`` indexes the GT crop list."""

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
    b = pair_boxes(pairs, GT_BOX_COLUMNS, where=where)
    df[list(GT_BOX_COLUMNS)] = b
    df["_short"] = np.minimum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]) + 1
    keys = ["clip_id", "camera", "track_id", "timestamp_us"]
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


def build_samples(
    pairs: pd.DataFrame,
    *,
    n_objects: int = 60,
    seed: int = 0,
    min_side: int = 32,
    nuisances: dict | None = None,
    artefact_strengths=ARTEFACT_STRENGTHS,
    progress: bool = True,
    where: str = "pairs",
) -> tuple[list[np.ndarray], list[Sample]]:
    """GT crops (list of (h, w, 3)) and every perturbed :class:`Sample` of them (see module doc)."""
    nuisances = NUISANCE_STRENGTHS if nuisances is None else nuisances
    rng = np.random.default_rng(seed)
    chosen, frames = _objects(pairs, n_objects=n_objects, min_side=min_side, rng=rng, where=where)
    by_track = {
        k: g.set_index("_rank") for k, g in frames.groupby(["clip_id", "camera", "track_id"])
    }
    cache: dict[str, np.ndarray] = {}

    def image(path):
        if path not in cache:
            if len(cache) > 8:
                cache.pop(next(iter(cache)))
            cache[path] = read_rgb(path)
        return cache[path]

    box_cols = ["gt_x0", "gt_y0", "gt_x1", "gt_y1"]
    gts = [
        cut_box(
            image(r["_gt_abs"]), r[box_cols].to_numpy(np.int64), where=f"{where}: GT box"
        ).copy()
        for _, r in chosen.iterrows()
    ]
    samples: list[Sample] = []
    for o, row in tqdm(
        list(chosen.iterrows()),
        desc="perturb",
        unit="object",
        file=sys.stderr,
        disable=not progress,
    ):
        r = np.random.default_rng([seed, o])
        img = image(row["_gt_abs"])
        size = (img.shape[1], img.shape[0])
        box = row[box_cols].to_numpy(np.int64)
        gt = gts[o]
        for name, strengths in nuisances.items():
            for s in strengths:
                crop = None
                if name == "box_jitter":
                    crop = cut_box(img, shifted_box(box, s, r.uniform(0, 2 * math.pi), size))
                elif name == "scale_jitter":
                    crop = cut_box(img, scaled_box(box, 1 + s * r.choice([-1.0, 1.0]), size))
                elif name == "occlusion":
                    other = (o + 1 + int(r.integers(len(gts) - 1))) % len(gts)
                    crop = occlude(gt, gts[other], s, int(r.integers(4)))
                elif name == "exposure":
                    crop = expose(gt, 1 + s * r.choice([-1.0, 1.0]))
                elif name == "jpeg":
                    crop = jpeg_roundtrip(gt, int(round(100 - s)))
                elif name == "view_shift":
                    track = by_track[(row["clip_id"], row["camera"], row["track_id"])]
                    for k in (int(row["_rank"] + s), int(row["_rank"] - s)):
                        if k in track.index:
                            nb = track.loc[k]
                            crop = cut_box(
                                image(nb["_gt_abs"]), nb[box_cols].to_numpy(np.int64)
                            ).copy()
                            break
                else:
                    raise InputError(
                        "nuisances", name, f"one of {', '.join(NUISANCE_STRENGTHS)}", name
                    )
                if crop is not None:
                    samples.append(
                        Sample(o, name, "nuisance", float(s), np.ascontiguousarray(crop))
                    )
        for name in ARTEFACTS:
            for s in artefact_strengths:
                samples.append(
                    Sample(o, name, "artefact", float(s), apply_artefact(gt, name, s, rng=r))
                )
    return gts, samples


def score_crop_pairs(
    gt_crops: list[np.ndarray],
    gt_index: np.ndarray,
    others: list[np.ndarray],
    *,
    metrics: list[str],
    encoder=None,
    tau: float | None = None,
    batch_size: int = 32,
    progress: bool = True,
) -> dict[str, np.ndarray]:
    """Metric values (N,) for the pairs ``(gt_crops[gt_index[k]], others[k])``, as ``nvrq score``
    computes them (``metrics``: column names from :func:`nvrq.scoring.resolve_metrics`)."""
    out: dict[str, np.ndarray] = {}
    enc_cols = [m for m in metrics if REGISTRY[split_column(m)[0]].needs_encoder]
    pix = [m for m in metrics if m not in enc_cols]
    if pix:
        vals = {m: np.empty(len(others)) for m in pix}
        for k, crop in enumerate(
            tqdm(others, desc="pixel metrics", unit="pair", file=sys.stderr, disable=not progress)
        ):
            gt = gt_crops[gt_index[k]]
            rs = resize_to(crop, gt.shape[0], gt.shape[1])
            for m in pix:
                vals[m][k] = REGISTRY[m].fn(gt, rs)
        out.update(vals)
    if enc_cols:
        size = encoder.spec.input_size
        crops = list(gt_crops) + list(others)
        feats = []
        for k in tqdm(
            range(0, len(crops), batch_size),
            desc="embed",
            unit="batch",
            file=sys.stderr,
            disable=not progress,
        ):
            feats.append(
                encoder.embed(np.stack([encoder_input(c, size) for c in crops[k : k + batch_size]]))
            )
        f = np.concatenate(feats)
        s = nvrq_similarity(f[: len(gt_crops)][gt_index], f[len(gt_crops) :])
        for m in enc_cols:
            out[m] = s if split_column(m)[0] == "nvrq" else nvrq_ca(s, tau=tau)
    return {m: out[m] for m in metrics}


def pooled_change(values: np.ndarray, *, higher_better: bool) -> np.ndarray:
    """Pooled percentile drop (N,) of ``values`` (N,): the fraction of the other finite samples the
    metric scores better (ties half); NaN stays NaN. See the module docstring."""
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
    (stability table, snr table) -- the two CSVs of ``nvrq stability``."""
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


def run_stability(
    pairs: pd.DataFrame,
    *,
    metrics: list[str],
    encoder=None,
    tau: float | None = None,
    n_objects: int = 60,
    seed: int = 0,
    min_side: int = 32,
    nuisances: dict | None = None,
    artefact_strengths=ARTEFACT_STRENGTHS,
    batch_size: int = 32,
    progress: bool = True,
    where: str = "pairs",
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The whole study -> ``(samples, stability, snr)`` tables (see :func:`summarise`)."""
    gts, samples = build_samples(
        pairs,
        n_objects=n_objects,
        seed=seed,
        min_side=min_side,
        nuisances=nuisances,
        artefact_strengths=artefact_strengths,
        progress=progress,
        where=where,
    )
    gt_index = np.array([s.obj for s in samples], np.int64)
    values = score_crop_pairs(
        gts,
        gt_index,
        [s.crop for s in samples],
        metrics=metrics,
        encoder=encoder,
        tau=tau,
        batch_size=batch_size,
        progress=progress,
    )
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
        d["change"] = pooled_change(v, higher_better=metric_info(m).higher_better)
        frames.append(d)
    table = pd.concat(frames, ignore_index=True)
    stab, snr = summarise(table)
    return table, stab, snr


def plot_stability(stab: pd.DataFrame, snr: pd.DataFrame, out_stem) -> list:
    """Two panels -> ``out_stem.png`` and ``out_stem.svg``: (a) SNR per nuisance and metric (log
    scale), (b) mean change vs strength under box jitter (solid) and artefacts (dashed)."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    metrics = list(dict.fromkeys(snr["metric"]))
    names = list(dict.fromkeys(snr["nuisance"]))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 4.5))
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
    ax1.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax1.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax1.set_xticks(np.arange(len(names)), names, rotation=30, ha="right")
    ax1.set_ylabel("signal-to-nuisance ratio (artefact / nuisance change)")
    ax1.set_title("(a) SNR per nuisance (higher = more stable)")
    ax1.legend(fontsize=8)
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
    ax2.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    written = []
    for ext in ("png", "svg"):
        target = Path(f"{out_stem}.{ext}")
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=ext, dpi=120)
        written.append(target)
    plt.close(fig)
    return written
