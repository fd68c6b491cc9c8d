"""Scale: the same ~1,000 pairs through the local engine and the Ray engine, side by side.

Writes a fleet of synthetic clips (smooth random 960x540 PNG images, 3 objects x 7 offsets
per frame: 1,008 pairs in 4 clips by default) as a pairs dataset partitioned by clip_id,
then scores it with ``psnr, ssim, nvrq, nvrq_ca`` (efficientnet-lite0, CPU):

- local: :func:`nvrq.scoring.driver.score_pairs` in this process (encoder load included);
- ray: :func:`nvrq.engines.ray_engine.score_on_ray` on a local Ray instance started first
  (its start-up is printed separately: a cluster is started once, not per run).

Prints pairs/s of each and the ratio (target: Ray >= 0.8x local on 2 cores), checks that
both give the same numbers, and with ``--stages`` the per-stage costs docs/SCALE.md quotes:
decode ms per image, crop ms per pair, encoder images/s per encoder (random weights: the
speed does not depend on them).

    python benchmarks/bench_scale.py
    python benchmarks/bench_scale.py --stages --frames 3
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from data_schema.datasets import DatasetWriter, read_dataset
from data_schema.tables import GT_BOX_COLUMNS, PAIRS_COLUMNS, pair_boxes, pair_id, pair_image_paths
from nvrq.crops import cut_box, encoder_input, read_rgb
from nvrq.encoders import ENCODERS, EncoderConfig, build_random, get_spec, load_encoder
from nvrq.encoders.memory import tune_allocator
from nvrq.engines.ray_engine import RayJob, score_on_ray
from nvrq.engines.scorers import MetricScorer
from nvrq.scoring.driver import score_pairs
from nvrq.scoring.plan import ScorePlan

OFFSETS = (-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0)
BOXES = [(100, 200, 299, 349), (420, 180, 579, 339), (700, 250, 779, 409)]
BATCH = 16  # encoder images per timed forward pass
COLUMNS = ["psnr", "ssim", "nvrq:efficientnet-lite0", "nvrq_ca:efficientnet-lite0"]


def _image(rng, h=540, w=960):
    coarse = rng.integers(0, 256, (h // 24 + 1, w // 24 + 1, 3)).astype(np.float32)
    img = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC) + rng.normal(0, 6, (h, w, 3))
    return np.clip(img, 0, 255).astype(np.uint8)


def write_fleet(root: Path, *, clips: int, frames: int) -> Path:
    """Scenes under ``root`` and their pairs dataset ``root/pairs`` (contract columns)."""

    rng = np.random.default_rng(0)
    with DatasetWriter(root / "pairs") as w:
        for c in range(clips):
            clip, scene, rows = f"clip{c:02d}", root / f"clip{c:02d}", []
            (scene / "img").mkdir(parents=True)
            for t in range(frames):
                ts = t * 100_000
                gt = _image(rng)
                cv2.imwrite(str(scene / f"img/gt_{ts}.png"), gt)
                for off in OFFSETS:
                    shift = int(4 * off)
                    r = np.roll(gt, shift, axis=1).astype(np.int16) + rng.normal(0, 3 + 3 * abs(off), gt.shape)
                    cv2.imwrite(str(scene / f"img/r_{ts}_{off:+.1f}.png"), np.clip(r, 0, 255).astype(np.uint8))
                    for j, (x0, y0, x1, y1) in enumerate(BOXES):
                        rows.append((pair_id(clip, "front", f"o{j}", ts, off), clip, "front", f"o{j}",
                                     "automobile", ts, off, f"img/gt_{ts}.png", f"img/r_{ts}_{off:+.1f}.png",
                                     x0, y0, x1, y1, x0 + shift, y0, x1 + shift, y1))
            df = pd.DataFrame(rows, columns=list(PAIRS_COLUMNS))
            df["scene_root"] = str(scene)
            w.write(clip, df)
    return root / "pairs"


def run_local(pairs_ds: Path) -> tuple[float, pd.DataFrame]:
    pairs = read_dataset(pairs_ds)
    tune_allocator()  # as `nvrq score` and the Ray actors do
    t0 = time.perf_counter()
    enc = load_encoder("efficientnet-lite0")
    res = score_pairs(pairs, ScorePlan.for_columns(COLUMNS, encoder=enc, tau=0.76),
                      encoder=enc, progress=False)
    return time.perf_counter() - t0, res.table


def run_ray(pairs_ds: Path, out: Path) -> tuple[float, float, pd.DataFrame]:
    import ray

    t0 = time.perf_counter()
    ray.init(include_dashboard=False, log_to_driver=False)
    start = time.perf_counter() - t0
    scorer = MetricScorer(tuple(COLUMNS), encoder=EncoderConfig("efficientnet-lite0"), tau=0.76)
    job = RayJob(pairs=str(pairs_ds), out=str(out), scorer=scorer, progress=False)
    t1 = time.perf_counter()
    score_on_ray(job, timing_path=out.with_name("ray.timing.csv"))
    wall = time.perf_counter() - t1
    ray.shutdown()
    return start, wall, read_dataset(out)


def _cpu() -> float:
    """CPU seconds of this process (all threads): robust to other load on a shared machine."""

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def stages(pairs_ds: Path) -> None:
    """Per-stage costs on this machine (decode, crop, encoder images/s per encoder)."""
    import torch

    pairs = read_dataset(pairs_ds).head(210)
    paths = pd.unique(pair_image_paths(pairs, "gt_path"))[:10]
    t0, c0 = time.perf_counter(), _cpu()
    imgs = [read_rgb(p) for p in paths]
    print(f"decode: {1000 * (time.perf_counter() - t0) / len(paths):.1f} ms wall, "
          f"{1000 * (_cpu() - c0) / len(paths):.1f} CPU-ms per 960x540 PNG image")
    boxes = pair_boxes(pairs, GT_BOX_COLUMNS)
    t0, c0 = time.perf_counter(), _cpu()
    for k, b in enumerate(boxes):
        encoder_input(cut_box(imgs[k % len(imgs)], b), 224)
    print(f"crop + pad + resize to 224: {1000 * (time.perf_counter() - t0) / len(boxes):.2f} ms wall, "
          f"{1000 * (_cpu() - c0) / len(boxes):.2f} CPU-ms per crop")
    print(f"encoders on CPU ({torch.get_num_threads()} threads, batch {BATCH}, random weights):")
    rng = np.random.default_rng(0)
    for name in ENCODERS:
        spec = get_spec(name)
        enc = build_random(name, runtime="torch")
        x = rng.integers(0, 256, (BATCH, spec.input_size, spec.input_size, 3), dtype=np.uint8)
        enc.embed(x[:2])
        t0, c0 = time.perf_counter(), _cpu()
        enc.embed(x)
        wall, cpu = time.perf_counter() - t0, _cpu() - c0
        print(f"  {name}: {BATCH / wall:.1f} images/s wall, {1000 * cpu / BATCH:.0f} CPU-ms per image "
              f"({spec.input_size} px)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clips", type=int, default=4)
    ap.add_argument("--frames", type=int, default=12, help="frames per clip (21 pairs each)")
    ap.add_argument("--stages", action="store_true", help="also print the per-stage costs")
    ap.add_argument("--stages-only", action="store_true", help="only the per-stage costs")
    args = ap.parse_args()
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    root = Path(tempfile.mkdtemp(prefix="bench_scale_"))
    pairs_ds = write_fleet(root, clips=args.clips, frames=args.frames)
    n = args.clips * args.frames * 21
    if args.stages or args.stages_only:
        stages(pairs_ds)
    if args.stages_only:
        return
    print(f"load average before the engines: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    local_s, local = run_local(pairs_ds)
    print(f"local engine: {n} pairs in {local_s:.1f} s = {n / local_s:.1f} pairs/s", flush=True)
    start_s, ray_s, on_ray = run_ray(pairs_ds, root / "ray")
    assert on_ray.pair_id.tolist() == local.pair_id.tolist()
    for c in COLUMNS:
        diff = np.nanmax(np.abs(on_ray[c].to_numpy() - local[c].to_numpy()))
        print(f"max |ray - local| {c}: {diff:.2e}")
    print(f"ray engine:   {n} pairs in {ray_s:.1f} s = {n / ray_s:.1f} pairs/s "
          f"(+ {start_s:.1f} s to start the local Ray instance)")
    print(f"ratio ray / local: {local_s / ray_s:.2f}x (target >= 0.8x on 2 cores); "
          f"including Ray start-up: {local_s / (ray_s + start_s):.2f}x")


if __name__ == "__main__":
    main()
