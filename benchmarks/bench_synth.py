"""Images per second of ``nvrq synth`` (issue 3: a 10 s clip, 7 offsets, 1280x720 within a few minutes).

Usage: ``python benchmarks/bench_synth.py [--seconds 2] [--size 1280x720] [--cameras pinhole]``.
Prints the wall time, images written and images per second per camera; the full target
(10 s at 10 Hz, 7 offsets = 800 images per camera) is extrapolated from the measured rate.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from nvrq.commands.synth import parse_size
from nvrq.synth import generate_scene


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--cameras", default="pinhole")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    cams = tuple(args.cameras.split(","))
    with tempfile.TemporaryDirectory() as tmp:
        c0 = time.process_time()
        t0 = time.perf_counter()
        out = generate_scene(
            Path(tmp) / "clip",
            seed=args.seed,
            seconds=args.seconds,
            cameras=cams,
            size=parse_size(args.size),
            progress=False,
        )
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0
        n = sum(1 for _ in (out / "images").rglob("*.png"))
    per_cam = n / len(cams) / wall
    print(
        f"synth {args.seconds:g} s clip, {args.size}, cameras {args.cameras}: {n} images in {wall:.1f} s"
    )
    print(f"images per second per camera: {per_cam:.2f} (target >= 5)")
    print(
        f"CPU time {cpu:.1f} s = {1000 * cpu / n:.0f} ms per image; on 2 idle cores about "
        f"{2 * n / len(cams) / cpu:.2f} images per second per camera (wall is slower on a busy machine)"
    )
    print(f"10 s clip, 7 offsets (800 images per camera): about {800 / per_cam / 60:.1f} min")


if __name__ == "__main__":
    main()
