"""Benchmark: does ``nvrq score`` keep the encoder busy, and what do the runtimes buy? (issue 15)

All numbers come from one run on one machine, measured side by side (rates interleaved:
torch, runtime, torch, runtime, ... and averaged), per encoder (``dinov2-small`` with random
weights, ``efficientnet-lite0`` with its pip weights when installed, else random) and batch size:

  encoder alone, images/s, pre-made uint8 inputs: torch eager fp32 (in this process, whose
      allocator ``nvrq`` tunes, :mod:`nvrq.encoders.memory`), torch eager fp32 in a plain
      process (glibc defaults: the baseline the issue measured), and the default CPU runtime
      (``runtime='auto'``: the fastest exported runtime identical to torch fp32);
  pipeline: pairs/s of :func:`nvrq.scoring.driver.score_pairs` with the default runtime and with
      torch, and ``pipeline / encoder-alone`` = pairs/s / (images/s / encoder images per pair)
      (target >= 0.9). Each pipeline run scores whole GT frames for about
      ``--pipeline-seconds`` of encoder work (steady state, not the first batch's wait), in
      ``--rounds`` rounds interleaved with the encoder-alone rates, averaged;
  ``decode_bound``: the best ratio any schedule can reach on this machine when decoding
      takes CPU from the encoder: ``T / (T + D / threads)``, T the encoder-alone seconds for
      the run's crops and D the seconds to decode and cut them with no encoder running;
  ``default / torch`` speed ratio (targets: DINOv2-S >= 1.3, efficientnet-lite0 >= 3; shown
      against both torch baselines) and the max |dNVRQ| between the two on the scene's pairs
      (target <= 1e-5);
  int8 (OpenVINO + NNCF, calibrated on GT crops of other pairs): drift check on the scene's
      pairs (NVRQ Spearman vs torch fp32, target >= 0.999) and ``int8 / torch fp32`` speed
      (target for DINOv2-S >= 2.5);
  (c) encoder images per pair vs the naive 2; (e) speed-up over a naive per-pair loop;
  methods (``--methods M``, 0 skips): a synthetic clip rendered by M reconstruction methods
      (``nvrq synth --methods``) scored with the first encoder at once, each GT crop embedded
      once for every method (``G + M·R`` encoder images), against scoring each method's pairs
      alone (``M·(G + R)``): both counts, the wall-time speed-up (fastest of ``--rounds``
      alternating runs each) and the max |dNVRQ| (0). With 7 offsets a GT crop serves 7
      renders per method, so the encoder work drops by only ``(M·(G + R)) / (G + M·R)``
      (about 1.1 for 3 methods); the GT images are decoded once instead of M times too.

Scene: ``nvrq.synth.generate_scene`` (7 offsets, 1280x720 PNG) + ``nvrq.pairs.make_pairs``
when available, else a random scene (smooth noise images, 7 offsets, boxes valid in every
offset).

    python benchmarks/bench_score.py [--pairs 150] [--pipeline-seconds 10] [--rounds 2] [--batch-sizes 8,32]
        [--threads 2] [--encoders dinov2-small,efficientnet-lite0]
        [--int8 dinov2-small,efficientnet-lite0] [--methods 3] [--methods-seconds 1] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from nvrq.scoring.plan import ScorePlan  # light: numpy and the registries

OFFSETS = (-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0)


def random_scene(root: Path, *, frames: int, objects: int, size=(1280, 720), seed=0) -> pd.DataFrame:
    """A pairs table over random smooth images: every object valid at every offset."""
    rng = np.random.default_rng(seed)
    w, h = size
    rows = []
    for t in range(frames):
        def img():
            coarse = rng.integers(0, 256, (h // 32, w // 32, 3)).astype(np.float32)
            return cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC).clip(0, 255).astype(np.uint8)
        gt_rel = f"gt/{t}.png"
        (root / "gt").mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(root / gt_rel), img())
        sides = rng.integers(40, 300, (objects, 2))
        x0 = rng.integers(20, w - 320, objects)  # the render box moves by up to -15 + 10 px
        y0 = rng.integers(0, h - 320, objects)
        for off in OFFSETS:
            r_rel = f"render_{off:+.2f}/{t}.png"
            (root / r_rel).parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(root / r_rel), img())
            for k in range(objects):
                dx = int(off * 5)
                rows.append(dict(pair_id=f"rand:front:obj{k}:{t}:{off:+.2f}", gt_path=gt_rel, render_path=r_rel,
                                 gt_x0=x0[k], gt_y0=y0[k], gt_x1=x0[k] + sides[k, 0], gt_y1=y0[k] + sides[k, 1],
                                 r_x0=x0[k] + 10 + dx, r_y0=y0[k], r_x1=x0[k] + 10 + dx + sides[k, 0],
                                 r_y1=y0[k] + sides[k, 1]))
    pairs = pd.DataFrame(rows)
    pairs["scene_root"] = str(root)
    return pairs


def synth_scene(root: Path, *, seconds: float, seed: int = 0) -> pd.DataFrame | None:
    try:
        from data_schema.scene import load_scene
        from nvrq.pairs import make_pairs
        from nvrq.synth.generate import generate_scene
    except ImportError:
        return None
    generate_scene(root, seed=seed, seconds=seconds, fps=5.0, offsets=OFFSETS, cameras=("pinhole",),
                   size=(1280, 720), progress=False)
    pairs, _ = make_pairs(load_scene(root), progress=False)
    return pairs


def methods_numbers(root: Path, encoder, *, n_methods: int, seconds: float, rounds: int = 2,
                    size=(960, 540)) -> dict:
    """Encoder images and wall time of one pass over an ``n_methods``-method clip's pairs
    against one pass per method (see the module docstring); the two are timed in turn,
    ``rounds`` times, and the fastest of each kept (the least disturbed on a shared machine)."""
    from data_schema.methods import METHOD_COLUMN
    from data_schema.scene import load_scene
    from nvrq.pairs import make_pairs
    from nvrq.scoring.driver import score_pairs
    from nvrq.synth.generate import generate_scene

    methods = [(f"m{k}", 0.5 * (k + 1)) for k in range(n_methods)]
    generate_scene(root, seed=0, seconds=seconds, fps=5.0, offsets=OFFSETS, size=size, methods=methods,
                   progress=False)
    pairs, _ = make_pairs(load_scene(root), progress=False)
    col = [f"nvrq:{encoder.spec.name}"]
    score_pairs(pairs.iloc[:8], ScorePlan.for_columns(col, encoder=encoder),
                encoder=encoder, progress=False)  # warm-up
    t_shared, t_apart = [], []
    for _ in range(max(1, rounds)):
        t0 = time.perf_counter()
        shared = score_pairs(pairs, ScorePlan.for_columns(col, encoder=encoder),
                             encoder=encoder, progress=False)
        t_shared.append(time.perf_counter() - t0)
        t0, apart, values = time.perf_counter(), 0, pd.Series(np.nan, index=pairs.index)
        for _, sub in pairs.groupby(METHOD_COLUMN, sort=False):
            res = score_pairs(sub, ScorePlan.for_columns(col, encoder=encoder),
                              encoder=encoder, progress=False)
            apart += res.n_encoder_images
            values[sub.index] = res.table[col[0]].to_numpy()
        t_apart.append(time.perf_counter() - t0)
    n_gt = len(pairs.drop_duplicates(["gt_path", "gt_x0", "gt_y0", "gt_x1", "gt_y1"]))
    return {"methods": n_methods, "methods_pairs": len(pairs), "methods_gt_crops_G": n_gt,
            "methods_renders_R": len(pairs) // n_methods,
            "methods_encoder_images_shared": shared.n_encoder_images,
            "methods_encoder_images_apart": apart,
            "methods_seconds_shared": min(t_shared), "methods_seconds_apart": min(t_apart),
            "methods_speedup_shared": min(t_apart) / min(t_shared),
            "methods_max_dnvrq_shared": float(np.max(np.abs(
                shared.table[col[0]].to_numpy() - values.to_numpy())))}


def naive_pairs_per_s(pairs: pd.DataFrame, encoder, n: int) -> float:
    from nvrq.crops import cut_box, encoder_input, read_rgb
    from nvrq.metrics.formulas import nvrq_similarity

    sub = pairs.iloc[:n]
    size = encoder.spec.input_size
    t0 = time.perf_counter()
    for row in sub.itertuples():
        root = Path(row.scene_root)
        gt = cut_box(read_rgb(root / row.gt_path), (row.gt_x0, row.gt_y0, row.gt_x1, row.gt_y1))
        rc = cut_box(read_rgb(root / row.render_path), (row.r_x0, row.r_y0, row.r_x1, row.r_y1))
        fg = encoder.embed(encoder_input(gt, size)[None])
        fr = encoder.embed(encoder_input(rc, size)[None])
        nvrq_similarity(fg, fr)
    return len(sub) / (time.perf_counter() - t0)


def encoder_images_per_s(encoder, batch_size: int, seconds: float) -> float:
    size = encoder.spec.input_size
    x = np.random.default_rng(0).integers(0, 256, (batch_size, size, size, 3), dtype=np.uint8)
    encoder.embed(x)  # warm-up
    n, t0 = 0, time.perf_counter()
    while n == 0 or time.perf_counter() - t0 < seconds:
        encoder.embed(x)
        n += batch_size
    return n / (time.perf_counter() - t0)


_PLAIN = """
import sys, torch, cv2
sys.path.insert(0, {bench!r})
import bench_score
name, threads, bs, seconds = {name!r}, {threads}, {bs}, {seconds}
torch.set_num_threads(threads)
enc, _ = bench_score.make_encoder(name, threads)
print(bench_score.encoder_images_per_s(enc, bs, seconds))
"""


class PlainTorch:
    """torch eager fp32 of ``name`` in a fresh process with glibc's allocator defaults."""

    def __init__(self, name: str, threads: int):
        self.name, self.threads = name, threads

    def images_per_s(self, batch_size: int, seconds: float) -> float:
        code = _PLAIN.format(bench=str(Path(__file__).resolve().parent), name=self.name, threads=self.threads,
                             bs=batch_size, seconds=seconds)
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
        return float(proc.stdout.split()[-1])


