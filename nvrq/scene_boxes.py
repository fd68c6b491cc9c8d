"""The boxes of a scene at its render frames, and the transforms into the GT and novel views.

Layer: nvrq core, geometry (scene boxes). The projection that ``nvrq pairs``
(:mod:`nvrq.pairs`, GT and novel view) and ``nvrq proxy nta-iou``
(:mod:`nvrq.proxies.nta_scene`, novel view alone) share: the same interpolated box poses, the
same rig poses, the same render views and the same (render row, box) candidates, so both
tables see the same boxes.

Convention:
    ``T_a_b`` maps frame ``b`` to frame ``a`` (4 x 4, metres). A view is a rig-frame
    perturbation ``(dx, dy, dz, roll, pitch, yaw)`` in metres and degrees
    (:func:`nvrq.geometry.poses.perturb_T_sensor_rig`); the zero view is the GT camera.
    Frames and render rows are matched by ``timestamp_us`` (int64 microseconds).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

from data_schema.perturbation import perturbation_array
from data_schema.scene import Scene
from nvrq.geometry.boxes import box_corners
from nvrq.geometry.poses import (
    interpolate_poses,
    invert_rigid,
    perturb_T_sensor_rig,
    pose7_to_matrix,
)

__all__ = ["FrameBoxes", "track_boxes_at", "render_views", "frame_boxes", "frame_candidates", "view_transforms"]


class FrameBoxes(NamedTuple):
    """Every box of a scene at some frames (:func:`frame_boxes`).

    Attributes
    ----------
    T_rig_world : (F, 4, 4) float64
        Rig poses (rig -> world) at the F frames; meaningless where ``on_trajectory`` is False.
    on_trajectory : (F,) bool
        Whether each frame lies inside the rig trajectory (frames outside have no boxes).
    track_index : (M,) int64
        Each box's track (index into ``scene.tracks``).
    frame_index : (M,) int64
        Each box's frame (index into the F frames).
    corners : (M, 8, 3) float64
        World corners of each box (metres), in :func:`nvrq.geometry.boxes.box_corners`' order.
    T_box_world : (M, 4, 4) float64
        Each box's centre pose (box -> world).
    dims_lwh : (M, 3) float64
        Each box's length, width, height (metres).
    """

    T_rig_world: np.ndarray
    on_trajectory: np.ndarray
    track_index: np.ndarray
    frame_index: np.ndarray
    corners: np.ndarray
    T_box_world: np.ndarray
    dims_lwh: np.ndarray


def track_boxes_at(scene: Scene, query_us: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Boxes of every track at every query time.

    ``query_us: (F,)`` -> ``(track_index: (M,), frame_index: (M,), T_box_world: (M, 4, 4))`` for
    the M (track, frame) combinations inside the track's own time span (never extrapolated).

    Parameters
    ----------
    scene : Scene
        The scene.
    query_us : (F,) int64, microseconds
        Frame times.

    Returns
    -------
    track_index : (M,) int64
    frame_index : (M,) int64
    T_box_world : (M, 4, 4) float64
        Box-centre poses, box frame to world frame (metres).
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


def render_views(renders: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """The distinct views of some render rows, and each row's view.

    Parameters
    ----------
    renders : pandas.DataFrame
        R rows of a scene's ``images.csv`` with the perturbation columns (``y_offset_m`` and,
        where present, the five others; absent ones are 0).

    Returns
    -------
    views : (K, 6) float64
        The distinct perturbations, the zero view always among them, sorted (a lateral-only
        scene gets its offsets in increasing order).
    view_index : (R,) int64
        Each render row's view (index into ``views``).

    >>> views, k = render_views(pd.DataFrame({"y_offset_m": [2.0, -1.0, 2.0]}))
    >>> views[:, 1].tolist(), k.tolist()
    ([-1.0, 0.0, 2.0], [2, 0, 2])
    """
    P_r = perturbation_array(renders)
    views, inverse = np.unique(np.concatenate([np.zeros((1, 6)), P_r]), axis=0, return_inverse=True)
    return views, np.asarray(inverse).reshape(-1)[1:]


def frame_boxes(scene: Scene, frames: np.ndarray) -> FrameBoxes:
    """The rig poses at ``frames`` and the world corners of every box there.

    A box exists at a frame inside its track's time span (:func:`track_boxes_at`) and inside
    the rig trajectory; frames outside the rig trajectory get no boxes (the caller counts them
    from ``on_trajectory``).

    Parameters
    ----------
    scene : Scene
        The scene.
    frames : (F,) int64, microseconds
        Frame times.

    Returns
    -------
    FrameBoxes
        Rig poses ``(F, 4, 4)``, ``on_trajectory (F,)``, and per box (M of them) its track,
        frame and world corners ``(M, 8, 3)``.
    """
    T_rig_world, on_traj = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, frames)
    tr_i, fr_i, T_box_world = track_boxes_at(scene, frames)
    keep = on_traj[fr_i]
    tr_i, fr_i, T_box_world = tr_i[keep], fr_i[keep], T_box_world[keep]
    dims = np.stack([scene.tracks[k].dims_lwh for k in tr_i]) if len(tr_i) else np.zeros((0, 3))
    return FrameBoxes(T_rig_world, on_traj, tr_i, fr_i, box_corners(T_box_world, dims), T_box_world, dims)


def frame_candidates(renders: pd.DataFrame, frames: np.ndarray,
                     frame_index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every render row paired with every box of its frame.

    Parameters
    ----------
    renders : pandas.DataFrame
        R render rows with ``timestamp_us``, each one of ``frames``.
    frames : (F,) int64, microseconds
        The frame times the boxes were taken at.
    frame_index : (M,) int64
        Each box's frame (index into ``frames``), as :attr:`FrameBoxes.frame_index`.

    Returns
    -------
    row_index : (C,) int64
        The render row of each candidate (index into ``renders``), in row order.
    box_index : (C,) int64
        Its box (index into the M boxes), in box order within a row.

    >>> rows, boxes = frame_candidates(pd.DataFrame({"timestamp_us": [20, 10, 20]}),
    ...                                np.array([10, 20]), np.array([1, 0, 1]))
    >>> rows.tolist(), boxes.tolist()
    ([0, 0, 1, 2, 2], [0, 2, 1, 0, 2])
    """
    frame_pos = {int(t): i for i, t in enumerate(frames)}
    r_frame = np.array([frame_pos[int(t)] for t in renders.timestamp_us], dtype=np.int64)
    order = np.argsort(frame_index, kind="stable")
    starts = np.searchsorted(frame_index[order], np.arange(len(frames) + 1))
    n_per_row = np.diff(starts)[r_frame]
    row_idx = np.repeat(np.arange(len(renders)), n_per_row)
    within = np.arange(len(row_idx)) - np.repeat(np.cumsum(n_per_row) - n_per_row, n_per_row)
    box_idx = order[np.repeat(starts[r_frame], n_per_row) + within]
    return row_idx, box_idx


