"""``analyze --pairs`` through the CLI at the paper's scale: 30M pairs x 3 metrics + a target.

Writes (once; ``--data DIR`` keeps it for reruns) three Parquet datasets partitioned by
``clip_id`` over 919 clips, as ``nvrq pairs`` (fleet) and ``nvrq score --engine ray`` write
them: the pairs (every contract column, two scene attributes, ``scene_root``), a metrics dataset
(``psnr, ssim, gmsd``) and a proxy dataset (``clip_drop``). Then runs

    analyze --pairs PAIRS --metrics-table METRICS --metrics-table PROXY --target clip_drop --out REPORT

as a subprocess and prints its wall time and peak resident memory (``ru_maxrss`` of the
child). Target: <= 300 s and <= 8 GB on 2 cores.

    python benchmarks/bench_analyze_pairs.py                  # 30M rows
    python benchmarks/bench_analyze_pairs.py --rows 3000000 --data /tmp/ap3m
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
import pyarrow as pa
import pyarrow.parquet as pq

from data_schema.datasets import partition_dir, write_manifest

N_CLIPS = 919
CLASSES = ["automobile", "heavy_truck", "pedestrian", "cyclist", "bus"]
OFFSETS = np.array([-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0])


def _clip_tables(clip: str, n: int, rng: np.random.Generator):
    """(pairs, metrics, proxy) pyarrow tables of one clip's n pairs (files omit clip_id)."""
    track = rng.integers(0, 60, n)
    ts = np.sort(rng.integers(0, 200, n)) * 100_000
    off = rng.choice(OFFSETS, n)
    tid = np.char.add("t", track.astype(str))
    pid = [f"{clip}:front:{t}:{s}:{o:+.2f}" for t, s, o in zip(tid.tolist(), ts.tolist(), off.tolist(), strict=True)]
    quality = rng.random(n) * np.exp(-np.abs(off) / 3)
    box = rng.integers(0, 900, (n, 4))
    pairs = {"pair_id": pid, "camera": np.full(n, "front"), "track_id": tid,
             "label_class": np.array(CLASSES)[track % 5], "timestamp_us": ts, "y_offset_m": off,
             "gt_path": np.char.add("images/gt/front/", ts.astype(str)),
             "render_path": np.char.add("images/render/front/", ts.astype(str))}
    for j, c in enumerate(("x0", "y0", "x1", "y1")):
        pairs[f"gt_{c}"] = box[:, j]
        pairs[f"r_{c}"] = box[:, j] + 3
    h = abs(hash(clip))
    pairs["lighting"] = np.full(n, ["daytime", "night", "dusk"][h % 3])
    pairs["road_type"] = np.full(n, ["urban", "highway", "rural"][(h // 3) % 3])
    pairs["scene_root"] = np.full(n, f"/data/{clip}")
    metrics = {"pair_id": pid, "psnr": 20 + 10 * quality + rng.normal(0, 2, n),
               "ssim": quality + rng.normal(0, 0.2, n), "gmsd": 0.3 - 0.2 * quality + rng.normal(0, 0.05, n)}
    proxy = {"pair_id": pid, "clip_drop": 1 - quality + rng.normal(0, 0.1, n)}
    return pa.table(pairs), pa.table(metrics), pa.table(proxy)


def generate(root: Path, rows: int, seed: int, n_clips: int = N_CLIPS) -> None:
    rng = np.random.default_rng(seed)
    sizes = np.full(n_clips, rows // n_clips)
    sizes[: rows - sizes.sum()] += 1
    files = []
    for i, n in enumerate(sizes):
        clip = f"clip{i:04d}"
        rel = f"{partition_dir(clip)}/part-0.parquet"
        for name, table in zip(("pairs", "metrics", "proxy"), _clip_tables(clip, int(n), rng), strict=True):
            (root / name / rel).parent.mkdir(parents=True, exist_ok=True)
            pq.write_table(table, root / name / rel)
        files.append(rel)
    for name in ("pairs", "metrics", "proxy"):
        write_manifest(root / name, files, rows=rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=30_000_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--clips", type=int, default=N_CLIPS, help=f"clips (default {N_CLIPS}, the paper's)")
    ap.add_argument("--data", default=None, help="keep the generated datasets here (reused if present)")
    args = ap.parse_args()
    root = Path(args.data) if args.data else Path(tempfile.mkdtemp(prefix="bench_ap_"))
    if not (root / "proxy" / "_dataset.json").is_file():
        t0 = time.perf_counter()
        generate(root, args.rows, args.seed, args.clips)
        print(f"generated {args.rows:,} pairs in {args.clips} clips in {time.perf_counter() - t0:.1f} s -> {root}")
    cli = Path(sys.executable).with_name("analyze")
    cmd = [str(cli) if cli.is_file() else "analyze", "--pairs", str(root / "pairs"),
           "--metrics-table", str(root / "metrics"), "--metrics-table", str(root / "proxy"),
           "--target", "clip_drop", "--out", str(root / "report"), "--quiet"]
    print("$ " + " ".join(cmd))
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    rss = ru.ru_maxrss / 1024**2  # Linux: KiB -> GB
    cpu = ru.ru_utime + ru.ru_stime  # on a shared machine wall time overstates the cost
    print(proc.stdout[-3000:])
    if proc.returncode:
        print(proc.stderr[-2000:])
        sys.exit(proc.returncode)
    print(f"analyze --pairs: {args.rows:,} rows x 3 metrics + target: wall {wall:.1f} s (target <= 300 s), "
          f"peak RSS {rss:.2f} GB (target <= 8 GB); CPU time {cpu:.1f} s")


if __name__ == "__main__":
    main()
