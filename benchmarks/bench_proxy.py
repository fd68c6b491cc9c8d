"""Benchmark: the ImageNet proxy's classifier (efficientnet-lite0 + its head) on each runtime.

Side by side in one run (interleaved rounds: torch, openvino, onnxruntime, torch, ... averaged):
crops/s of ``ImageClassifier.probabilities`` on pre-made uint8 crops (224 x 224), the speed
ratio of each exported runtime to torch eager fp32, and the max |d imagenet_drop| against torch
over consecutive crop pairs (Eq. 9; target <= 1e-5, the runtimes' identity tolerance). Random
weights when the pip weights are not installed.

    python benchmarks/bench_proxy.py [--crops 64] [--batch-size 32] [--rounds 3] [--threads 2]
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np


def _classifiers(cache: str, threads: int) -> dict:
    from nvrq.encoders.efficientnet import default_weights_path
    from nvrq.proxies.classifier_drop import ImageClassifier, load_classifier

    if default_weights_path() is not None:
        return {rt: load_classifier(runtime=rt, threads=threads, cache_dir=cache)
                for rt in ("torch", "openvino", "onnxruntime")}
    from nvrq.encoders import build_random

    enc = build_random("efficientnet-lite0", runtime="torch")
    base = ImageClassifier("efficientnet-lite0-random", enc.model, 224, enc.spec.mean, enc.spec.std)
    return {rt: ImageClassifier(**{k: getattr(base, k) for k in ("name", "model", "input_size", "mean", "std")})
            .on_runtime(rt, threads=threads, cache_dir=cache) for rt in ("torch", "openvino", "onnxruntime")}


def _rate(clf, crops: np.ndarray, batch: int) -> tuple[float, np.ndarray]:
    t = time.perf_counter()
    p = np.concatenate([clf.probabilities(crops[i:i + batch]) for i in range(0, len(crops), batch)])
    return len(crops) / (time.perf_counter() - t), p


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--crops", type=int, default=64)
    ap.add_argument("--batch-size", type=int, default=32)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    import torch

    from nvrq.encoders.runtimes import identity_images
    from nvrq.proxies.classifier_drop import top_class_drop

    torch.set_num_threads(args.threads)
    crops = identity_images(224, n=2 * (args.crops // 2))
    with tempfile.TemporaryDirectory() as cache:
        clfs = _classifiers(cache, args.threads)
        rates = {rt: [] for rt in clfs}
        probs = {}
        for rt, clf in clfs.items():  # warm-up (and the reference outputs)
            probs[rt] = _rate(clf, crops, args.batch_size)[1]
        for _ in range(args.rounds):
            for rt, clf in clfs.items():
                rates[rt].append(_rate(clf, crops, args.batch_size)[0])
    ref = top_class_drop(probs["torch"][0::2], probs["torch"][1::2])
    print(f"imagenet proxy, {len(crops)} crops, batch {args.batch_size}, {args.threads} threads, "
          f"{args.rounds} interleaved rounds")
    base = float(np.mean(rates["torch"]))
    for rt, r in rates.items():
        d = np.max(np.abs(top_class_drop(probs[rt][0::2], probs[rt][1::2]) - ref))
        print(f"  {rt:12s} {np.mean(r):8.1f} crops/s  ratio vs torch {np.mean(r) / base:5.2f}x  "
              f"max |d imagenet_drop| {d:.2g}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