def alone_rates(encoders: dict, batch_size: int, seconds: float) -> dict:
    """images/s of each encoder alone, one after the other (``seconds`` each)."""
    return {k: enc.images_per_s(batch_size, seconds) if isinstance(enc, PlainTorch)
            else encoder_images_per_s(enc, batch_size, seconds) for k, enc in encoders.items()}


def whole_frames(pairs: pd.DataFrame, n_pairs: int) -> pd.DataFrame:
    """The first GT frames of ``pairs`` (all their offsets, as in real use) holding >= ``n_pairs``."""
    keep, count = [], 0
    for g, n in pairs["gt_path"].value_counts(sort=False).reindex(pairs["gt_path"].unique()).items():
        if count >= max(1, n_pairs):
            break
        keep.append(g)
        count += int(n)
    return pairs[pairs["gt_path"].isin(keep)].reset_index(drop=True)


def decode_alone_seconds(pairs: pd.DataFrame) -> float:
    """Seconds to decode and cut every crop of ``pairs`` with nothing else running."""
    from nvrq.scoring.batches import iter_crop_batches

    t0 = time.perf_counter()
    for _ in iter_crop_batches(pairs, background=False):
        pass
    return time.perf_counter() - t0


def scene_pairs(root: Path, use_random: bool) -> tuple[pd.DataFrame, str]:
    """The pairs of the whole benchmark scene (synthetic, else random images) and its source."""
    pairs = None if use_random else synth_scene(root, seconds=2.0)
    source = "nvrq.synth.generate_scene"
    if pairs is None or len(pairs) == 0:
        pairs, source = random_scene(root, frames=8, objects=6), "random images"
    return pairs, source


