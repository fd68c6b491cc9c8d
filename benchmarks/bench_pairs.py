"""Box pairs per second: the vectorised ``make_pairs`` against a per-box ``cv2.projectPoints`` loop.

Scene: >= 200 tracks x 300 frames x 7 render offsets, one ``opencv_pinhole`` camera, the rig
driving straight at 10 m/s and the objects spread along the road. Both methods are timed in
this one run; the loop is timed on a random subset of candidate boxes (it is linear in
their number) and reported per box. Run: ``python benchmarks/bench_pairs.py``.
"""

from __future__ import annotations

import argparse
import time

import cv2
import numpy as np
import pandas as pd

from data_schema.scene import CameraCalib, Scene, Track
from nvrq.geometry.boxes import box_corners, box_sides, pixel_box
from nvrq.geometry.poses import invert_rigid, offset_T_sensor_rig, pose7_to_matrix
from nvrq.pairs import make_pairs, track_boxes_at

MODEL = {"type": "opencv_pinhole", "resolution": [1920, 1080], "focal_length": [1000.0, 1000.0],
         "principal_point": [960.0, 540.0], "radial_coeffs": [-0.05, 0.01, 0, 0, 0, 0],
         "tangential_coeffs": [0.0, 0.0], "thin_prism_coeffs": [0, 0, 0, 0]}
T_SENSOR_RIG = np.array([[0, 0, 1, 1.5], [-1, 0, 0, 0], [0, -1, 0, 1.5], [0, 0, 0, 1.0]])


def build_scene(n_tracks: int, n_frames: int, offsets: list[float], seed: int = 0) -> Scene:
    rng = np.random.default_rng(seed)
    ts = np.arange(n_frames, dtype=np.int64) * 100_000
    T_rig_world = np.broadcast_to(np.eye(4), (n_frames, 4, 4)).copy()
    T_rig_world[:, 0, 3] = ts / 1e6 * 10.0
    tracks = []
    for k in range(n_tracks):
        x0 = rng.uniform(5, 10.0 * n_frames / 10 + 60)
        y = rng.choice([-7.0, -3.5, 3.5, 7.0]) + rng.normal(0, 0.3)
        v = rng.choice([0.0, 8.0, -8.0])
        poses = np.zeros((n_frames, 7))
        poses[:, 0] = x0 + v * ts / 1e6
        poses[:, 1] = y
        poses[:, 2] = 0.8
        poses[:, 6] = 1.0
        tracks.append(Track(f"t{k}", "automobile", np.array([4.5, 1.9, 1.6]), ts, poses))
    rows = [("front", int(t), "gt", 0.0, f"gt/{t}.png") for t in ts]
    rows += [("front", int(t), "render", float(o), f"r/{o:+.0f}/{t}.png") for t in ts for o in offsets]
    images = pd.DataFrame(rows, columns=["camera", "timestamp_us", "source", "y_offset_m", "path"])
    return Scene(root=pd.io.common.Path("."), clip_id="bench", attributes={}, rig_timestamps_us=ts,
                 T_rig_world=T_rig_world, cameras={"front": CameraCalib("front", T_SENSOR_RIG, MODEL)},
                 tracks=tracks, images=images)


def loop_pairs(scene: Scene, cand: list[tuple[int, int, float]], offsets_all: np.ndarray) -> int:
    """The per-box baseline: for each candidate, both views through ``cv2.projectPoints``."""
    cam = scene.cameras["front"]
    m = cam.model
    K = np.array([[m["focal_length"][0], 0, m["principal_point"][0]], [0, m["focal_length"][1], m["principal_point"][1]],
                  [0, 0, 1]])
    k = m["radial_coeffs"]
    p = m["tangential_coeffs"]
    s = m["thin_prism_coeffs"]
    dist = np.array([k[0], k[1], p[0], p[1], k[2], k[3], k[4], k[5], *s])
    W, H = m["resolution"]
    kept = 0
    for frame, track, off in cand:
        tr = scene.tracks[track]
        T_box = pose7_to_matrix(tr.poses[frame])
        corners = box_corners(T_box, tr.dims_lwh)
        ok = True
        for o in (0.0, off):
            T_ws = invert_rigid(scene.T_rig_world[frame] @ offset_T_sensor_rig(cam.T_sensor_rig, np.array([o]))[0])
            pc = corners @ T_ws[:3, :3].T + T_ws[:3, 3]
            if (pc[:, 2] <= 0).any():
                ok = False
                break
            rvec, _ = cv2.Rodrigues(T_ws[:3, :3])
            uv, _ = cv2.projectPoints(corners.reshape(-1, 1, 3), rvec, T_ws[:3, 3], K, dist)
            uv = uv.reshape(-1, 2)
            if not np.isfinite(uv).all() or (uv < 0).any() or (uv[:, 0] > W - 1).any() or (uv[:, 1] > H - 1).any():
                ok = False
                break
            w, h = box_sides(pixel_box(uv))
            if min(w, h) < 30:
                ok = False
                break
        kept += ok
    return kept


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tracks", type=int, default=200)
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--loop-sample", type=int, default=20000, help="candidates timed in the loop baseline")
    args = ap.parse_args()
    offsets = [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]
    scene = build_scene(args.tracks, args.frames, offsets)

    t0 = time.perf_counter()
    pairs, stats = make_pairs(scene, progress=False)
    t_vec = time.perf_counter() - t0
    rate_vec = stats.candidates / t_vec

    # the same candidates for the loop: (frame, track) inside each track span x offsets
    tr_i, fr_i, _ = track_boxes_at(scene, scene.rig_timestamps_us)
    cand = [(f, t, o) for f, t in zip(fr_i, tr_i, strict=True) for o in offsets]
    rng = np.random.default_rng(1)
    sample = [cand[i] for i in rng.choice(len(cand), size=min(args.loop_sample, len(cand)), replace=False)]
    t0 = time.perf_counter()
    loop_pairs(scene, sample, np.array(offsets))
    t_loop = time.perf_counter() - t0
    rate_loop = len(sample) / t_loop

    print(f"scene: {args.tracks} tracks x {args.frames} frames x {len(offsets)} offsets = "
          f"{stats.candidates} candidate boxes, {stats.kept} pairs kept")
    print(f"vectorised make_pairs: {t_vec:.2f} s, {rate_vec:,.0f} box-pairs/s")
    print(f"per-box cv2.projectPoints loop: {len(sample)} boxes in {t_loop:.2f} s, {rate_loop:,.0f} box-pairs/s")
    print(f"speed-up (vectorised / loop): {rate_vec / rate_loop:.1f}x  (target >= 30x)")


if __name__ == "__main__":
    main()
