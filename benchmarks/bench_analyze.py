"""Speed of ``analyze``: the ratings path beside the all-pairs path, rows per second of both in
one run; and (``--stages``) the library's correlation tables and breakdowns at 30M rows.

Default: writes (once; ``--data DIR`` keeps them for reruns) a ``ratings.csv`` of ``--items``
items x ``--raters`` raters test votes (50,000 x 20 = 1M rows; docs/FORMATS.md §5 columns, two
scene attributes) with a metrics table (``psnr, ssim, gmsd``), and a pairs dataset of
``--pairs`` rows with metrics and a proxy (:func:`bench_analyze_pairs.generate`, the layout of
``nvrq pairs`` / ``nvrq score --engine ray``). Then runs, as subprocesses, ::

    analyze RATINGS --metrics-table METRICS --bootstrap 0 --out REPORT
    analyze --pairs PAIRS --metrics-table METRICS --metrics-table PROXY --target clip_drop --bootstrap 0 --out REPORT

and prints each one's wall time, CPU time and rows/s side by side, with their ratio. Target:
1M rating rows in <= 20 s (issue 23: it took about 60 s, while 30M pairs took about 210 s).

    python benchmarks/bench_analyze.py                        # 1M rating rows, 3M pairs
    python benchmarks/bench_analyze.py --pairs 30000000       # the paper's all-pairs scale
    python benchmarks/bench_analyze.py --stages --rows 3000000
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.tables.breakdowns import category_table, offset_table
from analysis.tables.summary import summary_table

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_analyze_pairs import generate as generate_pairs  # noqa: E402

OFFSETS = np.array([-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0])
CLASSES = np.array(["automobile", "heavy_truck", "pedestrian", "cyclist", "bus"])


def write_ratings(d: Path, n_items: int, n_raters: int, seed: int) -> int:
    """``d/ratings.csv`` (items x raters test votes, rows in rater-major order as an export
    by session writes them) and ``d/metrics.csv``; returns the number of vote rows."""
    rng = np.random.default_rng(seed)
    clip, track = rng.integers(0, 200, n_items), rng.integers(0, 60, n_items)
    ts, off = np.arange(n_items) * 100_000, rng.choice(OFFSETS, n_items)
    clips, tracks = np.char.add("clip", clip.astype(str)), np.char.add("t", track.astype(str))
    item = np.array([f"{c}:front:{t}:{s}:{o:+.2f}" for c, t, s, o in
                     zip(clips.tolist(), tracks.tolist(), ts.tolist(), off.tolist(), strict=True)])
    quality = np.exp(-np.abs(off) / 2) + rng.normal(0, 0.05, n_items)
    i = np.tile(np.arange(n_items), n_raters)
    r = np.repeat(np.arange(n_raters), n_items)
    vote = rng.random(i.size) < np.clip(quality[i] + rng.normal(0, 0.15, i.size), 0, 1)
    pd.DataFrame({
        "item_id": item[i], "rater_id": np.char.add("r", r.astype(str)), "vote": vote.astype(int),
        "voted_at": "2026-01-01T00:00:00Z", "response_ms": rng.integers(800, 3000, i.size),
        "kind": "test", "clip_id": clips[i], "camera": "front", "track_id": tracks[i],
        "label_class": CLASSES[track % 5][i], "timestamp_us": ts[i], "y_offset_m": off[i],
        "lighting": np.array(["daytime", "night"])[clip % 2][i],
        "road_type": np.array(["urban", "highway", "rural"])[clip % 3][i],
    }).to_csv(d / "ratings.csv", index=False)
    pd.DataFrame({"pair_id": item, "psnr": 20 + 10 * quality + rng.normal(0, 2, n_items),
                  "ssim": quality + rng.normal(0, 0.2, n_items),
                  "gmsd": 0.3 - 0.2 * quality + rng.normal(0, 0.05, n_items)}).to_csv(d / "metrics.csv", index=False)
    return int(i.size)


def run_analyze(args: list[str]) -> tuple[float, float]:
    """``analyze ARGS`` as a subprocess: ``(wall s, CPU s of the child)``; exits on failure."""
    cli = Path(sys.executable).with_name("analyze")
    cmd = [str(cli) if cli.is_file() else "analyze", *args, "--bootstrap", "0", "--quiet"]
    print("$ " + " ".join(cmd), flush=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode:
        print(proc.stderr[-2000:])
        sys.exit(proc.returncode)
    return wall, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def compare(args) -> None:
    root = Path(args.data) if args.data else Path(tempfile.mkdtemp(prefix="bench_analyze_"))
    rd, pdir = root / f"ratings_{args.items}x{args.raters}", root / f"pairs_{args.pairs}"
    rd.mkdir(parents=True, exist_ok=True)
    n_votes = args.items * args.raters
    if not (rd / "metrics.csv").is_file():
        t0 = time.perf_counter()
        write_ratings(rd, args.items, args.raters, args.seed)
        print(f"wrote {n_votes:,} rating rows in {time.perf_counter() - t0:.1f} s -> {rd}")
    if not (pdir / "proxy" / "_dataset.json").is_file():
        t0 = time.perf_counter()
        generate_pairs(pdir, args.pairs, args.seed, args.clips)
        print(f"wrote {args.pairs:,} pairs in {args.clips} clips in {time.perf_counter() - t0:.1f} s -> {pdir}")
    r_wall, r_cpu = run_analyze([str(rd / "ratings.csv"), "--metrics-table", str(rd / "metrics.csv"),
                                 "--out", str(root / "report_ratings")])
    p_wall, p_cpu = run_analyze(["--pairs", str(pdir / "pairs"), "--metrics-table", str(pdir / "metrics"),
                                 "--metrics-table", str(pdir / "proxy"), "--target", "clip_drop",
                                 "--out", str(root / "report_pairs")])
    r_rate, p_rate = n_votes / r_wall, args.pairs / p_wall
    print(f"ratings path: {n_votes:,} rows ({args.items:,} items x {args.raters} raters) in {r_wall:.1f} s "
          f"wall, {r_cpu:.1f} s CPU: {r_rate:,.0f} rows/s ({n_votes / r_cpu:,.0f} per CPU s); "
          f"target <= 20 s for 1M rows")
    print(f"pairs path:   {args.pairs:,} rows in {p_wall:.1f} s wall, {p_cpu:.1f} s CPU: {p_rate:,.0f} rows/s "
          f"({args.pairs / p_cpu:,.0f} per CPU s)")
    print(f"ratings rows/s over pairs rows/s: {r_rate / p_rate:.2f} (wall), "
          f"{(n_votes / r_cpu) / (args.pairs / p_cpu):.2f} (CPU)")


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


def stages(args) -> None:
    """The library functions ``analyze`` uses on ``--rows`` per-item rows (a target with ties
    like a GVF of 5 votes, ``--metrics`` columns, label_class, two scene attributes, 919 clips,
    5 offsets): wall time of each stage and peak RSS. Target: under 5 minutes and 8 GB at 30M."""
    t0, c0 = time.perf_counter(), cpu_s()
    items = make_items(args.rows, args.metrics, args.seed)
    metrics = [f"m{k}" for k in range(args.metrics)]
    t1, c1 = time.perf_counter(), cpu_s()
    print(f"generated {args.rows:,} rows x {args.metrics} metrics in {t1 - t0:.1f} s; "
          f"peak RSS {peak_rss_gb():.2f} GB")
    summary = summary_table(items, metrics, dict.fromkeys(metrics, True), n_boot=0, progress=False)
    t2 = time.perf_counter()
    print(f"summary table (plcc, srcc, krcc, roc_auc, logistic plcc): {t2 - t1:.1f} s")
    print(summary[["metric", "n", "plcc", "srcc", "krcc", "roc_auc", "plcc_logistic"]].to_string(index=False))
    cats = category_table(items, metrics, by=["label_class", "lighting", "road_type"], progress=False)
    t3 = time.perf_counter()
    print(f"breakdowns by label_class, lighting, road_type ({len(cats)} rows): {t3 - t2:.1f} s")
    offset_table(items, ["gvf"] + metrics)
    t4, c4 = time.perf_counter(), cpu_s()
    print(f"per-offset table: {t4 - t3:.1f} s")
    print(f"analysis CPU time {c4 - c1:.1f} s (generation {c1 - c0:.1f} s)")
    print(f"analysis total {t4 - t1:.1f} s (target < 300 s); peak RSS {peak_rss_gb():.2f} GB (target < 8 GB)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--items", type=int, default=50_000, help="rated items (default 50,000)")
    ap.add_argument("--raters", type=int, default=20, help="raters, each rating every item (default 20)")
    ap.add_argument("--pairs", type=int, default=3_000_000, help="rows of the pairs dataset (default 3M)")
    ap.add_argument("--clips", type=int, default=919, help="clips of the pairs dataset (default 919)")
    ap.add_argument("--data", default=None, help="keep the generated inputs here (reused if present)")
    ap.add_argument("--stages", action="store_true", help="time the library stages on --rows items instead")
    ap.add_argument("--rows", type=int, default=30_000_000, help="--stages: per-item rows (default 30M)")
    ap.add_argument("--metrics", type=int, default=3, help="--stages: metric columns (default 3)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    stages(args) if args.stages else compare(args)


if __name__ == "__main__":
    main()
