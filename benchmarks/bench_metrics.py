"""Benchmark: pairs/s of every encoder-free metric on real crops of the demo clip (issue 22).

One run, one machine, side by side: the demo's synthetic clip (``nvrq.synth.generate_scene``,
seed 0, 7 offsets, ``--size`` as ``nvrq demo``'s default 960x540), its pairs
(``nvrq.pairs.make_pairs``), the crops cut once; then each metric of the registry that needs
no encoder timed on the same crops in ``--rounds`` interleaved rounds (metric A, B, ..., A, B, ...)
and the rates averaged. Full-reference metrics get the GT crop and the render crop resized to it
(as ``nvrq score``); no-reference ones the raw render crop. One thread (OpenCV too), as
``nvrq score`` runs them. Printed per metric: pairs/s over all pairs, the share of NaN values and
pairs/s over the crops where it is defined (NIQE is NaN, and fast, below 96 px); then whether
every no-reference metric reaches the target of 50 crops/s (over all pairs and where defined).

    python benchmarks/bench_metrics.py [--seconds 1] [--size 960x540] [--max-pairs 600] [--rounds 2]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

TARGET = 50.0  # crops/s per no-reference metric on 2 cores (issue 22)


def demo_crops(root: Path, *, seconds: float, size: tuple[int, int], max_pairs: int):
    """(GT crops, render crops) of the demo clip's first ``max_pairs`` pairs, cut once."""
    from data_schema.scene import load_scene
    from nvrq.pairs import make_pairs
    from nvrq.scoring.batches import iter_crop_batches
    from nvrq.synth.generate import generate_scene

    generate_scene(root, seed=0, seconds=seconds, fps=10.0, offsets=(-3, -2, -1, 0, 1, 2, 3),
                   cameras=("pinhole",), size=size, progress=False)
    pairs, _ = make_pairs(load_scene(root), progress=False)
    pairs = pairs.iloc[:max_pairs].reset_index(drop=True)
    pairs["scene_root"] = str(root)
    gts, renders = [], []
    for b in iter_crop_batches(pairs, background=False):
        gts += [b.gt_crops[i] for i in b.gt_index]
        renders += b.render_crops
    return gts, renders


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--size", default="960x540")
    ap.add_argument("--max-pairs", type=int, default=600)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args(argv)
    import cv2

    from nvrq.crops import resize_to
    from nvrq.metrics import REGISTRY, reference_columns

    cv2.setNumThreads(1)
    w, h = (int(v) for v in args.size.split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        gts, renders = demo_crops(Path(tmp) / "scene", seconds=args.seconds, size=(w, h),
                                  max_pairs=args.max_pairs)
    resized = [resize_to(r, g.shape[0], g.shape[1]) for g, r in zip(gts, renders, strict=True)]
    sides = np.array([min(r.shape[:2]) for r in renders])
    print(f"demo clip {args.size}, {args.seconds:g} s: {len(renders)} pairs; render crop shorter side "
          f"median {np.median(sides):.0f} px (min {sides.min()}, max {sides.max()})")
    metrics = [n for n, i in REGISTRY.items() if i.kind == "metric" and i.fn is not None]
    with_gt = set(reference_columns(metrics))
    n = len(renders)
    per_crop = {m: np.zeros(n) for m in metrics}  # seconds per crop, summed over rounds
    values = {}
    for _ in range(args.rounds):
        for m in metrics:
            info = REGISTRY[m]
            args_of = (lambda k: (gts[k], resized[k])) if m in with_gt else (lambda k: (renders[k],))
            v = np.empty(n)
            for k in range(n):
                t = time.perf_counter()
                v[k] = info.fn(*args_of(k))
                per_crop[m][k] += time.perf_counter() - t
            values[m] = v
    print(f"\n{'metric':10s} {'kind':5s} {'pairs/s':>9s} {'NaN':>6s} {'pairs/s where defined':>22s}")
    slow = []
    for m in metrics:
        rate = n * args.rounds / per_crop[m].sum()
        ok = ~np.isnan(values[m])
        defined = ok.sum() * args.rounds / per_crop[m][ok].sum() if ok.any() else float("nan")
        kind = "FR" if m in with_gt else "NR"
        print(f"{m:10s} {kind:5s} {rate:9.1f} {1 - ok.mean():6.1%} {defined:22.1f}")
        if kind == "NR" and min(rate, defined) < TARGET:
            slow.append(m)
    print(f"\nno-reference metrics at >= {TARGET:.0f} crops/s (one thread): "
          f"{'all' if not slow else 'NOT ' + ', '.join(slow)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
