"""NVRQ-CA ``tau`` calibration and the small user config that stores calibrated taus.

Layer: an ``nvrq`` study, above the scoring (it embeds GT crops to measure a tau).

Rule: ``tau`` is the **median** of S (paper Eq. 4) over GT crops of *unrelated* objects --
pairs of GT crops from different tracks *and* different classes -- i.e. the similarity an
encoder gives to two objects that have nothing to do with each other (its noise floor).
Below that, NVRQ-CA (Eq. 5) maps S into the low band [0, w).

The config file that stores a calibrated tau, and the one tau rule (:func:`require_tau`: the
``tau`` given, else the config file's, else the encoder registry's), live in the leaf module
:mod:`nvrq.metrics.tau_config`; they are importable from here as well.

>>> import numpy as np
>>> recommend_tau(np.array([0.2, 0.4, 0.9]))
0.4
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
import pandas as pd
from tqdm import tqdm

from data_schema.errors import InputError, check_int
from data_schema.options import options_or_keywords
from data_schema.tables import (
    GT_BOX_COLUMNS,
    pair_boxes,
    pair_image_paths,
    require_columns,
)
from data_schema.text import plural
from nvrq.metrics.formulas import nvrq_similarity
from nvrq.metrics.tau_config import config_path, read_tau_config, require_tau, write_tau
from nvrq.scoring.batches import read_crops
from nvrq.scoring.core import embed_crops

__all__ = ["CalibrationOptions", "config_path", "read_tau_config", "write_tau", "require_tau", "recommend_tau",
           "unrelated_pairs", "Calibration", "calibrate_tau"]


def recommend_tau(s_unrelated: np.ndarray) -> float:
    """The calibration rule: the median of S over unrelated GT crop pairs.

    Parameters
    ----------
    s_unrelated : (M,) array
        S (paper Eq. 4) of unrelated GT crop pairs; non-finite values are left out.

    Returns
    -------
    float
        Their median.

    Raises
    ------
    InputError
        Naming ``s_unrelated`` when no finite value is left.
    """
    s = np.asarray(s_unrelated, np.float64)
    s = s[np.isfinite(s)]
    if s.size == 0:
        raise InputError(param="s_unrelated", expected="S of at least one unrelated GT crop pair", got="none")
    return float(np.median(s))


def unrelated_pairs(track_ids: np.ndarray, classes: np.ndarray, *, max_pairs: int, seed: int = 0,
                    allow_same_class: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), i < j, of crops from different tracks and (unless
    ``allow_same_class``) different classes; a uniform sample of at most ``max_pairs``.

    Parameters
    ----------
    track_ids : (N,) array of str
        Track of each crop.
    classes : (N,) array of str
        Class of each crop.
    max_pairs : int
        Largest number of pairs returned.
    seed : int, optional
        Seed of the sample.
    allow_same_class : bool, optional
        Also pair crops of the same class (different tracks).

    Returns
    -------
    i, j : (M,) int64
        Crop indices, ``i < j``, ``M <= max_pairs``.

    >>> i, j = unrelated_pairs(np.array(["a", "a", "b", "c"]), np.array(["car", "car", "car", "ped"]),
    ...                        max_pairs=10)
    >>> sorted(zip(i.tolist(), j.tolist()))
    [(0, 3), (1, 3), (2, 3)]
    """
    track_ids, classes = np.asarray(track_ids), np.asarray(classes)
    i, j = np.triu_indices(len(track_ids), k=1)
    ok = track_ids[i] != track_ids[j]
    if not allow_same_class:
        ok &= classes[i] != classes[j]
    i, j = i[ok], j[ok]
    if len(i) > max_pairs:
        pick = np.sort(np.random.default_rng(seed).choice(len(i), size=max_pairs, replace=False))
        i, j = i[pick], j[pick]
    return i, j


def _check_calibrate_args(encoder, **counts: int) -> None:
    """Validate :func:`calibrate_tau`'s keyword arguments (naming each parameter)."""
    if encoder is None or not hasattr(encoder, "embed"):
        raise InputError(param="encoder", expected="a loaded encoder", got=encoder)
    for name, value in counts.items():
        check_int(name, value)


def _embed_gt_crops(paths, boxes: np.ndarray, encoder, *, batch_size: int, progress: bool,
                    where: str) -> np.ndarray:
    """Embeddings (N, D) of the crops ``boxes`` (N, 4) of images ``paths`` (N,), with a progress bar."""
    crops = read_crops(paths, boxes, where=where)
    step = batch_size * 4
    parts = [embed_crops(crops[k:k + step], encoder, batch_size=batch_size)
             for k in tqdm(range(0, len(crops), step), unit="chunk", file=sys.stderr,
                           disable=not progress, desc="embed")]
    return np.concatenate(parts) if parts else np.zeros((0, 0), np.float32)


