"""GT / novel-view box pairs (docs/FORMATS.md §3; paper sections 3.2 and 5.1).

Layer: nvrq core, geometry (GT / novel-view box pairs).

For every camera, frame and render perturbation of a scene, every object box is projected
into the GT view (the real camera) and into the novel view (the virtual camera moved by the
render's perturbation ``(dx, dy, dz, roll, pitch, yaw)`` in the rig frame, paper Eq. 1-2
generalised; see :func:`nvrq.geometry.poses.perturb_T_sensor_rig`; a lateral-only scene
has ``y_offset_m`` alone). A pair is kept when the box is
valid in both views: all 8 corners have positive depth, are projectable by the camera
model and lie inside ``0 <= u <= W-1, 0 <= v <= H-1``; the inclusive pixel box has a
shorter side of at least ``min_side`` and an area of at least ``min_area`` pixels
(sides and area are those of the crop ``image[y0:y1+1, x0:x1+1]``).

Everything is vectorised: all boxes of all frames of a camera are projected at once as
an ``(M, K, 8, 3)`` array (M boxes, K views).

Paths: ``gt_path`` / ``render_path`` are relative to the scene folder, as in
``images.csv``; the extra last column ``scene_root`` holds the scene folder's absolute
path so that ``nvrq score`` finds the images from the pairs table alone.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN, method_columns, method_values
from data_schema.perturbation import (
    EXTRA_PERTURBATION_COLUMNS,
    LABEL_COLUMN,
    PERTURBATION_COLUMNS,
    axes,
    labels,
    lateral,
    perturbation_array,
)
from data_schema.scene import Scene
from data_schema.tables import (
    MIN_SIDE_PX,
    MIN_VISIBLE,
    PAIRS_COLUMNS,
    SOURCE_VISIBILITY,
    VISIBILITY_COLUMNS,
    pair_ids,
)
from data_schema.text import plural
from nvrq.geometry.boxes import box_corners, box_sides, pixel_box
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.visibility import pair_visibility, visible_fractions
from nvrq.scene_boxes import (
    frame_boxes,
    frame_candidates,
    render_views,
    track_boxes_at,
    view_transforms,
)

__all__ = ["DROP_REASONS", "PAIRS_OUTPUT_COLUMNS", "SOURCE_VISIBILITY", "VISIBILITY_COLUMNS", "PairStats", "track_boxes_at", "view_validity", "make_pairs",
           "project_boxes"]

#: Why a candidate box (camera, frame, track, render view) was dropped, in order of precedence.
DROP_REASONS = ("no_gt_image", "unprojectable", "outside_image", "too_small", "occluded")

#: Columns of a :func:`make_pairs` table before the scene attributes and ``scene_root``.
PAIRS_OUTPUT_COLUMNS = (*PAIRS_COLUMNS, *EXTRA_PERTURBATION_COLUMNS, LABEL_COLUMN, *VISIBILITY_COLUMNS)


@dataclass
class PairStats:
    """Counts of a :func:`make_pairs` run: candidates, kept pairs and drops per reason, in
    total and per perturbation axis (``by_axis[axis]`` = ``{'candidates', 'kept', *reasons}``).

    Attributes
    ----------
    candidates : int
        (camera, frame, track, view) combinations considered.
    kept : int
        Valid pairs.
    dropped : dict
        Reason -> count, reasons :data:`DROP_REASONS`.
    frames_outside_trajectory : int
        Frames whose time lies outside the rig trajectory.
    by_axis : dict
        Perturbation axis -> ``{'candidates', 'kept', *reasons}`` counts.
    """

    candidates: int = 0
    kept: int = 0
    dropped: dict = field(default_factory=lambda: dict.fromkeys(DROP_REASONS, 0))
    frames_outside_trajectory: int = 0
    by_axis: dict = field(default_factory=dict)

    def summary(self) -> str:
        drops = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in self.dropped.items())
        line = f"{self.kept} pairs kept of {self.candidates} candidate boxes; dropped: {drops}"
        if self.frames_outside_trajectory:
            line += f"; {plural(self.frames_outside_trajectory, 'frame')} outside the rig trajectory skipped"
        moved = [a for a in self.by_axis if a not in ("none", "y")]
        if moved:  # only when the scene has views beyond the lateral ones
            for axis, c in self.by_axis.items():
                drops = ", ".join(f"{k.replace('_', ' ')} {c[k]}" for k in DROP_REASONS)
                line += f"\n  axis {axis}: {c['kept']} kept of {c['candidates']}; dropped: {drops}"
        return line

    def add(self, axis_names: np.ndarray, has_gt: np.ndarray, worst: np.ndarray) -> None:
        """Count candidates with axis ``axis_names (C,)``, GT present ``has_gt (C,)`` and
        view code ``worst (C,)`` (0 valid, 1-3 as :func:`view_validity`, 4 occluded)."""
        for axis in dict.fromkeys(axis_names.tolist()):
            c = self.by_axis.setdefault(axis, {"candidates": 0, "kept": 0, **dict.fromkeys(DROP_REASONS, 0)})
            for k, n in _counts(axis_names == axis, has_gt, worst).items():
                c[k] += n
        total = _counts(np.ones(len(axis_names), bool), has_gt, worst)
        self.candidates += total["candidates"]
        self.kept += total["kept"]
        for reason in DROP_REASONS:
            self.dropped[reason] += total[reason]


def _counts(sel: np.ndarray, has_gt: np.ndarray, worst: np.ndarray) -> dict:
    """``{'candidates', 'kept', *DROP_REASONS}`` of the candidates where ``sel`` (as :meth:`PairStats.add`)."""
    c = {"candidates": int(sel.sum()), "kept": int((sel & has_gt & (worst == 0)).sum()),
         "no_gt_image": int((sel & ~has_gt).sum())}
    for reason, code in zip(DROP_REASONS[1:], (1, 2, 3, 4), strict=True):
        c[reason] = int((sel & has_gt & (worst == code)).sum())
    return c


def view_validity(
    camera, corners_sensor: np.ndarray, *, min_side: float, min_area: float
) -> tuple[np.ndarray, np.ndarray]:
    """Validity of boxes in one or more views.

    ``corners_sensor: (..., 8, 3)`` in the camera frame -> ``(code: (...,) int8, box: (..., 4) int64)``
    with ``code`` 0 = valid, 1 = some corner unprojectable (behind the camera or beyond the
    model's range), 2 = some corner outside the image, 3 = too small. ``box`` is only
    meaningful where ``code == 0``; elsewhere it is ``[0, 0, 0, 0]`` (a corner at a grazing
    angle projects to 1e20 px and more, beyond any integer box).

    Parameters
    ----------
    camera : camera model
        With ``project(points)`` -> ``(uv, projectable)`` and ``in_image(uv)``.
    corners_sensor : (..., 8, 3) float
        Box corners in the camera frame.
    min_side : float
        Smallest box side (pixels) that is valid.
    min_area : float
        Smallest box area (square pixels) that is valid.

    Returns
    -------
    code : (...,) int8
        0 valid, 1 unprojectable, 2 outside the image, 3 too small.
    box : (..., 4) int64
        Inclusive pixel boxes ``x0, y0, x1, y1``; ``[0, 0, 0, 0]`` where a corner is invalid.
    """
    uv, projectable = camera.project(corners_sensor)
    projectable = projectable & np.isfinite(uv).all(axis=-1)
    all_proj = projectable.all(axis=-1)
    uv = np.where(projectable[..., None], uv, 0.0)
    inside = camera.in_image(uv).all(axis=-1)
    box = pixel_box(np.where(inside[..., None, None], uv, 0.0))
    w, h = box_sides(box)
    big = (np.minimum(w, h) >= min_side) & (w * h >= min_area)
    code = np.where(~all_proj, 1, np.where(~inside, 2, np.where(~big, 3, 0))).astype(np.int8)
    return code, box


def _view_codes(model, T_sensor_rig, T_rig_world, fr_i, corners, views, *, min_side, min_area):
    """Codes ``(M, K)`` (0 valid in both views, else the failing view's reason, GT view
    first), GT boxes ``(M, 4)`` and novel-view boxes ``(M, K, 4)``."""
    # GT view first (world -> GT sensor per frame), then the novel views only for boxes valid
    # in the GT view (the others cannot pair): GT sensor -> view k's sensor (view_transforms)
    T_gt_world, T_sk_s = view_transforms(T_sensor_rig, T_rig_world, views)
    T_ws = T_gt_world[fr_i]  # (M, 4, 4)
    corners_gt = np.matmul(corners, np.swapaxes(T_ws[:, :3, :3], 1, 2)) + T_ws[:, None, :3, 3]
    code_gt, box_gt = view_validity(model, corners_gt, min_side=min_side, min_area=min_area)
    good = np.flatnonzero(code_gt == 0)
    pk = np.matmul(corners_gt[good, None], np.swapaxes(T_sk_s[:, :3, :3], 1, 2)) + T_sk_s[:, None, :3, 3]
    code_n, box_n = view_validity(model, pk, min_side=min_side, min_area=min_area)  # (G, K)
    code = np.repeat(code_gt[:, None], len(views), axis=1)
    code[good] = code_n
    box = np.zeros((len(fr_i), len(views), 4), np.int64)
    box[good] = box_n
    return code, box_gt, box


def _pair_rows(scene, cam_name, r, gt_paths, tr_sel, gb, rb, vis) -> pd.DataFrame:
    """The pairs-table rows of kept candidates: render rows ``r``, their tracks ``tr_sel``,
    GT boxes ``gb`` and render boxes ``rb`` ``(P, 4)``, visible fractions ``vis`` (2 x (P,))."""
    tracks = scene.tracks
    ts = r.timestamp_us.to_numpy(np.int64)
    P = perturbation_array(r)
    tid = np.array([tracks[k].track_id for k in tr_sel], dtype=object)
    df = pd.DataFrame({
        "clip_id": scene.clip_id,
        "camera": cam_name,
        "track_id": tid,
        "label_class": np.array([tracks[k].label_class for k in tr_sel], dtype=object),
        "timestamp_us": ts,
        "y_offset_m": r.y_offset_m.to_numpy(np.float64),
        "gt_path": [gt_paths[int(t)] for t in ts],
        "render_path": r.path.to_numpy(dtype=object),
    })
    for j, name in enumerate(("x0", "y0", "x1", "y1")):
        df[f"gt_{name}"] = gb[:, j]
        df[f"r_{name}"] = rb[:, j]
    for c in EXTRA_PERTURBATION_COLUMNS:  # absent in a hand-built images table: 0
        df[c] = P[:, PERTURBATION_COLUMNS.index(c)]
    df[LABEL_COLUMN] = labels(P)
    for c, v in zip(VISIBILITY_COLUMNS, vis, strict=True):
        df[c] = v
    if any(t.source_visibility is not None for t in tracks):  # the dataset's own label, at the nearest sample
        df[SOURCE_VISIBILITY] = [_source_label(tracks[k], t) for k, t in zip(tr_sel, ts, strict=True)]
    methods = method_values(r)
    if METHOD_COLUMN in r.columns:  # a scene with methods (docs/FORMATS.md §3)
        df[METHOD_COLUMN] = methods
    df.insert(0, "pair_id", pair_ids(df, methods))
    return df


def _source_label(track, t_us: int) -> str | None:
    if track.source_visibility is None:
        return None
    i = int(np.argmin(np.abs(np.asarray(track.timestamps_us, np.int64) - t_us)))
    return track.source_visibility[i]


def _camera_pairs(scene: Scene, cam, stats: PairStats, *, min_side, min_area, min_visible,
                  visibility=True) -> pd.DataFrame | None:
    """The pairs of one camera (None when it has no renders); counts go into ``stats``."""
    model = camera_from_model(cam.model, where=str(scene.root / "scene.json"),
                              field_prefix=f"cameras.{cam.name}.model.")
    rows = scene.images[scene.images.camera == cam.name]
    renders = rows[rows.source == "render"]
    if renders.empty:
        return None
    gt_rows = rows[rows.source == "gt"]
    gt_paths = dict(zip(gt_rows.timestamp_us, gt_rows.path, strict=True))
    frames = np.unique(renders.timestamp_us.to_numpy(np.int64))
    views, r_k = render_views(renders)
    fb = frame_boxes(scene, frames)
    stats.frames_outside_trajectory += int((~fb.on_trajectory).sum())
    tr_i = fb.track_index
    code, box_gt, box = _view_codes(model, cam.T_sensor_rig, fb.T_rig_world, fb.frame_index, fb.corners, views,
                                    min_side=min_side, min_area=min_area)
    row_idx, box_idx = frame_candidates(renders, frames, fb.frame_index)
    k_idx = r_k[row_idx]
    has_gt = np.array([int(t) in gt_paths for t in renders.timestamp_us], dtype=bool)[row_idx]
    worst = code[box_idx, k_idx]
    valid = np.flatnonzero(has_gt & (worst == 0))
    if visibility:
        T_gt_world, T_view_gt = view_transforms(cam.T_sensor_rig, fb.T_rig_world, views)
        vis = pair_visibility(model, T_gt_world, T_view_gt, fb.frame_index, fb.T_box_world, fb.dims_lwh,
                              np.stack([box_idx[valid], k_idx[valid]], axis=1), min_visible=min_visible)
    else:
        vis = (np.full(len(valid), np.nan), np.full(len(valid), np.nan))
    if min_visible > 0:
        seen = (vis[0] >= min_visible) & (vis[1] >= min_visible)  # NaN: not seen
        worst[valid[~seen]] = 4
        valid, vis = valid[seen], (vis[0][seen], vis[1][seen])
    stats.add(axes(views)[k_idx], has_gt, worst)
    row_idx, box_idx, k_idx = row_idx[valid], box_idx[valid], k_idx[valid]
    return _pair_rows(scene, cam.name, renders.iloc[row_idx], gt_paths, tr_i[box_idx],
                      box_gt[box_idx], box[box_idx, k_idx], vis)


def _assemble(scene: Scene, frames_out: list[pd.DataFrame]) -> pd.DataFrame:
    methods = method_columns(scene.images)  # [] for a single-method scene: the former columns
    source = [SOURCE_VISIBILITY] if any(t.source_visibility is not None for t in scene.tracks) else []
    cols = list(PAIRS_OUTPUT_COLUMNS) + methods + source + list(scene.attributes) + ["scene_root"]
    if frames_out:
        pairs = pd.concat(frames_out, ignore_index=True)
    else:
        pairs = pd.DataFrame({c: pd.Series(dtype=object) for c in (*PAIRS_OUTPUT_COLUMNS, *methods, *source)})
    for k, v in scene.attributes.items():
        pairs[k] = v
    pairs["scene_root"] = str(scene.root.resolve())
    pairs = pairs.loc[:, cols].sort_values(
        ["camera", "timestamp_us", "track_id", "y_offset_m", *EXTRA_PERTURBATION_COLUMNS, *methods], kind="stable")
    return pairs.reset_index(drop=True)


def _pair_rule(rule: dict) -> tuple[float, float, float]:
    """``(min_side, min_area, min_visible)`` from :func:`project_boxes`' keywords, checked
    (pixels >= 0; a visible fraction in [0, 1])."""
    unknown = sorted(set(rule) - {"min_side", "min_area", "min_visible"})
    if unknown:
        raise TypeError(f"project_boxes() got an unexpected keyword argument {unknown[0]!r}")
    rule = {"min_side": MIN_SIDE_PX, "min_area": 0, "min_visible": MIN_VISIBLE, **rule}
    for name in ("min_side", "min_area"):
        value = rule[name]
        if not isinstance(value, int | float | np.number) or not np.isfinite(value) or value < 0:
            raise InputError(param=name, expected="a non-negative number of pixels", got=value)
    _check_min_visible(rule["min_visible"])
    return rule["min_side"], rule["min_area"], rule["min_visible"]


def project_boxes(
    camera, *, T_sensor_rig: np.ndarray, T_rig_world: np.ndarray, T_box_world: np.ndarray,
    dims_lwh: np.ndarray, perturbations: np.ndarray | None = None, offsets: np.ndarray | None = None,
    **rule: float,
) -> pd.DataFrame:
    """``nvrq pairs``' rule for one frame, in memory: every box in the GT view and in each
    novel view, kept or dropped with its reason (no scene folder).

    Parameters
    ----------
    camera : CameraModel or dict
        A camera (:mod:`nvrq.geometry.cameras`), or a scene.json camera model dict
        (``{'type': 'pinhole', 'resolution': [W, H], ...}``, docs/FORMATS.md §2).
    T_sensor_rig : (4, 4)
        The camera's mounting in the rig frame (scene.json ``T_sensor_rig``).
    T_rig_world : (4, 4)
        The rig pose at this frame (rig -> world).
    T_box_world : (M, 4, 4)
        Box centre poses (box -> world).
    dims_lwh : (M, 3)
        Their length, width, height (m).
    perturbations : (K, 6), optional
        Novel views ``(dx, dy, dz, roll, pitch, yaw)`` in metres and degrees, in the rig frame
        (:func:`nvrq.geometry.poses.perturb_T_sensor_rig`); or ``offsets`` (K,), lateral
        offsets in metres (``dy`` alone; positive = left). One of the two.
    **rule : float
        The rarely changed pair rule, as :func:`make_pairs`: ``min_side`` (pixels, default
        :data:`data_schema.tables.MIN_SIDE_PX`), ``min_area`` (pixels, default 0) and
        ``min_visible`` (0..1, default :data:`data_schema.tables.MIN_VISIBLE`; every box given
        occludes the others).

    Returns
    -------
    pandas.DataFrame
        M * K rows, box-major: ``box`` (0..M-1), ``view`` (0..K-1), ``kept`` (bool), ``reason``
        (``''`` when kept, else ``unprojectable``, ``outside_image``, ``too_small`` or
        ``occluded``, the GT view's reason first, as :data:`DROP_REASONS`), the inclusive pixel
        boxes ``gt_x0, gt_y0, gt_x1, gt_y1`` and ``r_x0, r_y0, r_x1, r_y1`` (meaningful where
        kept), and ``gt_visible``, ``novel_visible`` (NaN where the box is not valid in the view;
        ``novel_visible`` is not cast where ``gt_visible`` is below ``min_visible``).

    >>> cam = {"type": "pinhole", "resolution": [640, 480], "focal_length": [500, 500],
    ...        "principal_point": [319.5, 239.5]}
    >>> T_cam = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 1.5], [0, 0, 0, 1.0]])  # x fwd, z up
    >>> T_box = np.eye(4); T_box[:3, 3] = [10, 0, 1]
    >>> out = project_boxes(cam, T_sensor_rig=T_cam, T_rig_world=np.eye(4), T_box_world=T_box[None],
    ...                     dims_lwh=[[4.0, 2.0, 1.5]], offsets=[0.0, 50.0])
    >>> out[["view", "kept", "reason", "gt_visible"]].values.tolist()
    [[0, True, '', 1.0], [1, False, 'outside_image', 1.0]]

    The nearest face (x = 8 m ahead, y = -1..1 m) gives ``u = 500 * (-y) / 8 + 319.5`` = 257..382:

    >>> out.loc[0, ["r_x0", "r_x1"]].tolist()
    [257, 382]
    """
    from nvrq.geometry.cameras import CameraModel

    if (perturbations is None) == (offsets is None):
        raise InputError(param="perturbations", expected="exactly one of perturbations (K, 6) and offsets (K,)",
                         got="both" if offsets is not None else "neither")
    views = lateral(np.asarray(offsets, np.float64).reshape(-1)) if offsets is not None \
        else np.asarray(perturbations, np.float64)
    if views.ndim != 2 or views.shape[1] != 6 or not np.isfinite(views).all():
        raise InputError(param="perturbations", expected="a finite (K, 6) array (dx, dy, dz, roll, pitch, yaw)",
                         got=f"shape {views.shape}")
    model = camera if isinstance(camera, CameraModel) else camera_from_model(camera, where="camera")
    arrays = {}
    for name, value, shape in (("T_sensor_rig", T_sensor_rig, (4, 4)), ("T_rig_world", T_rig_world, (4, 4)),
                               ("T_box_world", T_box_world, (None, 4, 4)), ("dims_lwh", dims_lwh, (None, 3))):
        arr = np.asarray(value, np.float64)
        if arr.ndim != len(shape) or any(s is not None and a != s for a, s in zip(arr.shape, shape, strict=True)):
            want = "(M, " + ", ".join(map(str, shape[1:])) + ")" if shape[0] is None else str(shape)
            raise InputError(param=name, expected=f"an array of shape {want}", got=f"shape {arr.shape}")
        arrays[name] = arr
    if len(arrays["T_box_world"]) != len(arrays["dims_lwh"]):
        raise InputError(param="dims_lwh", expected=f"one row per box ({len(arrays['T_box_world'])})",
                         got=f"{len(arrays['dims_lwh'])} rows")
    min_side, min_area, min_visible = _pair_rule(rule)
    m, k = len(arrays["T_box_world"]), len(views)
    corners = box_corners(arrays["T_box_world"], arrays["dims_lwh"])
    frame = np.zeros(m, np.int64)
    code, box_gt, box = _view_codes(model, arrays["T_sensor_rig"], arrays["T_rig_world"][None],
                                    frame, corners, views, min_side=min_side, min_area=min_area)
    b_i, k_i = np.nonzero(code == 0)
    T_gt_world, T_view_gt = view_transforms(arrays["T_sensor_rig"], arrays["T_rig_world"][None], views)
    gv = visible_fractions(model, np.matmul(T_gt_world[0], arrays["T_box_world"]), arrays["dims_lwh"])
    # the novel view cast only where the GT view meets the rule, and exactly (min_visible 0: no
    # upper bounds), as the table shows the dropped boxes' values too
    if min_visible > 0:
        b_i, k_i = b_i[gv[b_i] >= min_visible], k_i[gv[b_i] >= min_visible]
    _, nv = pair_visibility(model, T_gt_world, T_view_gt, frame, arrays["T_box_world"], arrays["dims_lwh"],
                            np.stack([b_i, k_i], axis=1))
    vis = np.full((2, m, k), np.nan)
    vis[0] = gv[:, None]
    vis[1, b_i, k_i] = nv
    if min_visible > 0:
        code[(code == 0) & ~((vis[0] >= min_visible) & (vis[1] >= min_visible))] = 4
    reasons = np.array(["", *DROP_REASONS[1:]], dtype=object)
    out = pd.DataFrame({"box": np.repeat(np.arange(m), k), "view": np.tile(np.arange(k), m),
                        "kept": (code == 0).reshape(-1), "reason": reasons[code.reshape(-1)]})
    for j, name in enumerate(("x0", "y0", "x1", "y1")):
        out[f"gt_{name}"] = np.repeat(box_gt[:, j], k)
    for j, name in enumerate(("x0", "y0", "x1", "y1")):
        out[f"r_{name}"] = box[:, :, j].reshape(-1)
    out["gt_visible"] = vis[0].reshape(-1)
    out["novel_visible"] = vis[1].reshape(-1)
    return out


def _check_min_visible(value) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float | np.number) or not 0 <= value <= 1:
        raise InputError(param="min_visible", expected="a visible fraction in [0, 1]", got=value)


def make_pairs(
    scene: Scene, *, min_side: float = MIN_SIDE_PX, min_area: float = 0, min_visible: float = MIN_VISIBLE,
    visibility: bool = True, progress: bool = True,
) -> tuple[pd.DataFrame, PairStats]:
    """All valid GT/render box pairs of ``scene`` (docs/FORMATS.md §3).

    Returns the pairs table (columns :data:`PAIRS_OUTPUT_COLUMNS`: the contract columns, the
    five optional perturbation components and the perturbation label; then ``method`` when
    the scene has methods (:mod:`data_schema.methods`; one pair per method render, the method
    ending the pair id); then one column per scene attribute, then ``scene_root``) and the
    :class:`PairStats` (a candidate per method render). A candidate (camera,
    frame, track, render view) invalid in the GT view is counted under the GT view's
    reason, otherwise under the novel view's; novel views are only projected for boxes
    valid in the GT view. The 8-corner and size criteria are the same in every view, and so
    is the visibility rule: at least ``min_visible`` of the object's silhouette is unoccluded
    by the frame's other boxes (:mod:`nvrq.geometry.visibility`) in the GT view and in the novel
    view; a candidate that fails it is counted as ``occluded``. ``min_visible=0`` is the paper's
    protocol. Every pair carries ``gt_visible`` and ``novel_visible``.

    Parameters
    ----------
    scene : Scene
        A validated scene (docs/FORMATS.md §2).
    min_side : float, pixels, optional
        Smallest box side kept, in every view.
    min_area : float, pixels, optional
        Smallest box area kept.
    min_visible : float, 0..1, optional
        Smallest visible fraction kept, in both views (0 keeps every pair: the paper's protocol).
    visibility : bool, optional
        Cast the visibility at all (False: ``gt_visible`` and ``novel_visible`` are NaN, and
        ``min_visible`` must be 0).
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    pairs : pandas.DataFrame
        The pairs table.
    stats : PairStats
    """

    for name, value in (("min_side", min_side), ("min_area", min_area)):
        if not isinstance(value, int | float | np.number) or not np.isfinite(value) or value < 0:
            raise InputError(param=name, expected="a non-negative number of pixels", got=value)
    _check_min_visible(min_visible)
    if not visibility and min_visible > 0:
        raise InputError(param="min_visible", expected="0 when visibility=False (nothing is cast)", got=min_visible)
    stats = PairStats()
    cams = list(scene.cameras.values())
    frames_out = []
    for cam in tqdm(cams, desc="pairs", unit="camera", disable=not progress or len(cams) < 2):
        df = _camera_pairs(scene, cam, stats, min_side=min_side, min_area=min_area, min_visible=min_visible,
                           visibility=visibility)
        if df is not None:
            frames_out.append(df)
    return _assemble(scene, frames_out), stats
