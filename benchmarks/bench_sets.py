"""``nvrq score-sets`` speed: the set scoring alone (before) against the set scoring with the crop
embeddings ``nvrq score`` already made (after: ``nvrq score --save-crop-features`` then
``score-sets --crop-features``, as the methods demo runs them), side by side in one run, with the
same encoder loaded once.

Before: :func:`nvrq.sets.score_sets` makes the pairs and embeds every distinct whole frame and
object crop (one pass in path order, each file decoded once). After: it takes the demo's pairs
table (``--pairs``, made by ``nvrq pairs`` with the same rules) and the object crops' embeddings
from the file ``nvrq score`` wrote while scoring those pairs (``--crop-features``: it embeds them
anyway, for NVRQ), so only the whole frames go through the encoder; the features and KID are
checked equal. ``nvrq pairs`` and ``nvrq score`` are not timed: the demo runs them before
score-sets either way. Then KID alone, as it was (every subset
computing its kernels from the features) against :func:`nvrq.sets.kid`, on sets of ``--kid-n``
features per side (the size of an object set of the default demo, 960x540 for 6 s).

Data: ``nvrq synth`` of the methods demo (``nvrq demo OUT --methods sharp:0.5,blurry:1.5``
renders the clip once per method and once as ``perfect:0``); ``--seconds 1 --size 480x270`` by
default, the default demo with ``--seconds 6 --size 960x540``, or ``--scene DIR`` (a scene of it
made before). Run: ``python benchmarks/bench_sets.py``.
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

import nvrq.sets as sets
from data_schema.scene import load_scene
from data_schema.tables import TableKind, read_table
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


def _timed(fn):
    c0, w0 = _cpu(), time.perf_counter()
    out = fn()
    return out, time.perf_counter() - w0, _cpu() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", default="1")
    ap.add_argument("--size", default="480x270")
    ap.add_argument("--offsets", default="-3,-2,-1,0,1,2,3")
    ap.add_argument("--methods", default="sharp:0.5,blurry:1.5,perfect:0", help="as the demo's synth")
    ap.add_argument("--scene", default=None, help="a synth scene made before (else one is made)")
    ap.add_argument("--kid-n", type=int, default=400, help="features per side of the KID-alone sets")
    ap.add_argument("--kid-sets", type=int, default=4, help="KID-alone sets")
    args = ap.parse_args()

    enc = sets._loaded(None)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.scene) if args.scene else Path(tmp) / "scene"
        if not args.scene:
            assert nvrq(["synth", str(root), "--seconds", args.seconds, "--size", args.size, "--offsets",
                         args.offsets, "--methods", args.methods, "--quiet"]) == 0
        pairs, crops = Path(tmp) / "pairs.csv", Path(tmp) / "crops.npz"
        assert nvrq(["pairs", str(root), "--out", str(pairs), "--quiet"]) == 0  # the demo's steps 2, 3
        assert nvrq(["score", str(pairs), "--out", str(Path(tmp) / "m.csv"), "--metrics", "nvrq",
                     "--save-crop-features", str(crops), "--quiet"]) == 0
        scene = load_scene(root)
        opts = sets.SetOptions()
        sets.embed([np.zeros((64, 64, 3), np.uint8)] * 2, encoder=enc)  # warm-up: not timed
        (before, groups, f_b, name), w_b, c_b = _timed(lambda: sets.score_sets(scene, opts, encoder=enc))
        (after, _, f_a, _), w_a, c_a = _timed(lambda: sets.score_sets(
            scene, opts, encoder=enc, known=sets.crop_features(crops, enc),
            pairs=read_table(pairs, kind=TableKind.PAIRS)))
    col = f"kid:{name}"
    same = np.allclose(f_b, f_a, rtol=1e-6, atol=1e-6) and np.allclose(
        before[col].to_numpy(float), after[col].to_numpy(float), rtol=1e-9, atol=1e-12, equal_nan=True)
    whole = groups["box"].isna()
    clip = f"scene {args.scene}" if args.scene else f"{args.seconds} s, {args.size}, offsets {args.offsets}, " \
        f"methods {args.methods}"
    print(f"score-sets on the methods demo's clip ({clip}): "
          f"{len(after)} sets, {groups['path'].nunique()} images, "
          f"{(groups['path'] + groups['box'].astype(str))[~whole].nunique()} distinct crops, "
          f"{len(groups)} set rows; features and KID equal before/after: {same}")
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
