"""Scale of ``analyze``: correlation tables and breakdowns on 30M crop-level rows.

The paper breaks down 28.4M crop-level rows of 919 clips. This script generates that many
per-item rows (a target with ties like a GVF of 5 votes, 3 metric columns, label_class,
two scene attributes, 919 clips, 5 offsets), then times the library functions ``analyze``
uses — :func:`analysis.summary.summary_table` (PLCC, SRCC, KRCC, ROC AUC, logistic PLCC; the
bootstrap is skipped at this scale, as the issue allows) and
:func:`analysis.breakdowns.category_table` / ``offset_table`` — and prints the wall time of
each stage and the peak resident memory. Target: under 5 minutes and 8 GB on 2 cores.

    python benchmarks/bench_analyze.py               # 30M rows
    python benchmarks/bench_analyze.py --rows 1000000
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np
import pandas as pd

from analysis.breakdowns import category_table, offset_table
from analysis.summary import summary_table


def make_items(n: int, n_metrics: int, seed: int) -> pd.DataFrame:
    """(n,) rows: gvf, majority_good, m0..m{k-1}, label_class, lighting, road_type, clip_id, y_offset_m."""
    rng = np.random.default_rng(seed)
    quality = rng.random(n, dtype=np.float64)
    gvf = np.clip(np.round((quality + rng.normal(0, 0.2, n)) * 5) / 5, 0, 1)
    df = pd.DataFrame({"gvf": gvf, "majority_good": gvf >= 0.5})
    for k in range(n_metrics):
        df[f"m{k}"] = quality + rng.normal(0, 0.1 + 0.1 * k, n)
    cats = {
        "label_class": ["automobile", "truck", "pedestrian", "cyclist", "bus"],
        "lighting": ["daytime", "night", "dusk"],
        "road_type": ["urban", "highway", "rural"],
    }
    for col, names in cats.items():
        df[col] = pd.Categorical.from_codes(rng.integers(0, len(names), n).astype(np.int8), names)
    df["clip_id"] = pd.Categorical.from_codes(
        rng.integers(0, 919, n).astype(np.int16), [f"clip{i:04d}" for i in range(919)]
    )
    df["y_offset_m"] = rng.choice(np.array([-2.0, -1.0, 0.0, 1.0, 2.0]), n)
    return df


def cpu_s() -> float:
    """CPU seconds of this process (user + system): on a shared machine, wall time overstates."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def peak_rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2  # Linux: KiB


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=30_000_000)
    ap.add_argument("--metrics", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    t0, c0 = time.perf_counter(), cpu_s()
    items = make_items(args.rows, args.metrics, args.seed)
    metrics = [f"m{k}" for k in range(args.metrics)]
    t1, c1 = time.perf_counter(), cpu_s()
    print(
        f"generated {args.rows:,} rows x {args.metrics} metrics in {t1 - t0:.1f} s; "
        f"peak RSS {peak_rss_gb():.2f} GB"
    )

    summary = summary_table(items, metrics, dict.fromkeys(metrics, True), n_boot=0, progress=False)
    t2 = time.perf_counter()
    print(f"summary table (plcc, srcc, krcc, roc_auc, logistic plcc): {t2 - t1:.1f} s")
    print(
        summary[["metric", "n", "plcc", "srcc", "krcc", "roc_auc", "plcc_logistic"]].to_string(
            index=False
        )
    )

    cats = category_table(
        items, metrics, by=["label_class", "lighting", "road_type"], progress=False
    )
    t3 = time.perf_counter()
    print(f"breakdowns by label_class, lighting, road_type ({len(cats)} rows): {t3 - t2:.1f} s")
    offset_table(items, ["gvf"] + metrics)
    t4, c4 = time.perf_counter(), cpu_s()
    print(f"per-offset table: {t4 - t3:.1f} s")
    print(f"analysis CPU time {c4 - c1:.1f} s (generation {c1 - c0:.1f} s)")
    print(
        f"analysis total {t4 - t1:.1f} s (target < 300 s); peak RSS {peak_rss_gb():.2f} GB (target < 8 GB)"
    )


if __name__ == "__main__":
    main()