def make_encoder(name: str, threads: int):
    from nvrq.encoders import build_random, load_encoder

    if name == "efficientnet-lite0":
        try:
            return load_encoder(name, runtime="torch", threads=threads), "pip weights"
        except Exception:  # the weights package is optional
            pass
    return build_random(name, runtime="torch", threads=threads), "random weights"


def bench_encoder(name: str, scene: pd.DataFrame, args, cache: str) -> dict:
    """Every number of one encoder (see the module docstring)."""
    from nvrq.encoders.drift import check_runtime, pair_inputs
    from nvrq.encoders.runtimes import wrap_runtime
    from nvrq.scoring.driver import score_pairs

    pairs = whole_frames(scene, args.pairs)
    torch_enc, weights = make_encoder(name, args.threads)
    default = wrap_runtime(torch_enc, runtime="auto", threads=args.threads, cache_dir=cache)
    out = {"encoder": name, "weights": weights, "default_runtime": default.runtime}
    col = [f"nvrq:{name}"]
    s = {}
    for enc_name, enc in (("torch", torch_enc), ("default", default)):
        res = score_pairs(pairs, ScorePlan.for_columns(col, encoder=enc, batch_size=32), encoder=enc, progress=False)
        s[enc_name] = res.table[col[0]].to_numpy()
    out["max_dnvrq_default_vs_torch"] = float(np.max(np.abs(s["torch"] - s["default"])))
    encoders = {"torch": torch_enc, "default": default}
    if name in args.int8:
        gt, render = pair_inputs(pairs, torch_enc.spec.input_size, n=args.int8_pairs + 150, seed=0)
        rec = check_runtime(torch_enc, gt[:args.int8_pairs], render[:args.int8_pairs], runtime="openvino",
                            precision="int8", calib=gt[args.int8_pairs:], cache_dir=cache)
        out.update({f"int8_{k}": rec[k] for k in ("nvrq_spearman", "mean_cosine", "min_cosine", "max_dnvrq",
                                                   "n_pairs")})
        out["int8_check_passes"] = rec["nvrq_spearman"] >= 0.999
        encoders["int8"] = wrap_runtime(torch_enc, runtime="openvino", precision="int8", threads=args.threads,
                                        cache_dir=cache, model_file=Path(rec["model_file"]))
    # last in each round: the subprocess gives the runtimes' spinning thread pools time to sleep
    encoders["plain_torch"] = PlainTorch(name, args.threads)
    per_pair = 1 + scene["gt_path"].nunique() / len(scene)  # about; measured below per run
    for bs in args.batch_sizes:
        # rounds of (every encoder alone, then each pipeline), averaged: the machine drifts
        alone, piped, runs = {k: [] for k in encoders}, {"torch": [], "default": []}, {}
        for _ in range(args.rounds):
            for k, v in alone_rates(encoders, bs, args.seconds / args.rounds).items():
                alone[k].append(v)
            for rt in piped:
                # whole frames worth about --pipeline-seconds of encoder work at the alone rate
                runs.setdefault(rt, whole_frames(scene, int(args.pipeline_seconds * alone[rt][0] / per_pair)))
                res = score_pairs(runs[rt], ScorePlan.for_columns(col, encoder=encoders[rt], batch_size=bs), encoder=encoders[rt], progress=False)
                piped[rt].append(res)
        rates = {k: float(np.mean(v)) for k, v in alone.items()}
        for rt, results in piped.items():
            n_pairs, n_images = results[0].n_pairs, results[0].n_encoder_images
            ipp = n_images / n_pairs
            pps = n_pairs / float(np.mean([r.timing.attrs["wall_seconds"] for r in results]))
            t_alone = n_images / rates[rt]
            decode = decode_alone_seconds(runs[rt])
            out.update({f"b{bs}_{rt}_pipeline_pairs": n_pairs, f"b{bs}_{rt}_pipeline_pairs_per_s": pps,
                        f"b{bs}_{rt}_pipeline_over_encoder_alone": pps / (rates[rt] / ipp),
                        f"b{bs}_{rt}_decode_bound": t_alone / (t_alone + decode / args.threads)})
            if rt == "default":
                out[f"b{bs}_encoder_images_per_pair"] = ipp
                out[f"b{bs}_decode_seconds_per_pair"] = decode / n_pairs
        out.update({f"b{bs}_torch_images_per_s": rates["torch"],
                    f"b{bs}_plain_torch_images_per_s": rates["plain_torch"],
                    f"b{bs}_default_images_per_s": rates["default"],
                    f"b{bs}_default_over_torch": rates["default"] / rates["torch"],
                    f"b{bs}_default_over_plain_torch": rates["default"] / rates["plain_torch"]})
        if "int8" in rates:
            out[f"b{bs}_int8_images_per_s"] = rates["int8"]
            out[f"b{bs}_int8_over_torch_fp32"] = rates["int8"] / rates["torch"]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=150,
                    help="pairs (whole GT frames) of the identity and int8 checks (default 150)")
    ap.add_argument("--pipeline-seconds", type=float, default=10.0,
                    help="encoder work per pipeline run, in seconds at the alone rate (default 10)")
    ap.add_argument("--naive-pairs", type=int, default=20, help="pairs timed in the naive loop (default 20)")
    ap.add_argument("--batch-sizes", default="8,32", help="encoder batch sizes (default 8,32)")
    ap.add_argument("--threads", type=int, default=2, help="encoder threads (default 2)")
    ap.add_argument("--seconds", type=float, default=8.0, help="seconds per encoder-alone rate (default 8)")
    ap.add_argument("--rounds", type=int, default=2,
                    help="interleaved rounds of encoder-alone and pipeline runs, averaged (default 2)")
    ap.add_argument("--encoders", default="dinov2-small,efficientnet-lite0")
    ap.add_argument("--int8", default="dinov2-small,efficientnet-lite0", help="encoders given an int8 check")
    ap.add_argument("--int8-pairs", type=int, default=100, help="pairs in the int8 drift check (default 100)")
    ap.add_argument("--random-scene", action="store_true", help="skip the synthetic renderer")
    ap.add_argument("--methods", type=int, default=3,
                    help="reconstruction methods of the shared-GT clip (default 3; 0 skips it)")
    ap.add_argument("--methods-seconds", type=float, default=1.0,
                    help="length of that clip in seconds (default 1)")
    ap.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)
    from nvrq.encoders.memory import tune_allocator

    tune_allocator()  # as the nvrq commands do (the plain-torch subprocess keeps glibc's defaults)
    args.batch_sizes = [int(b) for b in args.batch_sizes.split(",")]
    args.int8 = [e for e in args.int8.split(",") if e]

    import torch

    torch.set_num_threads(args.threads)
    cv2.setNumThreads(1)  # as `nvrq score` does
    with tempfile.TemporaryDirectory() as tmp:
        pairs, source = scene_pairs(Path(tmp) / "scene", args.random_scene)
        out = {"scene": source, "scene_pairs": len(pairs), "threads": args.threads, "cpus": os.cpu_count(),
               "load_average_at_start": os.getloadavg()[0], "encoders": []}
        for name in args.encoders.split(","):
            out["encoders"].append(bench_encoder(name, pairs, args, str(Path(tmp) / "cache")))
        first, _ = make_encoder(args.encoders.split(",")[0], args.threads)
        from nvrq.scoring.driver import score_pairs

        some = whole_frames(pairs, args.pairs)
        res = score_pairs(some, ScorePlan.for_columns([f"nvrq:{first.spec.name}"], encoder=first),
                          encoder=first, progress=False)
        out["c_encoder_images_vs_naive"] = res.n_encoder_images / res.n_pairs / 2
        out["e_speedup_over_naive"] = (res.n_pairs / res.timing.attrs["wall_seconds"]) / \
            naive_pairs_per_s(some, first, args.naive_pairs)
        if args.methods > 0:
            out.update(methods_numbers(Path(tmp) / "methods", first, n_methods=args.methods,
                                       seconds=args.methods_seconds, rounds=args.rounds))
        out["load_average_at_end"] = os.getloadavg()[0]
    report(out)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))
    return 0