def view_transforms(T_sensor_rig: np.ndarray, T_rig_world: np.ndarray,
                    views: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World -> GT camera per frame, and GT camera -> novel camera per view.

    The perturbation is rigid in the rig frame, so a point in the GT camera frame goes to view
    ``k``'s camera frame by ``inv(T_sensor'_rig) @ T_sensor_rig``; world -> view ``k`` at frame
    ``f`` is ``T_view_gt[k] @ T_gt_world[f]``.

    Parameters
    ----------
    T_sensor_rig : (4, 4) float64
        The camera's mounting (sensor -> rig).
    T_rig_world : (F, 4, 4) float64
        Rig poses (rig -> world) per frame.
    views : (K, 6) float64
        Perturbations ``(dx, dy, dz, roll, pitch, yaw)``, metres and degrees.

    Returns
    -------
    T_gt_world : (F, 4, 4) float64
        World -> GT camera frame, per frame.
    T_view_gt : (K, 4, 4) float64
        GT camera frame -> view ``k``'s camera frame (the identity for the zero view).

    >>> T_gt_world, T_view_gt = view_transforms(np.eye(4), np.eye(4)[None], np.array([[0, 2.0, 0, 0, 0, 0]]))
    >>> T_view_gt[0, :3, 3].tolist()  # the camera moved 2 m along y: points move -2 m
    [0.0, -2.0, 0.0]
    """
    T_gt_world = invert_rigid(T_rig_world @ T_sensor_rig)
    T_view_gt = invert_rigid(perturb_T_sensor_rig(T_sensor_rig, views)) @ T_sensor_rig
    return T_gt_world, T_view_gt
