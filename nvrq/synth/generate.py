"""``generate_scene``: write a complete synthetic scene folder (SPEC section 2).

Output layout::

    OUT/scene.json, OUT/images.csv, OUT/degradation.csv
    OUT/images/<camera>/gt/<timestamp_us>.png
    OUT/images/<camera>/render_<offset:+.2f>/<timestamp_us>.png

GT images come from the true cameras; renders from the virtual cameras of paper Eq. 1-2
(``T_sensor'_rig = T_offset @ T_sensor_rig``) with the artefacts of
:mod:`nvrq.synth.degradation`. ``degradation.csv`` has one row per camera, frame, tracked
object whose centre is in front of the virtual camera, and offset: ``camera,
timestamp_us, track_id, y_offset_m, severity`` and one strength column per artefact.

Deterministic: every random draw comes from ``numpy.random.default_rng`` streams keyed by
the seed (and camera, frame, offset), so one seed gives byte-identical files.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from tqdm import tqdm

from data_schema.errors import InputError
from data_schema.scene import save_scene
from data_schema.tables import atomic_path, write_table
from nvrq.geometry.poses import T_sensor_world, matrix_to_pose7, offset_T_sensor_rig
from nvrq.render_plan import default_image_path
from nvrq.synth.artefacts import ARTEFACTS, blend_into
from nvrq.synth.assets import build_assets
from nvrq.synth.degradation import severity, strengths
from nvrq.synth.ground import build_ground, camera_background
from nvrq.synth.layout import build_world
from nvrq.synth.renderer import virtual_camera
from nvrq.synth.view import render_view

__all__ = [
    "generate_scene",
    "scene_document",
    "camera_models",
    "CAMERA_KINDS",
    "DEGRADATION_COLUMNS",
]

CAMERA_KINDS = {"pinhole": "front", "ftheta": "front_wide"}
DEGRADATION_COLUMNS = (
    "camera",
    "timestamp_us",
    "track_id",
    "y_offset_m",
    "severity",
    "blur",
    "ghost",
    "floaters",
    "smear",
    "color_shift",
    "holes",
)


def camera_models(size: tuple[int, int]) -> dict[str, dict]:
    """SPEC camera entries for ``size (W, H)``: 'front' (opencv_pinhole, 60 deg wide, mild
    barrel distortion) and 'front_wide' (f-theta, 120 deg wide, image corners beyond
    ``max_angle``). Both mounted 1.5 m high looking forward, pitched down 2 deg."""
    W, H = size
    cx, cy = (W - 1) / 2, (H - 1) / 2
    f = (W / 2) / math.tan(math.radians(30))
    front = {
        "type": "opencv_pinhole",
        "resolution": [W, H],
        "focal_length": [f, f],
        "principal_point": [cx, cy],
        "radial_coeffs": [-0.04, 0.01, 0.0, 0.0, 0.0, 0.0],
        "tangential_coeffs": [0.0, 0.0],
        "thin_prism_coeffs": [0.0, 0.0, 0.0, 0.0],
    }
    fw = (W / 2) / math.radians(60)  # pixels per radian at the centre
    a2p = [0.0, fw, 0.0, -0.02 * fw, 0.0, 0.0]
    theta = np.linspace(0.0, 1.25, 200)
    rho = np.polyval(a2p[::-1], theta)
    p2a = np.polyfit(rho, theta, 5)[::-1]
    p2a[0] = 0.0
    wide = {
        "type": "ftheta",
        "resolution": [W, H],
        "principal_point": [cx, cy],
        "reference_poly": "ANGLE_TO_PIXELDIST",
        "angle_to_pixeldist_poly": a2p,
        "pixeldist_to_angle_poly": [float(c) for c in p2a],
        "max_angle": 1.1,
        "linear_cde": [1.0, 0.0, 0.0],
    }
    out = {}
    for name, model, pos in (
        ("front", front, (1.7, 0.0, 1.5)),
        ("front_wide", wide, (1.8, 0.0, 1.55)),
    ):
        p = math.radians(2.0)
        # camera axes (x right, y down, z forward) in the rig frame, pitched down by p
        z = np.array([math.cos(p), 0.0, -math.sin(p)])
        x = np.array([0.0, -1.0, 0.0])
        y = np.cross(z, x)
        T = np.eye(4)
        T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, y, z, pos
        out[name] = {"T_sensor_rig": T, "model": model}
    return out


def _parse(seconds, fps, offsets, cameras, size):
    if not (isinstance(seconds, int | float) and math.isfinite(seconds) and seconds > 0):
        raise InputError("--seconds", None, "a positive number of seconds", seconds)
    if not (isinstance(fps, int | float) and math.isfinite(fps) and 0 < fps <= 1000):
        raise InputError("--fps", None, "a frame rate in (0, 1000]", fps)
    offs = [float(o) for o in offsets]
    if (
        not offs
        or not all(math.isfinite(o) and abs(o) <= 20 for o in offs)
        or len(set(offs)) != len(offs)
    ):
        raise InputError(
            "--offsets", None, "distinct lateral offsets in metres within [-20, 20]", offsets
        )
    cams = list(cameras)
    bad = [c for c in cams if c not in CAMERA_KINDS]
    if not cams or bad or len(set(cams)) != len(cams):
        raise InputError(
            "--cameras", None, f"distinct camera kinds from {{{', '.join(CAMERA_KINDS)}}}", cameras
        )
    W, H = (int(v) for v in size)
    if len(tuple(size)) != 2 or W < 64 or H < 48 or W > 8192 or H > 8192:
        raise InputError("--size", None, "WxH with 64 <= W <= 8192 and 48 <= H <= 8192", size)
    return offs, [CAMERA_KINDS[c] for c in cams], (W, H)


def _write_png(path: Path, img: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        ok, buf = cv2.imencode(
            ".png",
            img,
            [
                cv2.IMWRITE_PNG_COMPRESSION,
                1,
                cv2.IMWRITE_PNG_STRATEGY,
                cv2.IMWRITE_PNG_STRATEGY_RLE,
            ],
        )
        if not ok:
            raise OSError(f"cannot encode {path}")
        tmp.write_bytes(buf.tobytes())


def scene_document(world, cams: dict, clip_id: str) -> dict:
    """The SPEC section 2 ``scene.json`` dict of a synthetic ``world`` seen by ``cams``.

    Tracks hold the frames where each actor is present (box centres, ``[x, y, z, qx, qy, qz, qw]``).
    """
    ts = world.timestamps_us
    tracks = []
    for actor in world.actors:
        idx = np.flatnonzero(actor.present)
        if len(idx) == 0:
            continue
        tracks.append(
            {
                "track_id": actor.track_id,
                "label_class": actor.label_class,
                "dims_lwh": [round(float(v), 4) for v in actor.dims],
                "timestamps_us": [int(t) for t in ts[idx]],
                "poses": np.round(matrix_to_pose7(actor.T_box_world[idx]), 6).tolist(),
            }
        )
    doc = {
        "clip_id": clip_id,
        "attributes": {"lighting": world.lighting, "road_type": world.road.road_type},
        "cameras": {
            n: {"T_sensor_rig": np.round(c["T_sensor_rig"], 12).tolist(), "model": c["model"]}
            for n, c in cams.items()
        },
        "rig_trajectory": {
            "timestamps_us": [int(t) for t in ts],
            "T_rig_world": np.round(world.T_rig_world, 9).tolist(),
        },
        "tracks": tracks,
    }
    return doc


def generate_scene(
    out: Path,
    *,
    seed: int = 0,
    seconds: float = 10.0,
    fps: float = 10.0,
    offsets=(-3, -2, -1, 0, 1, 2, 3),
    cameras=("pinhole",),
    size=(1280, 720),
    progress: bool = True,
) -> Path:
    """Write a synthetic scene folder to ``out`` and return it (see module docstring).

    ``cameras``: kinds from {'pinhole', 'ftheta'} (camera names 'front', 'front_wide');
    ``size (W, H)`` pixels; ``offsets`` lateral metres (left > 0).
    """
    offs, cam_names, (W, H) = _parse(seconds, fps, offsets, cameras, size)
    if not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError("--seed", None, "a non-negative integer", seed)
    out = Path(out)
    seed = int(seed)
    n_frames = max(int(round(seconds * fps)), 1)
    ts = np.round(np.arange(n_frames) * 1e6 / fps).astype(np.int64)
    world = build_world(np.random.default_rng([seed, 1]), timestamps_us=ts)
    assets = build_assets(world, np.random.default_rng([seed, 2]))
    ground = build_ground(
        world, np.random.default_rng([seed, 3]), res=float(np.clip(0.08 * 1280 / W, 0.06, 0.16))
    )
    all_cams = camera_models((W, H))
    cams = {n: all_cams[n] for n in cam_names}
    vcams = {n: virtual_camera(c["model"]) for n, c in cams.items()}
    bgds = {
        n: camera_background(
            vcams[n].K, vcams[n].size, cams[n]["T_sensor_rig"], lighting=world.lighting
        )
        for n in cams
    }
    clip_id = f"synth-{seed:06d}"
    global_cast = np.random.default_rng([seed, 4]).normal(0.0, 1.0, 3)

    def render_frame(task):
        ci, name, f = task
        cam, vc, bgd = cams[name], vcams[name], bgds[name]
        T_s_rig = offset_T_sensor_rig(cam["T_sensor_rig"], np.array(offs + [0.0]))
        T_cam_world = T_sensor_world(world.T_rig_world[f], T_s_rig)
        rows, imgs = [], []
        clean0 = None
        for j, o in enumerate([None] + offs):
            Tcw = T_cam_world[-1] if o is None else T_cam_world[j - 1]
            if o is not None and o == 0.0 and clean0 is not None:
                img, ids, boxes = (clean0[0].copy(),) + clean0[1:]
            else:
                img, ids, boxes = render_view(world, assets, ground, bgd, vc.K, vc.size, Tcw, f)
            if o is None:
                clean0 = (img.copy(), ids, boxes)
                imgs.append(("gt", 0.0, vc.to_real(img)))
                continue
            rng = np.random.default_rng([seed, 10, ci, f, j])
            T_wc = np.linalg.inv(Tcw)
            order = []
            for k, actor in enumerate(world.actors):
                if not actor.present[f]:
                    continue
                pc = T_wc[:3, :3] @ actor.T_box_world[f, :3, 3] + T_wc[:3, 3]
                if pc[2] <= 0:
                    continue
                sev = float(
                    severity(
                        np.array([o]), np.array([np.linalg.norm(pc)]), coverage=actor.coverage
                    )[0]
                )
                sev = float(np.clip(sev * (1.0 + rng.normal(0.0, 0.03)), 1e-3, 1.0))
                st = strengths(np.array([sev]), actor.profile)[0]
                rows.append((name, int(ts[f]), actor.track_id, o, sev, *st.tolist()))
                b = boxes.get(k)
                if b is not None and (b[2] - b[0]) * (b[3] - b[1]) >= 100:
                    order.append((-pc[2], k, st, sev))
            order.sort(key=lambda r: r[0])
            for _, k, st, sev in order:
                blend_into(img, ids, k, boxes[k], st, sev, rng=rng)
            sigma = 0.35 + 0.3 * abs(o)
            img = cv2.GaussianBlur(img, (0, 0), sigma)
            cast = (global_cast * (1.5 + 2.0 * abs(o))).astype(np.float32)
            img = np.clip(img.astype(np.float32) + cast, 0, 255).astype(np.uint8)
            imgs.append(("render", o, vc.to_real(img)))
        paths = []
        for source, o, im in imgs:
            rel = default_image_path(name, int(ts[f]), source, o)
            _write_png(out / rel, im)
            paths.append((name, int(ts[f]), source, o, rel))
        return paths, rows

    tasks = [(ci, name, f) for ci, name in enumerate(cams) for f in range(n_frames)]
    workers = min(2, os.cpu_count() or 1)
    image_rows, deg_rows = [], []
    bar = tqdm(
        total=len(tasks) * (len(offs) + 1),
        desc=f"synth {clip_id}",
        unit="img",
        disable=not progress,
    )
    pool = ThreadPoolExecutor(max_workers=workers) if workers > 1 else None
    try:
        for paths, rows in pool.map(render_frame, tasks) if pool else map(render_frame, tasks):
            image_rows += paths
            deg_rows += rows
            bar.update(len(paths))
    finally:
        if pool:
            pool.shutdown(cancel_futures=True)
        bar.close()

    doc = scene_document(world, cams, clip_id)
    deg = pd.DataFrame(
        deg_rows,
        columns=["camera", "timestamp_us", "track_id", "y_offset_m", "severity", *ARTEFACTS],
    )
    deg[["severity", *ARTEFACTS]] = deg[["severity", *ARTEFACTS]].round(5)
    write_table(deg, out / "degradation.csv", columns=DEGRADATION_COLUMNS)
    images = pd.DataFrame(
        image_rows, columns=["camera", "timestamp_us", "source", "y_offset_m", "path"]
    )
    save_scene(doc, images, out)
    return out