@dataclass
class Calibration:
    """``s``: S of every unrelated pair (M,); ``tau``: the median; counts for the report.

    Attributes
    ----------
    encoder : str
        The encoder name.
    s : (M,) float64
        S (paper Eq. 4) of every unrelated pair.
    tau : float
        Their median.
    n_crops : int
        GT crops used.
    """

    encoder: str
    s: np.ndarray
    tau: float
    n_crops: int

    def summary(self) -> str:
        q = np.quantile(self.s, [0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 1.0])
        return (f"{self.encoder}: S over {len(self.s)} unrelated GT crop pairs "
                f"({self.n_crops} crops): min {q[0]:.3f}, p5 {q[1]:.3f}, p25 {q[2]:.3f}, "
                f"median {q[3]:.3f}, p75 {q[4]:.3f}, p95 {q[5]:.3f}, max {q[6]:.3f}, "
                f"mean {self.s.mean():.3f}\nrecommended tau = median = {self.tau:.3f}")


@dataclass(frozen=True)
class CalibrationOptions:
    """How :func:`calibrate_tau` samples the GT crops (``nvrq calibrate-tau``'s options).

    Parameters
    ----------
    max_crops : int
        At most this many GT crops, one per (camera, track, timestamp), sampled uniformly.
    max_pairs : int
        At most this many unrelated pairs among them.
    seed : int
        Seeds both samples.
    allow_same_class : bool
        Also pair objects of one class (different tracks).
    batch_size : int
        Crops per encoder batch.

    """

    max_crops: int = 400
    max_pairs: int = 20000
    seed: int = 0
    allow_same_class: bool = False
    batch_size: int = 32


def calibrate_tau(pairs: pd.DataFrame, encoder, options: CalibrationOptions | None = None, *,
                  scene_root=None, progress: bool = True, where: str = "pairs",
                  **keywords) -> Calibration:
    """Measure ``encoder``'s noise floor on the GT crops of ``pairs`` (docs/FORMATS.md §3 table).

    One GT crop per (camera, track, timestamp) is used; at most ``options.max_crops`` of them
    (uniform sample, ``options.seed``), then at most ``options.max_pairs`` unrelated pairs
    among them.

    Parameters
    ----------
    pairs : pandas.DataFrame
        The pairs table (``track_id``, ``label_class``, ``gt_path`` and the GT box columns).
    encoder : Encoder
        The embedding model whose noise floor is measured.
    options : CalibrationOptions, optional
        The sample sizes, seed, class rule and batch size (default ``CalibrationOptions()``).
    scene_root : str or Path, optional
        The scene folder the image paths are relative to.
    progress : bool
        Show a progress bar.
    where : str
        The input named in errors.
    **keywords
        Deprecated spelling, kept for earlier callers: the fields of :class:`CalibrationOptions`
        as keywords. Not together with ``options``.

    Returns
    -------
    Calibration
        The similarities of the unrelated pairs and the recommended tau.
    """
    o = options_or_keywords(CalibrationOptions, options, keywords, who="calibrate_tau")
    max_crops, max_pairs, seed = o.max_crops, o.max_pairs, o.seed
    allow_same_class, batch_size = o.allow_same_class, o.batch_size
    _check_calibrate_args(encoder, max_crops=max_crops, max_pairs=max_pairs, batch_size=batch_size)
    require_columns(pairs, ["track_id", "label_class", "gt_path", *GT_BOX_COLUMNS], where=where)
    keys = [c for c in ("camera", "track_id", "timestamp_us") if c in pairs.columns]
    crops = pairs.drop_duplicates(subset=keys + ["gt_path"]).reset_index(drop=True)
    if len(crops) > max_crops:
        crops = crops.sample(n=max_crops, random_state=seed).reset_index(drop=True)
    i, j = unrelated_pairs(crops["track_id"].astype(str).to_numpy(),
                           crops["label_class"].astype(str).to_numpy(),
                           max_pairs=max_pairs, seed=seed, allow_same_class=allow_same_class)
    if len(i) == 0:
        what = "different tracks" + ("" if allow_same_class else " and classes")
        raise InputError(where, "track_id/label_class",
                         f"GT crops of at least two objects of {what}"
                         + ("" if allow_same_class else " (or `allow_same_class`)"),
                         f"{plural(crops['track_id'].nunique(), 'track')}, "
                         f"{plural(crops['label_class'].nunique(), 'class', 'classes')}")
    used = np.unique(np.concatenate([i, j]))
    crops = crops.iloc[used].reset_index(drop=True)
    remap = np.full(used.max() + 1, -1)
    remap[used] = np.arange(len(used))
    paths = pair_image_paths(crops, "gt_path", scene_root=scene_root, where=where)
    feats = _embed_gt_crops(paths, pair_boxes(crops, GT_BOX_COLUMNS, where=where), encoder,
                            batch_size=batch_size, progress=progress, where=where)
    s = nvrq_similarity(feats[remap[i]], feats[remap[j]])
    return Calibration(encoder.spec.name, s, recommend_tau(s), len(crops))
