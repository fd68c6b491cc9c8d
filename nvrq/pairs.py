"""GT / novel-view box pairs (SPEC section 3; paper sections 3.2 and 5.1).

For every camera, frame and render offset of a scene, every object box is projected
into the GT view (offset 0, the real camera) and into the novel view (the virtual camera
shifted by ``y_offset_m`` in the rig frame, paper Eq. 1-2). A pair is kept when the box is
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

from data_schema.scene import Scene
from data_schema.tables import GT_BOX_COLUMNS, PAIRS_COLUMNS, RENDER_BOX_COLUMNS, pair_id
from nvrq.geometry.boxes import box_corners, box_sides, pixel_box
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.poses import (
    interpolate_poses,
    invert_rigid,
    offset_T_sensor_rig,
    pose7_to_matrix,
)

__all__ = ["DROP_REASONS", "PairStats", "track_boxes_at", "view_validity", "make_pairs"]

#: Why a candidate box (camera, frame, track, render offset) was dropped, in order of precedence.
DROP_REASONS = ("no_gt_image", "unprojectable", "outside_image", "too_small")


@dataclass
class PairStats:
    """Counts of a :func:`make_pairs` run: candidates, kept pairs and drops per reason."""

    candidates: int = 0
    kept: int = 0
    dropped: dict = field(default_factory=lambda: dict.fromkeys(DROP_REASONS, 0))
    frames_outside_trajectory: int = 0

    def summary(self) -> str:
        drops = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in self.dropped.items())
        line = f"{self.kept} pairs kept of {self.candidates} candidate boxes; dropped: {drops}"
        if self.frames_outside_trajectory:
            line += f"; {self.frames_outside_trajectory} frames outside the rig trajectory skipped"
        return line


def track_boxes_at(scene: Scene, query_us: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Boxes of every track at every query time.

    ``query_us: (F,)`` -> ``(track_index: (M,), frame_index: (M,), T_box_world: (M, 4, 4))`` for
    the M (track, frame) combinations inside the track's own time span (never extrapolated).
    """
    q = np.asarray(query_us, dtype=np.int64)
    tr_idx, fr_idx, mats = [], [], []
    for k, track in enumerate(scene.tracks):
        T, ok = interpolate_poses(track.timestamps_us, pose7_to_matrix(track.poses), q)
        idx = np.flatnonzero(ok)
        tr_idx.append(np.full(idx.shape, k))
        fr_idx.append(idx)
        mats.append(T[idx])
    if not mats:
        return np.zeros(0, int), np.zeros(0, int), np.zeros((0, 4, 4))
    return np.concatenate(tr_idx), np.concatenate(fr_idx), np.concatenate(mats)


def view_validity(
    camera, corners_sensor: np.ndarray, *, min_side: float, min_area: float
) -> tuple[np.ndarray, np.ndarray]:
    """Validity of boxes in one or more views.

    ``corners_sensor: (..., 8, 3)`` in the camera frame -> ``(code: (...,) int8, box: (..., 4) int64)``
    with ``code`` 0 = valid, 1 = some corner unprojectable (behind the camera or beyond the
    model's range), 2 = some corner outside the image, 3 = too small. ``box`` is only
    meaningful where ``code == 0``.
    """
    uv, projectable = camera.project(corners_sensor)
    projectable = projectable & np.isfinite(uv).all(axis=-1)
    all_proj = projectable.all(axis=-1)
    uv = np.where(projectable[..., None], uv, 0.0)
    inside = camera.in_image(uv).all(axis=-1)
    box = pixel_box(uv)
    w, h = box_sides(box)
    big = (np.minimum(w, h) >= min_side) & (w * h >= min_area)
    code = np.where(~all_proj, 1, np.where(~inside, 2, np.where(~big, 3, 0))).astype(np.int8)
    return code, box


