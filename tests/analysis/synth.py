"""A small synthetic ``ratings.csv`` for the analysis tests (docs/FORMATS.md §5 columns).

Quality falls with |y_offset_m|; GVF follows it through simulated raters; the metric
columns are noisy functions of the same quality (``nvrq``/``nvrq_ca`` higher-better,
``blurriness`` lower-better, unknown to the registry).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from data_schema.tables import pair_id

OFFSETS = (-2.0, -1.0, 0.0, 1.0, 2.0)


def make_ratings(
    *, n_clips: int = 3, n_tracks: int = 4, n_frames: int = 2, n_raters: int = 5, seed: int = 0
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Returns (ratings, metrics) DataFrames; metrics has pair_id + nvrq columns."""
    rng = np.random.default_rng(seed)
    rows = []
    for c in range(n_clips):
        lighting = ["day", "night"][c % 2]
        for t in range(n_tracks):
            cls = ["automobile", "pedestrian"][t % 2]
            for f in range(n_frames):
                for off in OFFSETS:
                    rows.append(
                        {
                            "clip_id": f"clip{c}",
                            "camera": "front",
                            "track_id": f"t{t}",
                            "label_class": cls,
                            "timestamp_us": f * 100000,
                            "y_offset_m": off,
                            "lighting": lighting,
                        }
                    )
    pairs = pd.DataFrame(rows)
    pairs["item_id"] = [
        pair_id(r.clip_id, r.camera, r.track_id, r.timestamp_us, r.y_offset_m)
        for r in pairs.itertuples()
    ]
    quality = np.exp(-np.abs(pairs["y_offset_m"].to_numpy()) / 1.5) + rng.normal(
        0, 0.05, len(pairs)
    )
    votes = []
    for r in range(n_raters):
        p_good = np.clip(quality + rng.normal(0, 0.15, len(pairs)), 0, 1)
        v = (rng.random(len(pairs)) < p_good).astype(int)
        d = pairs.copy()
        d["rater_id"] = f"sim-{r}"
        d["vote"] = v
        d["kind"] = "test"
        votes.append(d)
        for g, exp in (("gold-good:a", 1), ("gold-bad:b", 0)):
            votes.append(
                pd.DataFrame([{"item_id": g, "rater_id": f"sim-{r}", "vote": exp, "kind": "gold"}])
            )
        votes.append(d.iloc[:3].assign(kind="repeat"))
    out = pd.concat(votes, ignore_index=True)
    out["voted_at"] = "2026-01-01T00:00:00Z"
    out["response_ms"] = rng.integers(800, 3000, len(out))
    out["blurriness"] = np.nan
    q = dict(zip(pairs["item_id"], quality, strict=True))
    blur = {k: 1 - v + rng.normal(0, 0.1) for k, v in q.items()}
    out["blurriness"] = out["item_id"].map(blur)
    out["s_det"] = out["item_id"].map(
        {k: np.clip(v + rng.normal(0, 0.1), 0, 1) for k, v in q.items()}
    )
    cols = [
        "item_id",
        "rater_id",
        "vote",
        "voted_at",
        "response_ms",
        "kind",
        "clip_id",
        "camera",
        "track_id",
        "label_class",
        "timestamp_us",
        "y_offset_m",
        "lighting",
        "blurriness",
        "s_det",
    ]
    metrics = pd.DataFrame(
        {
            "pair_id": pairs["item_id"],
            "nvrq:dinov2-small": quality + rng.normal(0, 0.1, len(pairs)),
            "nvrq_ca:dinov2-small": quality + rng.normal(0, 0.05, len(pairs)),
        }
    )
    return out[cols], metrics
