"""Render plans: the virtual camera of every (camera, frame, view) a renderer must draw.

Layer: nvrq core, geometry (render plans).

For each camera, frame and view (a lateral offset ``y``, paper Eq. 1-2, docs/FORMATS.md §1, or
a perturbation ``(dx, dy, dz, roll, pitch, yaw)``, see
:func:`nvrq.geometry.poses.perturb_T_sensor_rig`)::

    T_sensor'_rig   = T_pert @ T_sensor_rig            T_pert = translation (0, y, 0) in the rig frame
                                                       for a lateral offset
    T_sensor_world  = T_rig_world(t) @ T_sensor'_rig   (camera -> world; the rig pose interpolated at t)
    T_world_sensor  = inv(T_sensor_world)              (world -> camera, the view matrix)

with the camera's intrinsics (``K``, distortion, size) and the path (relative to the scene
folder) where ``images.csv`` expects the render. A frame outside the rig trajectory is
skipped, never extrapolated. :func:`render_plan` returns the plan as arrays
(:class:`RenderPlan`: ``viewmats``, ``Ks``, ``widths``, ... as gsplat's ``rasterization``
takes them), :func:`plan_table` as rows, :func:`write_render_plan` writes either as ``.csv``,
``.json`` or ``.npz`` (docs/FORMATS.md §14).

Convention: ``viewmats`` are ``T_world_sensor``, world -> camera, camera axes x right, y down,
z forward (OpenCV's); ``Ks`` put the centre of pixel (column i, row j) at (u=i, v=j) (§1). With
``world='source'`` the world is the source dataset's own (``scene.json`` ``source_world``, e.g.
drivestudio's re-based world): ``T_sensor_world_source = T_world_source @ T_sensor_world``.

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
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from data_schema.errors import InputError, check_choice
from data_schema.methods import METHOD_COLUMN, check_method_name, method_suffix, method_values
from data_schema.perturbation import (
    VIEW_COLUMNS,
    extra_columns,
    is_lateral,
    labels,
    lateral,
    perturbation_array,
    view_suffix,
    views_from,
)
from data_schema.scene import Scene, load_scene
from data_schema.tables import atomic_path, atomic_write_text, write_table
from nvrq.choices import PLAN_FORMATS, WORLDS  # plan file formats (by suffix), worlds
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.poses import (
    T_sensor_world,
    interpolate_poses,
    invert_rigid,
    perturb_T_sensor_rig,
)

__all__ = [
    "PLAN_CAMERA_COLUMNS",
    "PLAN_COLUMNS",
    "PLAN_FORMATS",
    "PLAN_PERTURBATION_COLUMNS",
    "WORLDS",
    "RenderPlan",
    "default_image_path",
    "plan_format",
    "plan_poses",
    "plan_table",
    "render_plan",
    "write_render_plan",
]

PLAN_COLUMNS = (
    "camera",
    "timestamp_us",
    "y_offset_m",
    "path",
    "T_sensor_rig",
    "T_sensor_world",
    "T_world_sensor",
)
#: The camera of each row, after :data:`PLAN_COLUMNS` (docs/FORMATS.md §14): the model type,
#: the image size in pixels, the pinhole intrinsics (empty for ``ftheta``, which has no K) and
#: ``distortion``, a JSON object of the model's other parameters with scene.json's names.
PLAN_CAMERA_COLUMNS = ("camera_model", "width", "height", "fx", "fy", "cx", "cy", "distortion")
#: Appended to the columns above when some view is not lateral (the columns every table gains).
PLAN_PERTURBATION_COLUMNS = VIEW_COLUMNS

#: scene.json model parameters that the K matrix and the image size already give.
_K_PARAMS = ("type", "resolution", "focal_length", "principal_point")


def default_image_path(camera: str, timestamp_us: int, source: str, y_offset_m: float = 0.0, *,
                       perturbation=None, method: str = "") -> str:
    """The image layout used by ``nvrq synth`` and ``nvrq import``: relative POSIX path.

    A lateral view goes to ``render_<y:+.2f>``; a ``perturbation (6,)`` with other non-zero
    components to ``render_<label>`` with ``=`` dropped and ``,`` as ``_``; the render of a
    named ``method`` (:mod:`data_schema.methods`) one folder deeper, ``render_<...>/<method>``:

    Parameters
    ----------
    camera : str
        Camera name.
    timestamp_us : int, microseconds
        Frame time.
    source : str
        ``{'gt', 'render'}``.
    y_offset_m : float, metres, optional
        Lateral offset (left > 0).
    perturbation : (6,) float64, optional
        ``(dx, dy, dz, roll, pitch, yaw)``: metres, degrees, rig frame; replaces ``y_offset_m``.
    method : str, optional
        Reconstruction method (``''``: none).

    Returns
    -------
    str
        Relative POSIX path.

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
    (K, 4, 4)``, ``T_sensor_world`` and ``T_world_sensor`` ``(F, K, 4, 4)``.

    Parameters
    ----------
    T_rig_world : (F, 4, 4) float64
        Rig poses, rig frame to world frame (metres).
    T_sensor_rig : (4, 4) float64
        The camera mounting, sensor frame to rig frame.
    views : (K,) float64 or (K, 6) float64
        Lateral offsets (metres) or perturbations (metres, degrees, rig frame).

    Returns
    -------
    dict
        ``T_sensor_rig: (K, 4, 4)``, ``T_sensor_world: (F, K, 4, 4)`` and
        ``T_world_sensor: (F, K, 4, 4)``.
    """
    views = np.asarray(views, float)
    T_sr = perturb_T_sensor_rig(T_sensor_rig, views if views.ndim == 2 else lateral(views))
    T_sw = T_sensor_world(np.asarray(T_rig_world, float)[:, None], T_sr[None])
    return {"T_sensor_rig": T_sr, "T_sensor_world": T_sw, "T_world_sensor": invert_rigid(T_sw)}


@dataclass(frozen=True)
class RenderPlan:
    """A render plan as arrays, one entry per render ``(N,)`` (docs/FORMATS.md §14).

    Rows are ordered by camera (scene.json order, or the order asked), then timestamp, then
    view (in the order asked; by default the views of ``images.csv`` sorted), then method.

    Attributes
    ----------
    viewmats : (N, 4, 4) float64
        World -> camera (``T_world_sensor``), OpenCV camera axes (x right, y down, z forward).
    Ks : (N, 3, 3) float64
        ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``, pixel centres at integers (§1); NaN for an
        ``ftheta`` camera (no K; its parameters are in ``camera_params``).
    widths, heights : (N,) int64
        Image size in pixels.
    paths : (N,) str
        Where ``images.csv`` expects the render, relative to the scene folder.
    view_ids : (N,) str
        ``CLIP:CAMERA:TIMESTAMP:VIEW[:METHOD]``, as a pair id without its track (§3, §9).
    cameras, methods : (N,) str
        Camera name; method name (``''`` for a scene without methods).
    timestamps_us : (N,) int64
    perturbations : (N, 6) float64
        ``(dx, dy, dz, roll, pitch, yaw)`` in the rig frame (metres, degrees; §9).
    T_sensor_rig, T_sensor_world : (N, 4, 4) float64
        The moved camera on the rig; camera -> world (the inverse of ``viewmats``).
    camera_models : (N,) str
        scene.json ``model.type``.
    radial_coeffs (N, 6), tangential_coeffs (N, 2), thin_prism_coeffs (N, 4) : float64
        OpenCV distortion (scene.json names and order): ``opencv_pinhole``'s ``k1..k6``,
        ``p1, p2``, ``s1..s4``; ``opencv_fisheye``'s ``k1..k4`` in the first four radial
        entries; zeros for ``pinhole``; NaN for ``ftheta``.
    camera_params : dict
        Camera name -> its scene.json model dict (every parameter, defaults filled).
    clip_id, world : str
        The scene's clip id; ``'scene'`` or ``'source'`` (the world of the poses).
    T_world_source : (4, 4) float64
        Scene world -> the poses' world (the identity for ``world='scene'``).
    """

    clip_id: str
    world: str
    T_world_source: np.ndarray
    cameras: np.ndarray
    timestamps_us: np.ndarray
    perturbations: np.ndarray
    methods: np.ndarray
    paths: np.ndarray
    view_ids: np.ndarray
    T_sensor_rig: np.ndarray
    T_sensor_world: np.ndarray
    viewmats: np.ndarray
    Ks: np.ndarray
    widths: np.ndarray
    heights: np.ndarray
    camera_models: np.ndarray
    radial_coeffs: np.ndarray
    tangential_coeffs: np.ndarray
    thin_prism_coeffs: np.ndarray
    camera_params: dict = field(repr=False)

    def __len__(self) -> int:
        return len(self.paths)

    def arrays(self) -> dict[str, np.ndarray]:
        """The ``.npz`` arrays (§14): every attribute, strings as unicode arrays (no pickle),
        ``camera_params`` as a 0-d JSON string."""
        out = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if name == "camera_params":
                value = json.dumps(value)
            out[name] = np.asarray(value, dtype=str) if isinstance(value, str) else np.asarray(value)
        for name in ("cameras", "methods", "paths", "view_ids", "camera_models"):
            out[name] = np.asarray(out[name], dtype=str)
        return out


def _plan_views(scene, offsets, perturbations) -> np.ndarray:
    """The views ``(K, 6)`` to plan: ``perturbations``, else ``offsets``, else those listed."""
    if perturbations is not None or offsets is not None:
        return views_from(offsets, perturbations)
    renders = scene.images[scene.images.source == "render"]
    if renders.empty:
        raise InputError(scene.root / "images.csv", "y_offset_m", "render rows or `offsets`",
                         "no render rows")
    return np.unique(perturbation_array(renders), axis=0)  # lateral-only: increasing y


def _intrinsics(scene: Scene, name: str) -> dict:
    """One camera's K ``(3, 3)`` (NaN without one), size and OpenCV coefficients, from its
    camera class (:mod:`nvrq.geometry.cameras`)."""
    model = scene.cameras[name].model
    cam = camera_from_model(model, where=str(scene.root / "scene.json"), field_prefix=f"cameras.{name}.model.")
    K = np.full((3, 3), np.nan)
    radial, tangential, prism = np.full(6, np.nan), np.full(2, np.nan), np.full(4, np.nan)
    if hasattr(cam, "focal_length"):  # every model but ftheta
        (fx, fy), (cx, cy) = cam.focal_length, cam.principal_point
        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        radial, tangential, prism = np.zeros(6), np.zeros(2), np.zeros(4)
        r = np.asarray(getattr(cam, "radial_coeffs", ()), float)
        radial[:len(r)] = r
        tangential[:] = getattr(cam, "tangential_coeffs", tangential)
        prism[:] = getattr(cam, "thin_prism_coeffs", prism)
    return {"K": K, "size": cam.resolution, "type": model["type"], "radial": radial, "tangential": tangential,
            "prism": prism}


def render_plan(scene, *, offsets=None, perturbations=None, cameras=None, method: str | None = None,
                world: str = "scene") -> RenderPlan:
    """The render plan of ``scene`` as arrays (:class:`RenderPlan`), e.g. for gsplat's
    ``rasterization(..., viewmats, Ks, width, height)``.

    Parameters
    ----------
    scene : Scene or path
        A loaded scene, or a scene folder (read with ``check_images=False``: the renders
        need not exist).
    offsets : sequence of float, optional
        Lateral offsets in metres (paper Eq. 1-2).
    perturbations : (K, 6) array, optional
        6-DoF views (docs/FORMATS.md §9); they take precedence over ``offsets``. Default: the
        render views listed in ``images.csv``.
    cameras : sequence of str, optional
        Camera names, in this order (default: all, in scene.json order).
    method : str, optional
        Plan only this method's renders (its listed paths, else the method's default paths).
        Default: every method of the scene (one row per view and method, the same pose), or
        none for a scene without methods.
    world : {'scene', 'source'}
        The world of ``viewmats`` and ``T_sensor_world``: the scene's, or the source
        dataset's (``scene.json`` ``source_world``, :func:`source_world`).

    Returns
    -------
    RenderPlan
        One entry per render. Frames are the timestamps ``images.csv`` lists for the camera
        (or the rig timestamps when it lists none) inside the rig trajectory. ``paths`` is the
        render's ``images.csv`` path when listed, else :func:`default_image_path`.

    Raises
    ------
    InputError
        An unknown camera, method name or world; a scene without render rows and no views
        asked; ``world='source'`` for a scene without ``source_world``.
    """
    if world not in WORLDS:
        check_choice("world", world, WORLDS)
    if method:
        check_method_name(method, where="method", field=None)
    if not isinstance(scene, Scene):
        scene = load_scene(scene, check_images=False)
    T_ws = np.eye(4)
    if world == "source":
        src = scene.source_world
        if src is None:
            raise InputError(scene.root / "scene.json", "source_world", param="world",
                             expected="the source dataset's world, which only a scene imported "
                             "from drivestudio records (plan this scene in its own world with "
                             "`world` scene instead)", got="no source_world key")
        T_ws = src.T_world_source
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
    methods = [method] if method else list(dict.fromkeys(r_methods.tolist())) or [""]
    listed = dict(zip(zip(renders.camera, renders.timestamp_us.astype(int), labels(perturbation_array(renders)),
                          r_methods, strict=True),
                      renders.path, strict=True))
    keys = labels(views)
    parts = []
    for name in names:
        cam = scene.cameras[name]
        ts = np.unique(images.loc[images.camera == name, "timestamp_us"].to_numpy(np.int64))
        if len(ts) == 0:
            ts = np.asarray(scene.rig_timestamps_us, np.int64)
        T_rw, ok = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, ts)
        ts, T_rw = ts[ok], T_rw[ok]
        P = plan_poses(T_rw, cam.T_sensor_rig, views)
        F, K, M = len(ts), len(views), len(methods)
        fi, ki, mi = (a.ravel() for a in np.meshgrid(np.arange(F), np.arange(K), np.arange(M), indexing="ij"))
        paths = [listed.get((name, int(ts[f]), keys[k], methods[m])) or default_image_path(
            name, ts[f], "render", views[k][1], perturbation=views[k], method=methods[m])
            for f, k, m in zip(fi, ki, mi, strict=True)]
        parts.append({"camera": np.full(len(fi), name, dtype=object), "t": ts[fi], "view": views[ki],
                      "method": np.asarray(methods, dtype=object)[mi], "path": np.asarray(paths, dtype=object),
                      "T_sr": P["T_sensor_rig"][ki], "T_sw": P["T_sensor_world"][fi, ki], "intr": _intrinsics(scene, name)})
    return _assemble(scene, parts, world, T_ws)


def _assemble(scene: Scene, parts: list[dict], world: str, T_ws: np.ndarray) -> RenderPlan:
    """The :class:`RenderPlan` of the per-camera blocks of :func:`render_plan`."""
    def cat(key, shape=()):
        return np.concatenate([p[key] for p in parts]) if parts else np.zeros((0, *shape))

    def per_row(key, shape):
        return np.concatenate([np.broadcast_to(p["intr"][key], (len(p["t"]), *shape)) for p in parts]) \
            if parts else np.zeros((0, *shape))

    cameras, methods = cat("camera").astype(object), cat("method").astype(object)
    ts, views = cat("t").astype(np.int64), cat("view", (6,)).reshape(-1, 6)
    T_sw = T_ws @ cat("T_sw", (4, 4)).reshape(-1, 4, 4)
    sizes = per_row("size", (2,)).astype(np.int64).reshape(-1, 2)
    vids = [f"{scene.clip_id}:{c}:{t}:{v}{m}" for c, t, v, m in zip(
        cameras, ts, view_suffix(views), method_suffix(methods), strict=True)]
    return RenderPlan(
        clip_id=scene.clip_id, world=world, T_world_source=np.asarray(T_ws, float), cameras=cameras,
        timestamps_us=ts, perturbations=views, methods=methods, paths=cat("path").astype(object),
        view_ids=np.asarray(vids, dtype=object), T_sensor_rig=cat("T_sr", (4, 4)).reshape(-1, 4, 4),
        T_sensor_world=T_sw, viewmats=invert_rigid(T_sw), Ks=per_row("K", (3, 3)).reshape(-1, 3, 3),
        widths=sizes[:, 0].copy(), heights=sizes[:, 1].copy(),
        camera_models=np.asarray([p["intr"]["type"] for p in parts for _ in p["t"]], dtype=object),
        radial_coeffs=per_row("radial", (6,)).reshape(-1, 6), tangential_coeffs=per_row("tangential", (2,)).reshape(-1, 2),
        thin_prism_coeffs=per_row("prism", (4,)).reshape(-1, 4),
        camera_params={p["camera"][0]: scene.cameras[p["camera"][0]].model for p in parts if len(p["t"])},
    )


def _distortion_json(plan: RenderPlan) -> list[str]:
    """The CSV ``distortion`` object of each row (per camera: parameters beyond K and size)."""
    text = {}
    for name, model in plan.camera_params.items():
        given = _K_PARAMS if model["type"] != "ftheta" else ("type", "resolution")
        text[name] = json.dumps({k: v for k, v in model.items() if k not in given})
    return [text[c] for c in plan.cameras]


def plan_table(scene, **options) -> pd.DataFrame:
    """The plan of :func:`render_plan` as rows (the rows of the CSV plan).

    Parameters
    ----------
    scene : Scene, path or RenderPlan
        A scene (or folder), planned with ``options`` (those of :func:`render_plan`), or a
        plan already made.
    **options
        Keywords of :func:`render_plan` (ignored for a plan already made).

    Returns
    -------
    DataFrame
        Columns :data:`PLAN_COLUMNS` (matrices as (4, 4) arrays; ``T_world_sensor`` is
        ``viewmats``), :data:`PLAN_CAMERA_COLUMNS` (``fx``-``cy`` NaN for ``ftheta``;
        ``distortion`` a JSON string), then :data:`PLAN_PERTURBATION_COLUMNS` when some view is
        not lateral, then ``method`` when some row names one.
    """
    return _table(scene if isinstance(scene, RenderPlan) else render_plan(scene, **options))


def _table(plan: RenderPlan) -> pd.DataFrame:
    P = plan.perturbations
    df = pd.DataFrame({
        "camera": plan.cameras, "timestamp_us": plan.timestamps_us, "y_offset_m": P[:, 1], "path": plan.paths,
        "T_sensor_rig": list(plan.T_sensor_rig), "T_sensor_world": list(plan.T_sensor_world),
        "T_world_sensor": list(plan.viewmats), "camera_model": plan.camera_models,
        "width": plan.widths, "height": plan.heights, "fx": plan.Ks[:, 0, 0], "fy": plan.Ks[:, 1, 1],
        "cx": plan.Ks[:, 0, 2], "cy": plan.Ks[:, 1, 2], "distortion": _distortion_json(plan),
    })
    extra = extra_columns(P, PLAN_PERTURBATION_COLUMNS)
    if extra:
        for j, c in zip((0, 2, 3, 4, 5), PLAN_PERTURBATION_COLUMNS[:-1], strict=True):
            df[c] = P[:, j]
        df[PLAN_PERTURBATION_COLUMNS[-1]] = labels(P)
    if (plan.methods != "").any():
        df[METHOD_COLUMN] = plan.methods
    return df


def plan_format(out: str | os.PathLike, fmt: str | None = None) -> str:
    """The format of a plan file, from its suffix.

    Parameters
    ----------
    out : path
        The plan file: ``.csv``, ``.json`` or ``.npz``.
    fmt : {'csv', 'json', 'npz'}, optional
        When given, the format the suffix must name.

    Returns
    -------
    str
        One of :data:`PLAN_FORMATS`.

    Raises
    ------
    InputError
        Naming ``out`` (another suffix) or ``format`` (an unknown one, or not the suffix's).

    >>> plan_format("plan.NPZ")
    'npz'
    """
    suffix = Path(out).suffix.lower().lstrip(".")
    expected = "a plan file ending in " + ", ".join(f".{f}" for f in PLAN_FORMATS)
    if fmt is not None and fmt not in PLAN_FORMATS:
        raise InputError(param="format", expected="one of {" + ", ".join(PLAN_FORMATS) + "}", got=repr(fmt))
    if suffix not in PLAN_FORMATS:
        raise InputError(param="out", expected=expected, got=str(out))
    if fmt is not None and fmt != suffix:
        raise InputError(param="format", expected=f"the format of the output's suffix (.{suffix})", got=fmt)
    return suffix


def write_render_plan(plan: RenderPlan, out: str | os.PathLike, *, format: str | None = None) -> Path:
    """Write ``plan`` atomically as ``.csv`` (:func:`plan_table` rows, matrices and
    ``distortion`` as JSON strings, row-major), ``.json`` (``{"clip_id", "world",
    "T_world_source", "renders": [{..., matrices as nested lists}]}``) or ``.npz``
    (:meth:`RenderPlan.arrays`), by suffix (docs/FORMATS.md §14).

    Parameters
    ----------
    plan : RenderPlan
    out : path
        The plan file.
    format : {'csv', 'json', 'npz'}, optional
        Must agree with the suffix of ``out`` when given.

    Returns
    -------
    Path
        ``out``.
    """
    out = Path(out)
    fmt = plan_format(out, format)
    if fmt == "npz":
        with atomic_path(out) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **plan.arrays())
        return out
    table = _table(plan)
    mats = ["T_sensor_rig", "T_sensor_world", "T_world_sensor"]
    if fmt == "json":
        renders = []
        for r in table.to_dict("records"):
            r.update({m: np.asarray(r[m]).tolist() for m in mats})
            r.update({k: None if pd.isna(r[k]) else float(r[k]) for k in ("fx", "fy", "cx", "cy")})
            r.update(timestamp_us=int(r["timestamp_us"]), width=int(r["width"]), height=int(r["height"]),
                     distortion=json.loads(r["distortion"]))
            renders.append(r)
        doc = {"clip_id": plan.clip_id, "world": plan.world, "T_world_source": plan.T_world_source.tolist(),
               "renders": renders}
        atomic_write_text(out, json.dumps(doc) + "\n")
        return out
    for m in mats:
        table[m] = [json.dumps(np.asarray(v).tolist()) for v in table[m]]
    return write_table(table, out)
