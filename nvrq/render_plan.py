"""Render plans: the virtual camera pose of every (camera, frame, offset) a renderer must draw.

For each camera, frame and lateral offset ``y`` (paper Eq. 1-2, SPEC section 1)::

    T_sensor'_rig   = T_offset(y) @ T_sensor_rig       T_offset = translation (0, y, 0) in the rig frame
    T_sensor_world  = T_rig_world(t) @ T_sensor'_rig   (camera -> world; the rig pose interpolated at t)
    T_world_sensor  = inv(T_sensor_world)              (world -> camera, the view matrix)

and the path (relative to the scene folder) where ``images.csv`` expects the render. A
frame outside the rig trajectory is skipped, never extrapolated.

Worked example: a camera 1.5 m ahead of the rig origin, rig at world (10, 5, 0) yawed +90
deg (rig x = world +y, rig y = world -x). At ``y = +2`` the camera moves 2 m to the rig's
left, i.e. to world -x: its centre is at world (10 - 2, 5 + 1.5, 0) = (8, 6.5, 0).

>>> import numpy as np
>>> from nvrq.geometry.poses import pose7_to_matrix
>>> T_rw = pose7_to_matrix(np.array([10, 5, 0, 0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)]))
>>> T_sr = np.eye(4); T_sr[0, 3] = 1.5
>>> P = plan_poses(T_rw[None], T_sr, np.array([2.0]))
>>> np.round(P["T_sensor_world"][0, 0, :3, 3], 9).tolist()
[8.0, 6.5, 0.0]
>>> default_image_path("front", 100000, "render", -1.0)
'images/front/render_-1.00/100000.png'
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.tables import atomic_write_text, write_table
from nvrq.geometry.poses import T_sensor_world, interpolate_poses, invert_rigid, offset_T_sensor_rig

__all__ = ["default_image_path", "plan_poses", "render_plan", "write_render_plan", "PLAN_COLUMNS"]

PLAN_COLUMNS = (
    "camera",
    "timestamp_us",
    "y_offset_m",
    "path",
    "T_sensor_rig",
    "T_sensor_world",
    "T_world_sensor",
)


def default_image_path(camera: str, timestamp_us: int, source: str, y_offset_m: float = 0.0) -> str:
    """The image layout used by ``nvrq synth`` and ``nvrq import``: relative POSIX path."""
    sub = "gt" if source == "gt" else f"render_{float(y_offset_m):+.2f}"
    return f"images/{camera}/{sub}/{int(timestamp_us)}.png"


def plan_poses(T_rig_world: np.ndarray, T_sensor_rig: np.ndarray, y_offsets_m: np.ndarray) -> dict:
    """Poses for frames ``T_rig_world: (F, 4, 4)``, one camera ``T_sensor_rig: (4, 4)`` and
    offsets ``(K,)``: ``T_sensor_rig (K, 4, 4)``, ``T_sensor_world`` and ``T_world_sensor``
    ``(F, K, 4, 4)``."""
    T_sr = offset_T_sensor_rig(T_sensor_rig, np.asarray(y_offsets_m, float))
    T_sw = T_sensor_world(np.asarray(T_rig_world, float)[:, None], T_sr[None])
    return {"T_sensor_rig": T_sr, "T_sensor_world": T_sw, "T_world_sensor": invert_rigid(T_sw)}


def render_plan(scene, *, offsets=None, cameras=None) -> pd.DataFrame:
    """Plan rows (columns :data:`PLAN_COLUMNS`, matrices as (4, 4) arrays) for ``scene``.

    ``offsets``: metres; default the render offsets listed in ``images.csv``. Frames are
    the timestamps ``images.csv`` lists for the camera, or the rig timestamps when it lists
    none. ``path`` is the render's ``images.csv`` path when listed, else
    :func:`default_image_path`.
    """
    images = scene.images
    if offsets is None:
        offsets = sorted(images.loc[images.source == "render", "y_offset_m"].unique().tolist())
        if not offsets:
            raise InputError(
                scene.root / "images.csv",
                "y_offset_m",
                "render rows or an --offsets list",
                "no render rows",
            )
    offsets = np.asarray([float(o) for o in offsets])
    names = list(scene.cameras) if cameras is None else list(cameras)
    unknown = [c for c in names if c not in scene.cameras]
    if unknown:
        raise InputError(
            "--cameras", None, f"cameras of the scene ({', '.join(scene.cameras)})", unknown[0]
        )
    listed = {
        (r.camera, int(r.timestamp_us), float(r.y_offset_m)): r.path
        for r in images[images.source == "render"].itertuples()
    }
    rows = []
    for name in names:
        cam = scene.cameras[name]
        ts = np.unique(images.loc[images.camera == name, "timestamp_us"].to_numpy(np.int64))
        if len(ts) == 0:
            ts = np.asarray(scene.rig_timestamps_us, np.int64)
        T_rw, ok = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, ts)
        ts, T_rw = ts[ok], T_rw[ok]
        P = plan_poses(T_rw, cam.T_sensor_rig, offsets)
        for i, t in enumerate(ts):
            for k, o in enumerate(offsets):
                path = listed.get((name, int(t), float(o))) or default_image_path(
                    name, t, "render", o
                )
                rows.append(
                    (
                        name,
                        int(t),
                        float(o),
                        path,
                        P["T_sensor_rig"][k],
                        P["T_sensor_world"][i, k],
                        P["T_world_sensor"][i, k],
                    )
                )
    return pd.DataFrame(rows, columns=list(PLAN_COLUMNS))


def write_render_plan(plan: pd.DataFrame, out: str | Path, *, clip_id: str = "") -> Path:
    """Write ``plan`` as ``.csv`` (matrices as JSON strings, row-major 4x4) or ``.json``
    (``{"clip_id", "renders": [{..., matrices as nested lists}]}``), atomically."""
    out = Path(out)
    mats = ["T_sensor_rig", "T_sensor_world", "T_world_sensor"]
    if out.suffix.lower() == ".json":
        renders = []
        for r in plan.itertuples(index=False):
            d = {
                "camera": r.camera,
                "timestamp_us": int(r.timestamp_us),
                "y_offset_m": float(r.y_offset_m),
                "path": r.path,
            }
            d.update({m: np.asarray(getattr(r, m)).tolist() for m in mats})
            renders.append(d)
        atomic_write_text(out, json.dumps({"clip_id": clip_id, "renders": renders}) + "\n")
        return out
    if out.suffix.lower() != ".csv":
        raise InputError(
            out, None, "a plan file ending in .csv or .json", out.suffix or "no suffix"
        )
    flat = plan.copy()
    for m in mats:
        flat[m] = [json.dumps(np.asarray(v).tolist()) for v in flat[m]]
    return write_table(flat, out, columns=PLAN_COLUMNS)