def make_pairs(
    scene: Scene, *, min_side: float = 30, min_area: float = 0, progress: bool = True
) -> tuple[pd.DataFrame, PairStats]:
    """All valid GT/render box pairs of ``scene`` (SPEC section 3).

    Returns the pairs table (columns :data:`~data_schema.tables.PAIRS_COLUMNS`, then one
    column per scene attribute, then ``scene_root``) and the :class:`PairStats`. A candidate
    (camera, frame, track, render offset) invalid in the GT view is counted under the GT
    view's reason, otherwise under the novel view's; novel views are only projected for
    boxes valid in the GT view.
    """
    stats = PairStats()
    images = scene.images
    frames_out = []
    cams = list(scene.cameras.values())
    for cam in tqdm(cams, desc="pairs", unit="camera", disable=not progress or len(cams) < 2):
        model = camera_from_model(cam.model, where=str(scene.root / "scene.json"),
                                  field_prefix=f"cameras.{cam.name}.model.")
        rows = images[images.camera == cam.name]
        renders = rows[rows.source == "render"]
        if renders.empty:
            continue
        gt_paths = dict(zip(rows.loc[rows.source == "gt", "timestamp_us"], rows.loc[rows.source == "gt", "path"],
                            strict=True))
        frames = np.unique(renders.timestamp_us.to_numpy(np.int64))
        offsets = np.unique(np.concatenate([[0.0], renders.y_offset_m.to_numpy(np.float64)]))
        T_rig_world, on_traj = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, frames)
        stats.frames_outside_trajectory += int((~on_traj).sum())
        tr_i, fr_i, T_box_world = track_boxes_at(scene, frames)
        keep = on_traj[fr_i]
        tr_i, fr_i, T_box_world = tr_i[keep], fr_i[keep], T_box_world[keep]
        dims = np.stack([scene.tracks[k].dims_lwh for k in tr_i]) if len(tr_i) else np.zeros((0, 3))
        corners = box_corners(T_box_world, dims)  # (M, 8, 3) world
        # GT view first: world -> sensor is inv(T_rig_world @ T_sensor_rig), per frame
        T_ws = invert_rigid(T_rig_world @ cam.T_sensor_rig)[fr_i]  # (M, 4, 4)
        corners_gt = np.matmul(corners, np.swapaxes(T_ws[:, :3, :3], 1, 2)) + T_ws[:, None, :3, 3]
        code_gt, box_gt = view_validity(model, corners_gt, min_side=min_side, min_area=min_area)
        # novel views only for boxes valid in the GT view (the others cannot pair). The
        # offset is rigid in the rig frame, so sensor' = inv(T_sensor'_rig) @ T_sensor_rig @ sensor.
        T_sk_s = invert_rigid(offset_T_sensor_rig(cam.T_sensor_rig, offsets)) @ cam.T_sensor_rig  # (K, 4, 4)
        good = np.flatnonzero(code_gt == 0)
        pk = np.matmul(corners_gt[good, None], np.swapaxes(T_sk_s[:, :3, :3], 1, 2)) + T_sk_s[:, None, :3, 3]
        code_n, box_n = view_validity(model, pk, min_side=min_side, min_area=min_area)  # (G, K)
        # code[m, k]: 0 valid in both views, else the failing view's reason (GT view first)
        code = np.repeat(code_gt[:, None], len(offsets), axis=1)
        code[good] = code_n
        box = np.zeros((len(tr_i), len(offsets), 4), np.int64)
        box[good] = box_n
        # candidates: every render image row x every box of its frame
        frame_pos = {int(t): i for i, t in enumerate(frames)}
        r_frame = np.array([frame_pos[int(t)] for t in renders.timestamp_us], dtype=np.int64)
        r_k = np.searchsorted(offsets, renders.y_offset_m.to_numpy(np.float64))
        order = np.argsort(fr_i, kind="stable")
        starts = np.searchsorted(fr_i[order], np.arange(len(frames) + 1))
        counts = np.diff(starts)
        n_per_row = counts[r_frame]
        row_idx = np.repeat(np.arange(len(renders)), n_per_row)
        within = np.arange(len(row_idx)) - np.repeat(np.cumsum(n_per_row) - n_per_row, n_per_row)
        box_idx = order[np.repeat(starts[r_frame], n_per_row) + within]
        k_idx = r_k[row_idx]
        has_gt = np.array([int(t) in gt_paths for t in renders.timestamp_us], dtype=bool)[row_idx]
        worst = code[box_idx, k_idx]
        stats.candidates += len(row_idx)
        stats.dropped["no_gt_image"] += int((~has_gt).sum())
        for reason, c in zip(DROP_REASONS[1:], (1, 2, 3), strict=True):
            stats.dropped[reason] += int(((worst == c) & has_gt).sum())
        ok = has_gt & (worst == 0)
        row_idx, box_idx, k_idx = row_idx[ok], box_idx[ok], k_idx[ok]
        stats.kept += len(row_idx)
        r = renders.iloc[row_idx]
        tracks = scene.tracks
        ts = r.timestamp_us.to_numpy(np.int64)
        off = r.y_offset_m.to_numpy(np.float64)
        tid = np.array([tracks[k].track_id for k in tr_i[box_idx]], dtype=object)
        df = pd.DataFrame({
            "clip_id": scene.clip_id,
            "camera": cam.name,
            "track_id": tid,
            "label_class": np.array([tracks[k].label_class for k in tr_i[box_idx]], dtype=object),
            "timestamp_us": ts,
            "y_offset_m": off,
            "gt_path": [gt_paths[int(t)] for t in ts],
            "render_path": r.path.to_numpy(dtype=object),
        })
        gb, rb = box_gt[box_idx], box[box_idx, k_idx]
        df[list(GT_BOX_COLUMNS)] = gb
        df[list(RENDER_BOX_COLUMNS)] = rb
        df.insert(0, "pair_id", [pair_id(scene.clip_id, cam.name, t, s, o)
                                 for t, s, o in zip(tid, ts, off, strict=True)])
        frames_out.append(df)
    cols = list(PAIRS_COLUMNS) + list(scene.attributes) + ["scene_root"]
    if frames_out:
        pairs = pd.concat(frames_out, ignore_index=True)
    else:
        pairs = pd.DataFrame({c: pd.Series(dtype=object) for c in PAIRS_COLUMNS})
    for k, v in scene.attributes.items():
        pairs[k] = v
    pairs["scene_root"] = str(scene.root.resolve())
    pairs = pairs.loc[:, cols].sort_values(["camera", "timestamp_us", "track_id", "y_offset_m"], kind="stable")
    return pairs.reset_index(drop=True), stats
