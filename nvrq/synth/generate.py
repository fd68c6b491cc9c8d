"""``generate_scene``: write a complete synthetic scene folder (docs/FORMATS.md §2).

Layer: nvrq core, synth (synthetic scenes).

Output layout::

    OUT/scene.json, OUT/images.csv, OUT/degradation.csv
    OUT/images/<camera>/gt/<timestamp_us>.png
    OUT/images/<camera>/render_<offset:+.2f>/<timestamp_us>.png      (lateral views)
    OUT/images/<camera>/render_<z+0.50_yaw-5.00>/<timestamp_us>.png  (other perturbations)
    OUT/images/<camera>/render_<view>/<method>/<timestamp_us>.png       (with ``methods``)

GT images come from the true cameras; renders from the virtual cameras of paper Eq. 1-2
generalised (``T_sensor'_rig = T_pert @ T_sensor_rig``, see
:func:`nvrq.geometry.poses.perturb_T_sensor_rig`) with the artefacts of
:mod:`nvrq.synth.degradation`, growing with the perturbation's size
(:func:`nvrq.synth.degradation.perturbation_size`). ``degradation.csv`` has one row per
camera, frame, tracked object whose centre is in front of the virtual camera, and view:
``camera, timestamp_us, track_id, y_offset_m, severity`` and one strength column per
artefact; the five other perturbation columns follow (in it and in ``images.csv``) only when
some view is not lateral, so a lateral-only scene is written exactly as before.

Methods (``methods=[(name, scale), ...]``, ``nvrq synth --methods``): each view is rendered
once, then degraded once per method with the same random draws and every severity (and the
offset-driven whole-image blur and colour cast) multiplied by the method's scale, so the
ranking of the methods is known: a smaller scale is a less degraded, better method.
``images.csv`` and ``degradation.csv`` then end with a ``method`` column (empty for GT rows).

Deterministic: every random draw comes from ``numpy.random.default_rng`` streams keyed by
the seed (and camera, frame, offset), so one seed gives byte-identical files.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
from tqdm import tqdm

from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN, check_method_scales, method_columns
from data_schema.options import options_or_keywords
from data_schema.perturbation import (
    LIMITS,
    PERTURBATION_COLUMNS,
    extra_columns,
    labels,
    lateral,
)
from data_schema.scene import save_scene
from data_schema.tables import IMAGES_COLUMNS, atomic_folder, atomic_path, write_table
from nvrq.geometry.poses import T_sensor_world, matrix_to_pose7, perturb_T_sensor_rig
from nvrq.render_plans import default_image_path
from nvrq.synth.artefacts import ARTEFACTS, blend_into
from nvrq.synth.assets import build_assets
from nvrq.synth.degradation import perturbation_size, severity, strengths
from nvrq.synth.ground import build_ground, camera_background
from nvrq.synth.layout import build_world
from nvrq.synth.renderer import virtual_camera
from nvrq.synth.view import render_view

__all__ = [
    "SynthOptions",
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
    """scene.json camera entries for ``size (W, H)``: 'front' (opencv_pinhole, 60 deg wide, mild
    barrel distortion) and 'front_wide' (f-theta, 120 deg wide, image corners beyond
    ``max_angle``). Both mounted 1.5 m high looking forward, pitched down 2 deg.

    Parameters
    ----------
    size : (int, int)
        ``(W, H)`` pixels.

    Returns
    -------
    dict
        Camera name -> ``{"model": dict, "T_sensor_rig": (4, 4) float64}``.
    """
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


def _parse(seconds, fps, cameras, size):
    if not (isinstance(seconds, int | float) and math.isfinite(seconds) and seconds > 0):
        raise InputError(param="seconds", expected="a positive number of seconds", got=seconds)
    if not (isinstance(fps, int | float) and math.isfinite(fps) and 0 < fps <= 1000):
        raise InputError(param="fps", expected="a frame rate in (0, 1000]", got=fps)
    cams = list(cameras)
    bad = [c for c in cams if c not in CAMERA_KINDS]
    if not cams or bad or len(set(cams)) != len(cams):
        raise InputError(
            param="cameras", expected=f"distinct camera kinds from {{{', '.join(CAMERA_KINDS)}}}", got=cameras
        )
    W, H = (int(v) for v in size)
    if len(tuple(size)) != 2 or W < 64 or H < 48 or W > 8192 or H > 8192:
        raise InputError(param="size", expected="WxH with 64 <= W <= 8192 and 48 <= H <= 8192", got=size)
    return [CAMERA_KINDS[c] for c in cams], (W, H)


def _views(offsets, perturbations) -> np.ndarray:
    """The render views ``(K, 6)``: ``perturbations`` when given, else the lateral ``offsets``."""
    m, deg = LIMITS["m"], LIMITS["deg"]
    if perturbations is None:
        offs = [float(o) for o in offsets]
        if not offs or not all(math.isfinite(o) and abs(o) <= m for o in offs) or len(set(offs)) != len(offs):
            raise InputError(param="offsets", expected=f"distinct lateral offsets in metres within [-{m:g}, {m:g}]",
                             got=offsets)
        return lateral(offs)
    P = np.asarray(perturbations, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 6 or not len(P) or not np.isfinite(P).all() \
            or np.abs(P[:, :3]).max() > m or np.abs(P[:, 3:]).max() > deg or len(set(labels(P))) != len(P):
        raise InputError(param="perturbations", expected=f"distinct (K, 6) rows (dx, dy, dz in [-{m:g}, {m:g}] m; "
                         f"roll, pitch, yaw in [-{deg:g}, {deg:g}] deg)", got=np.shape(P))
    return P


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
    """The docs/FORMATS.md §2 ``scene.json`` dict of a synthetic ``world`` seen by ``cams``.

    Tracks hold the frames where each actor is present (box centres, ``[x, y, z, qx, qy, qz, qw]``).

    Parameters
    ----------
    world : World
        The clip's world.
    cams : dict
        Camera name -> ``scene.json`` camera entry (:func:`camera_models`).
    clip_id : str
        The clip id written to the document.

    Returns
    -------
    dict
        The ``scene.json`` document.
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


