"""Render plans: the virtual camera pose of every (camera, frame, view) a renderer must draw.

For each camera, frame and view (a lateral offset ``y``, paper Eq. 1-2, docs/FORMATS.md §1, or
a perturbation ``(dx, dy, dz, roll, pitch, yaw)``, see
:func:`nvrq.geometry.poses.perturb_T_sensor_rig`)::

    T_sensor'_rig   = T_pert @ T_sensor_rig            T_pert = translation (0, y, 0) in the rig frame
                                                       for a lateral offset
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
from data_schema.methods import METHOD_COLUMN, method_columns, method_values
from data_schema.perturbation import (
    VIEW_COLUMNS,
    extra_columns,
    is_lateral,
    labels,
    lateral,
    perturbation_array,
    views_from,
)
from data_schema.tables import atomic_write_text, write_table
from nvrq.geometry.poses import (
    T_sensor_world,
    interpolate_poses,
    invert_rigid,
    perturb_T_sensor_rig,
)

__all__ = ["default_image_path", "plan_poses", "render_plan", "write_render_plan", "PLAN_COLUMNS",
           "PLAN_PERTURBATION_COLUMNS"]

PLAN_COLUMNS = (
    "camera",
    "timestamp_us",
    "y_offset_m",
    "path",
    "T_sensor_rig",
    "T_sensor_world",
    "T_world_sensor",
)
#: Appended to :data:`PLAN_COLUMNS` when some view is not lateral (the columns every table gains).
PLAN_PERTURBATION_COLUMNS = VIEW_COLUMNS


def default_image_path(camera: str, timestamp_us: int, source: str, y_offset_m: float = 0.0, *,
                       perturbation=None, method: str = "") -> str:
    """The image layout used by ``nvrq synth`` and ``nvrq import``: relative POSIX path.

    A lateral view goes to ``render_<y:+.2f>``; a ``perturbation (6,)`` with other non-zero
    components to ``render_<label>`` with ``=`` dropped and ``,`` as ``_``; the render of a
    named ``method`` (:mod:`data_schema.methods`) one folder deeper, ``render_<...>/<method>``:

    >>> default_image_path("front", 5, "render", perturbation=np.array([0, 0, 0.5, 0, 0, -5]))
    'images/front/render_z+0.50_yaw-5.00/5.png'
    >>> default_image_path("front", 5, "render", 1.0, method="3dgs")
    'images/front/render_+1.00/3dgs/5.png'
    """
    if source == "gt":
        sub = "gt"
    elif perturbation is not None and not is_lateral(np.asarray(perturbation, float).reshape(1, 6))[0]:
        sub = "render_" + labels(perturbation)[0].replace("=", "").replace(",", "_")
    else:
        sub = f"render_{float(y_offset_m):+.2f}"
    if method and source != "gt":
        sub += f"/{method}"
    return f"images/{camera}/{sub}/{int(timestamp_us)}.png"


def plan_poses(T_rig_world: np.ndarray, T_sensor_rig: np.ndarray, views: np.ndarray) -> dict:
    """Poses for frames ``T_rig_world: (F, 4, 4)``, one camera ``T_sensor_rig: (4, 4)`` and
    views: lateral offsets ``(K,)`` or perturbations ``(K, 6)``. Returns ``T_sensor_rig
    (K, 4, 4)``, ``T_sensor_world`` and ``T_world_sensor`` ``(F, K, 4, 4)``."""
    views = np.asarray(views, float)
    T_sr = perturb_T_sensor_rig(T_sensor_rig, views if views.ndim == 2 else lateral(views))
    T_sw = T_sensor_world(np.asarray(T_rig_world, float)[:, None], T_sr[None])
    return {"T_sensor_rig": T_sr, "T_sensor_world": T_sw, "T_world_sensor": invert_rigid(T_sw)}


def _plan_views(scene, offsets, perturbations) -> np.ndarray:
    """The views ``(K, 6)`` to plan: ``perturbations``, else ``offsets``, else those listed."""
    if perturbations is not None or offsets is not None:
        return views_from(offsets, perturbations)
    renders = scene.images[scene.images.source == "render"]
    if renders.empty:
        raise InputError(scene.root / "images.csv", "y_offset_m", "render rows or `offsets`",
                         "no render rows")
    return np.unique(perturbation_array(renders), axis=0)  # lateral-only: increasing y


def render_plan(scene, *, offsets=None, perturbations=None, cameras=None) -> pd.DataFrame:
    """Plan rows (columns :data:`PLAN_COLUMNS`, matrices as (4, 4) arrays; then
    :data:`PLAN_PERTURBATION_COLUMNS` when some view is not lateral; then ``method`` for a
    scene with methods) for ``scene``.

    ``offsets``: lateral metres, or ``perturbations (K, 6)`` (which take precedence);
    default the render views listed in ``images.csv``. Frames are the timestamps
    ``images.csv`` lists for the camera, or the rig timestamps when it lists none. A scene
    with methods (docs/FORMATS.md §2) gets one row per view and method (same pose). ``path``
    is the render's ``images.csv`` path when listed, else :func:`default_image_path`.
    """
    images = scene.images
    views = _plan_views(scene, offsets, perturbations)
    names = list(scene.cameras) if cameras is None else list(cameras)
    unknown = [c for c in names if c not in scene.cameras]
    if unknown:
        raise InputError(
            param="cameras", expected=f"cameras of the scene ({', '.join(scene.cameras)})", got=unknown[0]
        )
    renders = images[images.source == "render"]
    r_methods = method_values(renders)
    methods = list(dict.fromkeys(r_methods.tolist()))  # [''] without methods
    listed = dict(zip(zip(renders.camera, renders.timestamp_us.astype(int), labels(perturbation_array(renders)),
                          r_methods, strict=True),
                      renders.path, strict=True))
    keys = labels(views)
    rows = []
    for name in names:
        cam = scene.cameras[name]
        ts = np.unique(images.loc[images.camera == name, "timestamp_us"].to_numpy(np.int64))
        if len(ts) == 0:
            ts = np.asarray(scene.rig_timestamps_us, np.int64)
        T_rw, ok = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, ts)
        ts, T_rw = ts[ok], T_rw[ok]
        P = plan_poses(T_rw, cam.T_sensor_rig, views)
        for i, t in enumerate(ts):
            for k, v in enumerate(views):
                for m in methods:
                    path = listed.get((name, int(t), keys[k], m)) or default_image_path(
                        name, t, "render", v[1], perturbation=v, method=m)
                    rows.append((name, int(t), float(v[1]), path, P["T_sensor_rig"][k], P["T_sensor_world"][i, k],
                                 P["T_world_sensor"][i, k], *v[[0, 2, 3, 4, 5]].tolist(), keys[k], m))
    plan = pd.DataFrame(rows, columns=[*PLAN_COLUMNS, *PLAN_PERTURBATION_COLUMNS, METHOD_COLUMN])
    return plan.loc[:, [*PLAN_COLUMNS, *extra_columns(views, PLAN_PERTURBATION_COLUMNS), *method_columns(plan)]]


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
            d.update({c: getattr(r, c) for c in (*PLAN_PERTURBATION_COLUMNS, METHOD_COLUMN) if c in plan.columns})
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
    return write_table(flat, out, columns=[c for c in plan.columns])
