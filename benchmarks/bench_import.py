"""Frames per second of ``nvrq import drivestudio``, against just copying (or linking) its images.

A synthetic drivestudio layout (default 200 frames x 5 cameras, the Waymo kind, and the same in
the per-frame PandaSet kind) is written once (tests/nvrq/sources/drivestudio_layout.py); then, in
this one run and on warm files, each is timed (best of ``--rounds``):

- ``copy only``: ``shutil.copyfile`` of every GT image into a fresh folder (what ``--copy`` must do);
  the steps are interleaved round by round, so that the shared disk's slow spells hit each;
- ``import --copy``: the whole import (read and check every file, build the scene, copy the images);
- ``link only`` / ``import``: the same with symbolic links (the default);
- ``read files only``: reading every text file and image header the import reads, without
  the checks and geometry; ``read_drivestudio`` minus it is the geometry and checks.

The claim (issue 27): the import is bound by copying images, not by the geometry, i.e.
``import --copy / copy only`` is close to 1 and the geometry is a small part of the import.
Wall and CPU (user + system of this process) seconds are both printed: on a shared machine the
wall times of file operations swing with the other processes; CPU time much less.
Run: ``python benchmarks/bench_import.py [--frames 200] [--cameras 5] [--size 1920x1280]``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' layout writer

from data_schema.scene import load_scene, save_scene  # noqa: E402
from nvrq.sources.drivestudio import import_drivestudio, read_drivestudio  # noqa: E402
from nvrq.synth.generate import camera_models, scene_document  # noqa: E402
from nvrq.synth.layout import build_world  # noqa: E402
from tests.nvrq.sources.drivestudio_layout import camera_ring, write_layout  # noqa: E402


def _timed(fn) -> tuple[float, float]:
    """``(wall seconds, CPU seconds of this process, user + system)`` of one call."""
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def _source(tmp: Path, frames: int, size: tuple[int, int]):
    ts = np.round(np.arange(frames + 2) * 1e5).astype(np.int64)  # a margin for the per-frame lags
    world = build_world(np.random.default_rng([0, 1]), timestamps_us=ts)
    front = camera_models(size)["front"]
    images = pd.DataFrame({"camera": ["front"], "timestamp_us": [0], "source": ["gt"], "y_offset_m": [0.0],
                           "path": ["x.png"]})
    save_scene(scene_document(world, {"front": front}, "bench"), images, tmp / "src")
    return load_scene(tmp / "src", check_images=False), front


def _jpeg(size: tuple[int, int]) -> bytes:
    """A JPEG with photo-like detail (blurred noise), so that copying costs what real images cost."""
    W, H = size
    img = cv2.GaussianBlur(np.random.default_rng(0).integers(0, 255, (H, W, 3), dtype=np.uint8), (0, 0), 2.0)
    return cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()


def _read_files_only(root: Path) -> None:
    """Open what the import opens: every text file's text and every image's header."""
    for sub in ("intrinsics", "extrinsics", "ego_pose"):
        if (root / sub).is_dir():
            for e in os.scandir(root / sub):
                Path(e.path).read_text()
    for e in os.scandir(root / "images"):
        with Image.open(e.path) as im:
            im.size  # noqa: B018 (the header read is the point)
    for name in ("instances_info.json", "frame_instances.json"):
        (root / "instances" / name).read_text()


def bench(tmp: Path, source, variant: str, n_cams: int, frames: int, blob: bytes, rounds: int) -> None:
    scene, front = source
    T_sr, models = camera_ring(np.asarray(front["T_sensor_rig"]), front["model"], n_cams)
    lag = [c * 4_000 for c in range(n_cams)] if variant == "pandaset" else None
    layout = write_layout(tmp / variant, scene, variant, T_sensor_rig=T_sr, models=models, n_frames=frames,
                          lag_us=lag, image_bytes=blob)
    srcs = sorted((layout.root / "images").iterdir())
    out = tmp / f"{variant}_out"

    def fresh():
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir()

    def copy_only():
        fresh()
        for p in srcs:
            shutil.copyfile(p, out / p.name)

    def link_only():
        fresh()
        for p in srcs:
            os.symlink(os.path.abspath(p), out / p.name)

    steps = {"copy": copy_only, "import_copy": lambda: import_drivestudio(layout.root, out, offsets=[0.0, 1.0, 2.0],
                                                                         copy=True),
             "link": link_only, "import_link": lambda: import_drivestudio(layout.root, out, offsets=[0.0, 1.0, 2.0]),
             "read": lambda: read_drivestudio(layout.root), "files": lambda: _read_files_only(layout.root)}
    copy_only()  # warm the page cache: every timing below reads warm files
    wall, cpu = dict.fromkeys(steps, float("inf")), dict.fromkeys(steps, float("inf"))
    for _ in range(rounds):  # interleaved, so that a slow spell of the shared disk hits every step
        for name, fn in steps.items():
            if name.startswith("import"):
                shutil.rmtree(out, ignore_errors=True)
            w, c = _timed(fn)
            wall[name], cpu[name] = min(wall[name], w), min(cpu[name], c)
    n_tracks = len(load_scene(out, check_images=False).tracks)
    print(f"\n{variant}: {frames} frames x {n_cams} cameras = {len(srcs)} images of "
          f"{models[0]['resolution'][0]}x{models[0]['resolution'][1]} ({len(blob) / 1e3:.0f} kB each), "
          f"{n_tracks} tracks; best of {rounds}, wall and CPU (user + system) seconds")
    rows = [("copy only", "copy", ""), ("import --copy", "import_copy", "copy"), ("link only", "link", ""),
            ("import (links)", "import_link", "link"), ("read+check", "read", ""), ("read files only", "files", "")]
    for label, key, base in rows:
        line = f"  {label:18s} {wall[key]:7.3f} s  cpu {cpu[key]:7.3f} s"
        if key.startswith("import"):
            line += (f"   {frames / wall[key]:5.0f} frames/s   import/{base} wall {wall[key] / wall[base]:.2f}"
                     f"  cpu {cpu[key] / cpu[base]:.2f}")
        print(line)
    geo_w, geo_c = max(wall["read"] - wall["files"], 0.0), max(cpu["read"] - cpu["files"], 0.0)
    print(f"  geometry, checks   {geo_w:7.3f} s  cpu {geo_c:7.3f} s   (read+check - read files only: "
          f"{100 * geo_c / cpu['import_copy']:.0f}% of import --copy's CPU)")
    rest = max(cpu["import_copy"] - cpu["read"] - cpu["copy"], 0.0)
    print(f"  the rest           cpu {rest:7.3f} s   (scene.json, images.csv, folders: import --copy - read+check "
          "- copy only)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--cameras", type=int, default=5)
    ap.add_argument("--size", default="1920x1280", help="image size WxH (default: Waymo's front camera)")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.lower().split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        source = _source(tmp, args.frames, size)
        blob = _jpeg(size)
        for variant in ("waymo", "pandaset"):
            bench(tmp, source, variant, args.cameras, args.frames, blob, args.rounds)


if __name__ == "__main__":
    main()