@dataclass
class _Clip:
    """Everything a frame's renderer needs (built once per scene)."""

    seed: int
    clip_id: str
    ts: np.ndarray
    world: object
    assets: object
    ground: object
    cams: dict
    vcams: dict
    bgds: dict
    global_cast: np.ndarray


def _build_clip(seed: int, seconds: float, fps: float, cam_names: list, size: tuple) -> _Clip:
    """Draw the world, textures, ground and camera backgrounds (the seeded random streams 1-4)."""
    W, _ = size
    n_frames = max(int(round(seconds * fps)), 1)
    ts = np.round(np.arange(n_frames) * 1e6 / fps).astype(np.int64)
    world = build_world(np.random.default_rng([seed, 1]), timestamps_us=ts)
    assets = build_assets(world, np.random.default_rng([seed, 2]))
    ground = build_ground(
        world, np.random.default_rng([seed, 3]), res=float(np.clip(0.08 * 1280 / W, 0.06, 0.16))
    )
    all_cams = camera_models(size)
    cams = {n: all_cams[n] for n in cam_names}
    vcams = {n: virtual_camera(c["model"]) for n, c in cams.items()}
    bgds = {
        n: camera_background(vcams[n].K, vcams[n].size, cams[n]["T_sensor_rig"], lighting=world.lighting)
        for n in cams
    }
    global_cast = np.random.default_rng([seed, 4]).normal(0.0, 1.0, 3)
    return _Clip(seed, f"synth-{seed:06d}", ts, world, assets, ground, cams, vcams, bgds, global_cast)


def _degrade_objects(clip: _Clip, name: str, f: int, view: np.ndarray, Tcw, img, ids, boxes, rng,
                     scale: float = 1.0):
    """Blend every visible object's artefacts into ``img`` (far to near), their severity
    multiplied by the method's ``scale``; returns the degradation rows of the objects in front
    of the virtual camera."""
    size = float(perturbation_size(view[None])[0])
    T_wc = np.linalg.inv(Tcw)
    rows, order = [], []
    for k, actor in enumerate(clip.world.actors):
        if not actor.present[f]:
            continue
        pc = T_wc[:3, :3] @ actor.T_box_world[f, :3, 3] + T_wc[:3, 3]
        if pc[2] <= 0:
            continue
        sev = float(severity(np.array([size]), np.array([np.linalg.norm(pc)]), coverage=actor.coverage)[0])
        sev = float(np.clip(sev * (1.0 + rng.normal(0.0, 0.03)) * scale, 1e-3, 1.0))
        st = strengths(np.array([sev]), actor.profile)[0]
        rows.append((name, int(clip.ts[f]), actor.track_id, *view.tolist(), sev, *st.tolist()))
        b = boxes.get(k)
        if b is not None and (b[2] - b[0]) * (b[3] - b[1]) >= 100:
            order.append((-pc[2], k, st, sev))
    order.sort(key=lambda r: r[0])
    for _, k, st, sev in order:
        blend_into(img, ids, k, boxes[k], st, sev, rng=rng)
    return rows