def report(out: dict) -> None:
    for k, v in out.items():
        if k != "encoders":
            print(f"{k:36s} {v:.3f}" if isinstance(v, float) else f"{k:36s} {v}")
    if "methods" in out:
        g, m, r = out["methods_gt_crops_G"], out["methods"], out["methods_renders_R"]
        print(f"--- {m} methods: encoder images {out['methods_encoder_images_shared']} shared "
              f"(G + M·R = {g} + {m}·{r} = {g + m * r}) vs {out['methods_encoder_images_apart']} per method "
              f"(M·(G + R) = {m * (g + r)}); speed-up {out['methods_speedup_shared']:.2f}x")
    for e in out["encoders"]:
        print(f"--- {e['encoder']} ({e['weights']})")
        for k, v in e.items():
            print(f"{k:36s} {v:.4g}" if isinstance(v, float) else f"{k:36s} {v}")
        checks = {f"pipeline/encoder-alone >= 0.9 ({rt})": all(
            v >= 0.9 for k, v in e.items() if k.endswith(f"{rt}_pipeline_over_encoder_alone"))
            for rt in ("default", "torch")}
        checks["max |dNVRQ| <= 1e-5"] = e["max_dnvrq_default_vs_torch"] <= 1e-5
        need = {"dinov2-small": 1.3, "efficientnet-lite0": 3.0}.get(e["encoder"])
        if need:
            for base in ("torch", "plain_torch"):
                checks[f"default/{base} >= {need}"] = all(v >= need for k, v in e.items()
                                                         if k.endswith(f"_default_over_{base}"))
        if e["encoder"] == "dinov2-small" and "int8_check_passes" in e:
            checks["int8/torch >= 2.5 with check passing"] = e["int8_check_passes"] and all(
                v >= 2.5 for k, v in e.items() if k.endswith("int8_over_torch_fp32"))
        print("targets: " + ", ".join(f"{k}: {'met' if ok else 'MISSED'}" for k, ok in checks.items()))


if __name__ == "__main__":
    sys.exit(main())
