"""The study design (paper section 4): which tracks, frames and views raters see.

Pure functions on a pairs table (docs/FORMATS.md §3). A *track* is ``(clip_id, track_id)``; a
*frame* of it is ``(camera, timestamp_us)``. A *view* is a render perturbation, keyed by its
label (:mod:`data_schema.perturbation`; a lateral offset ``y`` is the view ``y=+1.00``, 0 is
``none``). A frame is usable when the pairs table holds the object in **every** chosen view
there, so with views along several axes (``'all'``) every chosen frame is shown along each
axis; raters never see which (items are opaque).

- :func:`parse_offsets`: ``'all'`` or a comma list, matched at 0.01 m (as in ``pair_id``).
- :func:`choose_views`: ``'all'`` (every view of the table) or lateral offsets as labels.
- :func:`choose_tracks`: tracks spread over strata (label class x scene attributes):
  strata are visited round-robin in a seeded random order, one random track each visit.
- :func:`spread_frames`: ``k`` frames evenly along the track (by time), first and last
  included.

>>> spread_frames(10, 4)
[0, 3, 6, 9]
>>> spread_frames(3, 12)
[0, 1, 2]
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN
from data_schema.perturbation import (
    AXES,
    EXTRA_PERTURBATION_COLUMNS,
    VIEW_COLUMNS,
    labels,
    lateral,
    perturbation_array,
)
from data_schema.tables import PAIRS_COLUMNS, offset_cm, parse_offsets

__all__ = ["choose_offsets", "choose_views", "attribute_columns", "usable_frames", "choose_tracks",
           "spread_frames", "select_test_pairs"]

_EXTRA_NON_ATTRIBUTES = ("scene_root", *VIEW_COLUMNS, METHOD_COLUMN)


def attribute_columns(pairs: pd.DataFrame) -> list[str]:
    """Scene attribute columns: those after the contract columns (``scene_root``, the view
    columns, ``method`` and ``_*`` excluded)."""
    return [c for c in pairs.columns if c not in PAIRS_COLUMNS
            and c not in _EXTRA_NON_ATTRIBUTES and not str(c).startswith("_")]


def choose_offsets(spec: str, available) -> list[float]:
    """Chosen offsets (sorted, metres) from ``'all'`` or ``'0,1.5,-1.5'``, among ``available``.

    >>> choose_offsets("all", [0.0, 1.0, -1.0, 1.0])
    [-1.0, 0.0, 1.0]
    >>> choose_offsets("1, 0", [0.0, 1.0, -1.0])
    [0.0, 1.0]
    """
    have = sorted(set(offset_cm(available).tolist()))
    if str(spec).strip().lower() == "all":
        chosen = have
    else:
        chosen = sorted(set(offset_cm(parse_offsets(spec, field="offsets")).tolist()))
        missing = [c for c in chosen if c not in have]
        if missing or not chosen:
            raise InputError("offsets", None,
                             f"offsets present in the pairs table ({[h / 100 for h in have]})", spec)
    return [c / 100 for c in chosen]


def _view_keys(views) -> list[str]:
    """View labels from labels, or from lateral offsets in metres (the former API)."""
    views = list(views)
    if all(isinstance(v, str) for v in views):
        return views
    return labels(lateral(views))


def _view_order(label: str) -> tuple:
    """Sort key of a view label: axis order, then value ('none' first)."""
    if label == "none":  # the real camera sits at 0 among the lateral offsets
        return (AXES.index("y"), 0.0, label)
    axis, _, value = label.split(",")[0].partition("=")
    return (AXES.index(axis) if "," not in label else len(AXES), float(value), label)


def choose_views(spec: str, pairs: pd.DataFrame) -> list[str]:
    """Chosen view labels: ``'all'`` -> every view of ``pairs`` (old tables: their offsets);
    else a comma list of lateral offsets in metres (:func:`parse_offsets`).

    >>> choose_views("all", pd.DataFrame({"y_offset_m": [1.0, 0.0], "yaw_deg": [0.0, 5.0]}))
    ['y=+1.00', 'yaw=+5.00']
    """
    if str(spec).strip().lower() == "all":
        return sorted(set(labels(perturbation_array(pairs))), key=_view_order)
    lat = pairs[~pairs.reindex(columns=list(EXTRA_PERTURBATION_COLUMNS), fill_value=0.0).ne(0).any(axis=1)]
    return _view_keys(choose_offsets(spec, lat["y_offset_m"]))


def usable_frames(pairs: pd.DataFrame, offsets: list) -> pd.DataFrame:
    """One row per (clip_id, track_id, camera, timestamp_us) holding every chosen view.

    ``offsets``: view labels, or lateral offsets in metres. Columns: clip_id, track_id,
    camera, timestamp_us, label_class + attribute columns.
    """
    want = set(_view_keys(offsets))
    df = pairs.assign(_cm=labels(perturbation_array(pairs)))
    df = df[df["_cm"].isin(want)]
    keys = ["clip_id", "track_id", "camera", "timestamp_us"]
    counts = df.groupby(keys, sort=True)["_cm"].nunique()
    full = counts[counts == len(want)].index
    first = df.drop_duplicates(keys).set_index(keys)
    cols = ["label_class", *attribute_columns(pairs)]
    return first.loc[full, cols].reset_index()


def choose_tracks(frames: pd.DataFrame, n_tracks: int, rng: np.random.Generator) -> list[tuple]:
    """``n_tracks`` (clip_id, track_id) keys spread over label class x attribute strata."""
    attrs = [c for c in frames.columns if c not in ("clip_id", "track_id", "camera", "timestamp_us")]
    tracks = frames.drop_duplicates(["clip_id", "track_id"])
    strata: dict[tuple, list[tuple]] = {}
    for row in tracks.itertuples(index=False):
        d = row._asdict()
        strata.setdefault(tuple(str(d[a]) for a in attrs), []).append((d["clip_id"], d["track_id"]))
    pools = [strata[k] for k in sorted(strata)]
    pools = [[p[i] for i in rng.permutation(len(p))] for p in pools]
    pools = [pools[i] for i in rng.permutation(len(pools))]
    chosen: list[tuple] = []
    while len(chosen) < n_tracks and any(pools):
        for pool in pools:
            if pool and len(chosen) < n_tracks:
                chosen.append(pool.pop(0))
    return chosen


def spread_frames(n: int, k: int) -> list[int]:
    """Indices of ``min(n, k)`` positions spread evenly over ``range(n)``."""
    if n <= k:
        return list(range(n))
    return sorted(set(np.round(np.linspace(0, n - 1, k)).astype(int).tolist()))


def select_test_pairs(pairs: pd.DataFrame, *, offsets: list[float], n_tracks: int,
                      frames_per_track: int, rng: np.random.Generator
                      ) -> tuple[pd.DataFrame, list[dict]]:
    """Test pairs of the design and a JSON-able record of the chosen tracks and frames."""
    frames = usable_frames(pairs, offsets)
    if frames.empty:
        raise InputError("pairs", "y_offset_m",
                         f"at least one (track, frame) holding every view {offsets}", "none")
    chosen = choose_tracks(frames, n_tracks, rng)
    record, keep = [], []
    for clip_id, track_id in chosen:
        tf = frames[(frames["clip_id"] == clip_id) & (frames["track_id"] == track_id)]
        tf = tf.sort_values(["timestamp_us", "camera"]).reset_index(drop=True)
        idx = spread_frames(len(tf), frames_per_track)
        sel = tf.iloc[idx]
        keep.append(sel[["clip_id", "track_id", "camera", "timestamp_us"]])
        record.append({"clip_id": str(clip_id), "track_id": str(track_id),
                       "label_class": str(tf["label_class"].iloc[0]),
                       "frames": [[str(c), int(t)] for c, t in zip(sel["camera"], sel["timestamp_us"], strict=True)]})
    keys = pd.concat(keep, ignore_index=True)
    want = set(_view_keys(offsets))
    sel = pairs.merge(keys, on=["clip_id", "track_id", "camera", "timestamp_us"])
    sel = sel[np.isin(labels(perturbation_array(sel)), sorted(want))]
    sel = sel.drop_duplicates("pair_id")
    order = ["y_offset_m", *[c for c in EXTRA_PERTURBATION_COLUMNS if c in sel.columns]]
    return sel.sort_values(["clip_id", "track_id", "timestamp_us", "camera", *order], kind="stable"
                           ).reset_index(drop=True), record