def _whole_image_artefacts(clip: _Clip, img: np.ndarray, view: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """Blur and colour cast growing with the perturbation's size (times the method's ``scale``)."""
    size = float(perturbation_size(view[None])[0]) * scale
    img = cv2.GaussianBlur(img, (0, 0), 0.35 + 0.3 * size)
    cast = (clip.global_cast * (1.5 + 2.0 * size)).astype(np.float32)
    return np.clip(img.astype(np.float32) + cast, 0, 255).astype(np.uint8)


def _render_frame(clip: _Clip, views: np.ndarray, methods: list, out: Path, task) -> tuple[list, list]:
    """GT and every view of one camera frame, each view once per method (``(name, scale)``;
    name ``''`` for none): image rows ``(camera, t, source, *view, path, method)`` and
    degradation rows (``method`` last). Every method degrades the same clean render with the
    same random stream, so they differ by their scale only."""
    ci, name, f = task
    cam, vc, bgd = clip.cams[name], clip.vcams[name], clip.bgds[name]
    T_s_rig = perturb_T_sensor_rig(cam["T_sensor_rig"], np.concatenate([views, np.zeros((1, 6))]))
    T_cam_world = T_sensor_world(clip.world.T_rig_world[f], T_s_rig)
    render = partial(render_view, clip.world, clip.assets, clip.ground, bgd, vc.K, vc.size)
    img, ids, boxes = render(T_cam_world[-1], f)
    clean0 = (img.copy(), ids, boxes)
    imgs = [("gt", np.zeros(6), "", vc.to_real(img))]
    deg_rows = []
    for j, view in enumerate(views, start=1):
        Tcw = T_cam_world[j - 1]
        clean = clean0 if not view.any() else render(Tcw, f)  # the zero view sees exactly the GT scene
        for method, scale in methods:
            img, ids, boxes = (clean[0].copy(),) + clean[1:]
            rng = np.random.default_rng([clip.seed, 10, ci, f, j])
            deg_rows += [(*r, method) for r in _degrade_objects(clip, name, f, view, Tcw, img, ids, boxes, rng,
                                                                 scale)]
            imgs.append(("render", view, method, vc.to_real(_whole_image_artefacts(clip, img, view, scale))))
    paths = []
    t = int(clip.ts[f])
    for source, view, method, im in imgs:
        rel = default_image_path(name, t, source, view[1], perturbation=view, method=method)
        _write_png(out / rel, im)
        paths.append((name, t, source, *view.tolist(), rel, method))
    return paths, deg_rows


def _render_all(clip: _Clip, views: np.ndarray, methods: list, out: Path, progress: bool) -> tuple[list, list]:
    """Render every camera frame (two threads); image rows and degradation rows, in order."""
    tasks = [(ci, name, f) for ci, name in enumerate(clip.cams) for f in range(len(clip.ts))]
    workers = min(2, os.cpu_count() or 1)
    image_rows, deg_rows = [], []
    bar = tqdm(total=len(tasks) * (len(views) * len(methods) + 1), desc=f"synth {clip.clip_id}", unit="img",
               disable=not progress)
    work = partial(_render_frame, clip, views, methods, out)
    pool = ThreadPoolExecutor(max_workers=workers) if workers > 1 else None
    try:
        for paths, rows in pool.map(work, tasks) if pool else map(work, tasks):
            image_rows += paths
            deg_rows += rows
            bar.update(len(paths))
    finally:
        if pool:
            pool.shutdown(cancel_futures=True)
        bar.close()
    return image_rows, deg_rows


def _write_tables(clip: _Clip, views: np.ndarray, out: Path, image_rows: list, deg_rows: list) -> None:
    """``degradation.csv``, ``images.csv`` and ``scene.json`` (extra perturbation columns only
    when some view is not lateral, ``method`` last only with methods)."""
    extra = extra_columns(views)
    deg = pd.DataFrame(deg_rows, columns=["camera", "timestamp_us", "track_id", *PERTURBATION_COLUMNS,
                                          "severity", *ARTEFACTS, METHOD_COLUMN])
    deg[["severity", *ARTEFACTS]] = deg[["severity", *ARTEFACTS]].round(5)
    write_table(deg, out / "degradation.csv", columns=[*DEGRADATION_COLUMNS, *extra, *method_columns(deg)])
    images = pd.DataFrame(image_rows, columns=["camera", "timestamp_us", "source", *PERTURBATION_COLUMNS, "path",
                                               METHOD_COLUMN])
    save_scene(scene_document(clip.world, clip.cams, clip.clip_id),
               images.loc[:, [*IMAGES_COLUMNS, *extra, *method_columns(images)]], out)


@dataclass(frozen=True)
class SynthOptions:
    """What :func:`generate_scene` draws (``nvrq synth``'s options).

    Parameters
    ----------
    seed : int
        Seeds the layout, the tracks and the artefacts (>= 0).
    seconds, fps : float
        Clip length (s) and frame rate (Hz).
    offsets : sequence of float
        Lateral novel-view offsets in metres (left > 0).
    perturbations : (K, 6) array, optional
        ``(dx, dy, dz, roll, pitch, yaw)`` views (metres, degrees); they replace ``offsets``.
    cameras : sequence of str
        Camera kinds from {'pinhole', 'ftheta'} (named 'front', 'front_wide').
    size : (int, int)
        Image width and height in pixels.
    methods : list of (str, float), optional
        None (one unnamed method), or ``[(name, scale), ...]``
        (:func:`data_schema.methods.check_method_scales`): every view is rendered once per
        method, its artefact severity times ``scale`` (a smaller scale is a better method).

    """

    seed: int = 0
    seconds: float = 10.0
    fps: float = 10.0
    offsets: tuple = (-3, -2, -1, 0, 1, 2, 3)
    perturbations: object = None
    cameras: tuple = ("pinhole",)
    size: tuple = (1280, 720)
    methods: object = None


def generate_scene(out: Path, options: SynthOptions | None = None, *, progress: bool = True,
                   **keywords) -> Path:
    """Write a synthetic scene folder to ``out`` and return it (see module docstring).

    The folder is built beside ``out`` and put in its place at the end
    (:class:`data_schema.tables.atomic_folder`): a scene folder already there is replaced as a
    whole, and an interrupted run leaves it as it was.

    ``cameras``: kinds from {'pinhole', 'ftheta'} (camera names 'front', 'front_wide');
    ``size (W, H)`` pixels; ``offsets`` lateral metres (left > 0), or ``perturbations``
    ``(K, 6)`` ``(dx, dy, dz, roll, pitch, yaw)`` (metres, degrees), which replace them.
    ``methods``: None (one unnamed method), or ``[(name, scale), ...]``
    (:func:`data_schema.methods.check_method_scales`): every view is rendered once per method, its
    artefact severity times ``scale`` (so a smaller scale is a better method).

    Parameters
    ----------
    out : pathlib.Path
        The scene folder to write.
    options : SynthOptions, optional
        What to draw (default: :class:`SynthOptions` defaults, or ``keywords``).
    progress : bool, optional
        Show a progress bar (default True).
    **keywords
        :class:`SynthOptions` fields, instead of ``options``.

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    o = options_or_keywords(SynthOptions, options, keywords, who="generate_scene")
    seed, seconds, fps, methods = o.seed, o.seconds, o.fps, o.methods
    cam_names, (W, H) = _parse(seconds, fps, o.cameras, o.size)
    views = _views(o.offsets, o.perturbations)
    methods = [("", 1.0)] if methods is None else check_method_scales(methods, option="methods")
    if not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError(param="seed", expected="a non-negative integer", got=seed)
    out = Path(out)
    clip = _build_clip(int(seed), seconds, fps, cam_names, (W, H))
    with atomic_folder(out) as tmp:  # whole or nothing: no file of a scene already at ``out`` stays
        image_rows, deg_rows = _render_all(clip, views, methods, tmp, progress)
        _write_tables(clip, views, tmp, image_rows, deg_rows)
    return out
