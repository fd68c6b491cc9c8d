"""Hand-built inputs of the method comparison (docs/FORMATS.md §3-6): a pairs table and a
metrics table with a ``method`` column, and pairwise votes.

Every object (clip, camera, track, timestamp, offset) is rendered by each method; a method's
degradation is ``scale * |offset|`` on top of an object effect shared by all methods (so the
comparison is paired). At offset 0 the methods differ only by a small independent noise:
near-identical renders, a tie.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from data_schema.tables import pair_id

OFFSETS = (-2.0, -1.0, 0.0, 1.0, 2.0)
METHODS = {"sharp": 0.5, "blurry": 1.5}
NVRQ_CA = "nvrq_ca:dinov2-small"


def make_method_tables(*, methods=None, n_clips: int = 2, n_tracks: int = 5, n_frames: int = 2,
                       seed: int = 0) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(pairs, metrics): one pair per object, view and method; pair id = object id + ':METHOD'."""
    methods = methods or METHODS
    rng = np.random.default_rng(seed)
    rows = []
    for c in range(n_clips):
        for t in range(n_tracks):
            cls = ["automobile", "pedestrian"][t % 2]
            effect = rng.normal(0, 1.0)
            for f in range(n_frames):
                for off in OFFSETS:
                    frame_effect = effect + rng.normal(0, 0.3)
                    for m, scale in methods.items():
                        noise = rng.normal(0, 0.05)
                        base = pair_id(f"clip{c}", "front", f"t{t}", f * 100000, off)
                        rows.append({
                            "pair_id": f"{base}:{m}", "clip_id": f"clip{c}", "camera": "front",
                            "track_id": f"t{t}", "label_class": cls, "timestamp_us": f * 100000,
                            "y_offset_m": off, "method": m, "lighting": ["day", "night"][c % 2],
                            "psnr": 30 + 2 * frame_effect - 3 * scale * abs(off) + noise,
                            NVRQ_CA: 0.8 + 0.02 * frame_effect - 0.08 * scale * abs(off) + noise / 100,
                        })
    df = pd.DataFrame(rows)
    metrics = df[["pair_id", "psnr", NVRQ_CA]].copy()
    pairs = df.drop(columns=["psnr", NVRQ_CA])
    return pairs, metrics


def make_pairwise_votes(pairs: pd.DataFrame, *, n_raters: int = 5, slope: float = 2.0,
                        seed: int = 0) -> pd.DataFrame:
    """Pairwise votes between the two methods of ``pairs`` (export columns of a pairwise study):
    each rater votes on every object and view; P(choose the less degraded side) follows a
    logistic of the severity difference ``slope * |scale_a - scale_b| * |offset|``, with a
    "can't tell" when the difference is small. Raters alternate the side of ``a``."""
    rng = np.random.default_rng(seed)
    names = list(METHODS)
    objects = pairs[pairs["method"] == names[0]].reset_index(drop=True)
    out = []
    for r in range(n_raters):
        for i, o in objects.iterrows():
            a, b = (names[0], names[1]) if i % 2 == 0 else (names[1], names[0])
            diff = slope * (METHODS[b] - METHODS[a]) * abs(o["y_offset_m"])  # > 0: a less degraded
            p_a = 1 / (1 + np.exp(-diff))
            u = rng.random()
            choice = "tie" if abs(diff) < 0.5 and u < 0.5 else ("a" if rng.random() < p_a else "b")
            out.append({"item_id": f"item-{i}", "rater_id": f"sim-{r}", "kind": "test",
                        "method_a": a, "method_b": b, "side_a": "left" if (i + r) % 2 else "right",
                        "choice": choice, "response_ms": 900.0,
                        **{c: o[c] for c in ("clip_id", "camera", "track_id", "label_class",
                                             "timestamp_us", "y_offset_m", "lighting")}})
    return pd.DataFrame(out)
