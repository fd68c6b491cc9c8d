"""Pairs per second: the Python API (``nvrq.Evaluator``) against ``nvrq score`` on the same pairs.

One synthetic clip (``nvrq.synth.generate_scene``), its pairs (``make_pairs``), one encoder
loaded once and shared, so start-up (imports, model load, runtime export) is outside both
timings. Measured in this one run, interleaved over ``--rounds``:

- ``nvrq score``: :func:`nvrq.scoring.driver.score_pairs`, the command's driver (it reads and decodes
  the images, cuts the crops, scores them);
- API, crops: the same GT frames' crops handed to :meth:`nvrq.Evaluator.score_crops` in chunks
  of whole GT frames (as ``score_pairs`` batches them), the frames decoded in the timed loop
  too, so both do the same work;
- API, frames: :meth:`nvrq.Evaluator.update_frame` per (GT image, render image), frames
  decoded in the loop, as an evaluation loop calls it (the Evaluator scores every
  ``update_pairs`` pairs at once).

The ratio API / ``nvrq score`` is the API's own overhead (target >= 0.95). The numbers are
checked equal before timing.

Then one pair per call, as a training loop scoring a sample now and then calls it: the function
``nvrq.score_crops`` (after its first call, which loads the encoder into the API's cache,
:func:`nvrq.api.clear_encoder_cache`) against ``Evaluator.score_crops`` with its encoder
loaded, interleaved over ``--calls`` calls, medians side by side (target: the function at most
1.5x the Evaluator; before the cache every call reloaded the encoder, 710 ms against 66 ms).

Run: ``python benchmarks/bench_api.py [--seconds 2 --size 640x360]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

import nvrq
from data_schema.scene import load_scene
from data_schema.tables import GT_BOX_COLUMNS, RENDER_BOX_COLUMNS
from nvrq.crops import cut_box, read_rgb
from nvrq.encoders.memory import tune_allocator
from nvrq.pairs import make_pairs
from nvrq.scoring.batches import gt_groups, pack_groups
from nvrq.scoring.driver import score_pairs
from nvrq.scoring.plan import ScorePlan
from nvrq.synth.generate import generate_scene

METRICS = ["psnr", "ssim", "nvrq", "nvrq_ca"]


def api_crops(ev: nvrq.Evaluator, pairs: pd.DataFrame, root: Path, max_pairs: int) -> pd.DataFrame:
    """Every pair through ``ev.score_crops``, whole GT frames per call (up to ``max_pairs``)."""
    out = []
    gb, rb = pairs[list(GT_BOX_COLUMNS)].to_numpy(), pairs[list(RENDER_BOX_COLUMNS)].to_numpy()
    for rows in pack_groups(gt_groups(pairs["gt_path"].to_numpy()), max_pairs):
        images, shared, gts, renders = {}, {}, [], []
        for i in rows:
            g = pairs.gt_path.iat[i]
            img = images.get(g)
            if img is None:
                img = images[g] = read_rgb(root / g)
            gts.append(shared.setdefault((g, *gb[i]), cut_box(img, gb[i])))
            r = pairs.render_path.iat[i]
            rimg = images.get(r)
            if rimg is None:
                rimg = images[r] = read_rgb(root / r)
            renders.append(cut_box(rimg, rb[i]))
        out.append(ev.score_crops(gts, renders).set_index(pd.Index(rows)))
    return pd.concat(out).sort_index()


def api_frames(ev: nvrq.Evaluator, pairs: pd.DataFrame, root: Path) -> pd.DataFrame:
    """Every pair through ``ev.update_frame``, one call per (GT image, render image); the
    Evaluator scores them in batches of ``update_pairs`` pairs."""
    ev.reset()
    gt_cache = {}
    for (g, r), rows in pairs.groupby(["gt_path", "render_path"], sort=False):
        gt = gt_cache.get(g)
        if gt is None:
            gt_cache.clear()
            gt = gt_cache[g] = read_rgb(root / g)
        ev.update_frame(gt, read_rgb(root / r), rows[list(GT_BOX_COLUMNS)].to_numpy(),
                        rows[list(RENDER_BOX_COLUMNS)].to_numpy(), labels={"row": rows.index.to_numpy()})
    return ev.pairs.set_index("row").sort_index()


def one_pair_calls(ev: nvrq.Evaluator, gt, render, *, encoder: str, runtime: str, calls: int) -> dict:
    """Seconds of one-pair calls: the function ``nvrq.score_crops`` (its first call, then
    ``calls`` more) and ``ev.score_crops`` interleaved with them; the results checked equal."""
    metrics = list(ev.columns)
    nvrq.clear_encoder_cache()
    first, got = timed(lambda: nvrq.score_crops([gt], [render], metrics=metrics, encoder=encoder,
                                                runtime=runtime))
    want = ev.score_crops([gt], [render])
    assert np.allclose(got.to_numpy(), want.to_numpy(), rtol=0, atol=1e-6, equal_nan=True)
    fn, cls = [], []
    for _ in range(calls):
        fn.append(timed(lambda: nvrq.score_crops([gt], [render], metrics=metrics, encoder=encoder,
                                                 runtime=runtime))[0])
        cls.append(timed(lambda: ev.score_crops([gt], [render]))[0])
    return {"first": first, "function": fn, "Evaluator": cls}


def timed(fn):
    t0 = time.perf_counter()
    res = fn()
    return time.perf_counter() - t0, res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="clip length (default 2)")
    ap.add_argument("--size", default="640x360", help="image size WxH (default 640x360)")
    ap.add_argument("--encoder", default="efficientnet-lite0")
    ap.add_argument("--runtime", default="auto", help="encoder runtime (default auto, as nvrq score)")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds (default 3)")
    ap.add_argument("--calls", type=int, default=30, help="interleaved one-pair calls (default 30)")
    args = ap.parse_args(argv)
    tune_allocator()  # as the nvrq commands do
    w, h = (int(v) for v in args.size.split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        root = generate_scene(Path(tmp) / "scene", seed=0, seconds=args.seconds, fps=5.0,
                              offsets=(-2, -1, 0, 1, 2), size=(w, h), progress=False)
        pairs, _ = make_pairs(load_scene(root), progress=False)
        ev = nvrq.Evaluator(metrics=METRICS, encoder=args.encoder, runtime=args.runtime)
        enc, tau = ev.encoder, ev.tau

        def cli():
            return score_pairs(pairs, ScorePlan.for_columns(ev.columns, encoder=enc, tau=tau),
                               encoder=enc, progress=False).table

        ref = cli()
        for name, got in (("crops", api_crops(ev, pairs, root, 256)), ("frames", api_frames(ev, pairs, root))):
            diff = np.nanmax(np.abs(got[ev.columns].to_numpy() - ref[ev.columns].to_numpy())[np.isfinite(ref[ev.columns].to_numpy())])
            assert diff < 1e-6, (name, diff)
        secs = {"nvrq score": [], "API crops": [], "API frames": []}
        for _ in range(args.rounds):
            secs["nvrq score"].append(timed(cli)[0])
            secs["API crops"].append(timed(lambda: api_crops(ev, pairs, root, 256))[0])
            secs["API frames"].append(timed(lambda: api_frames(ev, pairs, root))[0])
        p0 = pairs.iloc[0]
        one = one_pair_calls(ev, cut_box(read_rgb(root / p0.gt_path), p0[list(GT_BOX_COLUMNS)].to_numpy()),
                             cut_box(read_rgb(root / p0.render_path), p0[list(RENDER_BOX_COLUMNS)].to_numpy()),
                             encoder=args.encoder, runtime=args.runtime, calls=args.calls)
    n = len(pairs)
    print(f"{n} pairs, {pairs.gt_path.nunique()} GT frames, {args.size}, encoder {args.encoder} "
          f"({enc.runtime}, {enc.threads} threads), metrics {', '.join(ev.columns)}; {args.rounds} rounds")
    base = n / np.mean(secs["nvrq score"])
    for k, v in secs.items():
        rate = n / np.mean(v)
        print(f"  {k:11s}: {rate:7.1f} pairs/s (rounds: {', '.join(f'{n / s:.1f}' for s in v)}); "
              f"{rate / base:.2f}x nvrq score")
    fn_ms, ev_ms = 1000 * np.median(one["function"]), 1000 * np.median(one["Evaluator"])
    print(f"one pair per call, median of {args.calls} interleaved calls: nvrq.score_crops {fn_ms:.1f} ms "
          f"(first call, loading the encoder: {1000 * one['first']:.0f} ms), Evaluator.score_crops "
          f"{ev_ms:.1f} ms; function / Evaluator = {fn_ms / ev_ms:.2f}x (target <= 1.5x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
