"""``nvrq score-sets`` speed: the set scoring as it was (before) against :func:`nvrq.sets.score_sets`
(after), on the methods demo's data, side by side in one run, with the same encoder loaded once.

Before: the distinct images embedded mode by mode in order of first appearance (a render is
decoded again for every mode and whenever another file came between two of its crops), and KID
as 100 subsets, each computing its three (m, m) kernels from the features. After: one pass in
path order (each file decoded once), and KID from the kernels computed once: a set whose subset
is the whole of both sides (every set of a scene below 1000 images per side) has one value.

Data: ``nvrq synth`` of the methods demo (``nvrq demo OUT --methods sharp:0.5,blurry:1.5
--seconds 1 --size 480x270`` renders the same clip). Then KID alone on sets of ``--kid-n``
features per side (the size of an object set of the default demo, 960x540 for 6 s).
Run: ``python benchmarks/bench_sets.py``.
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

import nvrq.sets as sets
from data_schema.scene import load_scene
from nvrq.cli import main as nvrq


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def kid_before(render, gt, *, subsets=sets.KID_SUBSETS, subset_size=sets.KID_SUBSET_SIZE, seed=sets.KID_SEED):
    """KID as it was: every subset computes its kernels from the features."""
    r, g = np.asarray(render, np.float64), np.asarray(gt, np.float64)
    m = min(int(subset_size), len(r), len(g))
    rng = np.random.RandomState(seed)
    gamma = 1.0 / r.shape[1]
    vals = np.empty(int(subsets))
    for k in range(int(subsets)):
        x = r[rng.choice(len(r), m, replace=False)]
        y = g[rng.choice(len(g), m, replace=False)]
        kxx = (x @ x.T * gamma + 1.0) ** 3
        kyy = (y @ y.T * gamma + 1.0) ** 3
        kxy = (x @ y.T * gamma + 1.0) ** 3
        vals[k] = ((kxx.sum() - np.trace(kxx)) + (kyy.sum() - np.trace(kyy))) / (m * (m - 1)) \
            - 2.0 * kxy.sum() / (m * m)
    return {"kid": float(vals.mean()), "kid_std": float(vals.std()), "kid_subset_size": m}


def score_sets_before(scene, options, *, encoder, batch_size=32):
    """The set scoring as it was: mode by mode, in order of first appearance, KID per subset."""
    groups = sets.set_groups(scene, options)
    keys = groups["path"].astype(str) + "|" + groups["box"].map(lambda b: "" if b is None else str(b))
    codes = pd.factorize(keys)[0]
    first = np.flatnonzero(~pd.Series(codes).duplicated().to_numpy())
    whole = groups["box"].isna().to_numpy()[first]
    uniq = None
    reader = sets._Reader(scene.root)
    for mode, sel in (("stretch", np.flatnonzero(whole)), ("pad", np.flatnonzero(~whole))):
        for b0 in range(0, len(sel), batch_size):
            chunk = sel[b0:b0 + batch_size]
            ims = [reader(groups["path"].iat[first[k]], groups["box"].iat[first[k]]) for k in chunk]
            f = sets.embed(ims, encoder=encoder, batch_size=batch_size, square=mode)
            uniq = np.empty((len(first), f.shape[1])) if uniq is None else uniq
            uniq[chunk] = f
    features = uniq[codes]
    fast = sets.kid
    sets.kid = kid_before
    try:
        return sets.set_table(groups, features, options, encoder=encoder.spec.name), reader
    finally:
        sets.kid = fast


def _timed(fn):
    c0, w0 = _cpu(), time.perf_counter()
    out = fn()
    return out, time.perf_counter() - w0, _cpu() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", default="1")
    ap.add_argument("--size", default="480x270")
    ap.add_argument("--offsets", default="-3,-2,-1,0,1,2,3")
    ap.add_argument("--methods", default="sharp:0.5,blurry:1.5")
    ap.add_argument("--kid-n", type=int, default=400, help="features per side of the KID-alone sets")
    ap.add_argument("--kid-sets", type=int, default=4, help="KID-alone sets")
    args = ap.parse_args()

    enc = sets._loaded(None)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "scene"
        assert nvrq(["synth", str(root), "--seconds", args.seconds, "--size", args.size, "--offsets",
                     args.offsets, "--methods", args.methods, "--quiet"]) == 0
        scene = load_scene(root)
        opts = sets.SetOptions()
        sets.embed([np.zeros((64, 64, 3), np.uint8)] * 2, encoder=enc)  # warm-up: not timed
        (before, _), w_b, c_b = _timed(lambda: score_sets_before(scene, opts, encoder=enc))
        (after, groups, _, name), w_a, c_a = _timed(lambda: sets.score_sets(scene, opts, encoder=enc))
    col = f"kid:{name}"
    same = np.allclose(before[col].to_numpy(float), after[col].to_numpy(float), rtol=1e-9, atol=1e-12,
                       equal_nan=True)
    print(f"score-sets on the methods demo's clip ({args.seconds} s, {args.size}, offsets {args.offsets}, "
          f"methods {args.methods}): {len(after)} sets, {groups['path'].nunique()} images, "
          f"{len(groups)} set rows; KID equal before/after: {same}")
    print(f"{'':24s}{'before':>12s}{'after':>12s}{'ratio':>10s}")
    print(f"{'wall s':24s}{w_b:12.2f}{w_a:12.2f}{w_b / w_a:10.2f}")
    print(f"{'CPU s':24s}{c_b:12.2f}{c_a:12.2f}{c_b / c_a:10.2f}")

    rng = np.random.default_rng(0)
    feats = [(rng.normal(size=(args.kid_n, 1280)), rng.normal(0.1, 1, size=(args.kid_n, 1280)))
             for _ in range(args.kid_sets)]
    kb, w_kb, c_kb = _timed(lambda: [kid_before(r, g) for r, g in feats])
    ka, w_ka, c_ka = _timed(lambda: [sets.kid(r, g) for r, g in feats])
    same = all(abs(a["kid"] - b["kid"]) <= 1e-9 * abs(b["kid"]) + 1e-12 for a, b in zip(ka, kb, strict=True))
    print(f"KID alone: {args.kid_sets} sets of {args.kid_n} x 1280 features per side, 100 subsets; "
          f"equal: {same}")
    print(f"{'KID wall s':24s}{w_kb:12.2f}{w_ka:12.2f}{w_kb / w_ka:10.2f}")
    print(f"{'KID CPU s':24s}{c_kb:12.2f}{c_ka:12.2f}{c_kb / c_ka:10.2f}")
    print("speed-up (before / after) per row above")


if __name__ == "__main__":
    main()
