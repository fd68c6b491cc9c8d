"""The viewpoint floor of a real log: pairs of two GT views of one object (``nvrq pairs --floor``,
docs/FORMATS.md §3).

Layer: nvrq core, geometry (floor pairs).

A metric that compares a novel view's crop with the recorded GT crop also scores the change of
viewpoint itself: off the path, a perfect render loses score too. A real log has no perfect
render, but it photographs the same object from many poses. For each novel view of a pairs table
this module looks for another GT view of the same track (another timestamp, or another camera)
whose change of viewpoint from the pair's GT view matches that of the novel view:

- the **viewing direction** of a camera on an object is the direction of the camera centre from
  the box centre, expressed in the box frame (so a moving object is seen from its own frame);
- a change of view is measured by the **angle** between two viewing directions and the
  **distance ratio** (the new distance over the GT view's);
- a GT view ``g`` of the track matches a novel view ``n`` when ``|angle_g - angle_n| <=
  max(ANGLE_TOL_DEG, ANGLE_REL_TOL * angle_n)`` and ``|ln(ratio_g / ratio_n)| <= ln(1 +
  RATIO_TOL)``;
- among the matches, the one seen from the direction closest to the novel view's own (the
  smallest angle between the two viewing directions: a view moved left is matched on the
  object's left, not by its mirror image on the right), then the smallest normalised error
  (the larger of the two errors, each over its tolerance), then the earliest view.

A match gives one ``method = "floor"`` row: the pair's GT crop, and as its "render" the other GT
image (``render_path``, relative to the scene folder as in ``images.csv``) with the object's box
there as ``r_x0..r_y1``. The row keeps the novel view's perturbation (``y_offset_m`` ...), so a
table grouped by view puts the floor beside the renders; ``nvrq score`` scores it unchanged.
The partner view must pass the same box rule as any GT view (:func:`nvrq.pairs.view_validity`).
The recorded view (no perturbation) gets no floor row: a perfect render there is the GT crop
itself.

:func:`floor_rows` builds the rows for a scene and its pairs table, :func:`add_floor` appends them
to the table, and :func:`viewing_geometry` is the geometry both use.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.methods import FLOOR_METHOD, FLOOR_PAIR_COLUMNS, METHOD_COLUMN, method_values
from data_schema.perturbation import EXTRA_PERTURBATION_COLUMNS, LABEL_COLUMN, perturbation_array
from data_schema.scene import Scene
from data_schema.tables import pair_ids
from nvrq.geometry.boxes import box_corners
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.poses import (
    interpolate_poses,
    invert_rigid,
    perturb_T_sensor_rig,
    pose7_to_matrix,
)
from nvrq.scene_boxes import track_boxes_at

__all__ = ["ANGLE_TOL_DEG", "ANGLE_REL_TOL", "RATIO_TOL", "FLOOR_COLUMNS", "FloorStats", "viewing_geometry",
           "check_floor_scene", "gt_views", "floor_rows", "add_floor"]

#: absolute tolerance on the change of viewing angle (degrees)
ANGLE_TOL_DEG = 1.0
#: relative tolerance on the change of viewing angle (share of the novel view's angle)
ANGLE_REL_TOL = 0.15
#: tolerance on the distance ratio: ``|ln(ratio_g / ratio_n)| <= ln(1 + RATIO_TOL)``
RATIO_TOL = 0.10
#: the columns ``--floor`` adds to the pairs table: the novel view's change of viewpoint (every
#: row) and the floor partner's (floor rows; empty on the others)
FLOOR_COLUMNS = FLOOR_PAIR_COLUMNS
#: a (query, candidate) block is at most this many elements (memory bound of the matching)
_BLOCK = 4_000_000


@dataclass
class FloorStats:
    """Counts of a :func:`floor_rows` run.

    Attributes
    ----------
    views : int
        Distinct novel views of the pairs table off the recorded view (camera, frame, track,
        perturbation).
    matched : int
        Those given a floor row.
    gt_views : int
        GT views of the scene's tracks valid for the box rule (the partners to choose from).
    """

    views: int = 0
    matched: int = 0
    gt_views: int = 0

    def summary(self) -> str:
        """One line: how many novel views got a floor pair."""
        return (f"floor: {self.matched} of {self.views} novel views matched by another GT view "
                f"(of {self.gt_views} valid GT views)")


def viewing_geometry(T_box_world: np.ndarray, centres_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Viewing directions and distances of cameras on boxes, in the box frame.

    Parameters
    ----------
    T_box_world : (N, 4, 4) float64
        Box poses (box -> world).
    centres_world : (N, 3) float64
        Camera centres in the world frame (metres).

    Returns
    -------
    direction : (N, 3) float64
        Unit vectors from the box centre to the camera centre, in the box frame.
    distance : (N,) float64
        Distances from the box centre to the camera centre (metres).

    >>> T = np.eye(4)[None].copy(); T[0, :3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # yawed 90 deg
    >>> d, r = viewing_geometry(T, np.array([[0.0, 5.0, 0.0]]))
    >>> np.round(d, 12).tolist(), r.tolist()  # world +y is the box's +x
    ([[1.0, 0.0, 0.0]], [5.0])
    """
    T = np.asarray(T_box_world, np.float64)
    rel = np.asarray(centres_world, np.float64) - T[:, :3, 3]
    local = np.einsum("nji,nj->ni", T[:, :3, :3], rel)  # R^T (c - t)
    dist = np.linalg.norm(local, axis=1)
    return local / np.where(dist > 0, dist, 1.0)[:, None], dist


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (degrees) between unit vectors ``a (..., 3)`` and ``b (..., 3)`` (atan2: exact near 0)."""
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, np.sum(a * b, axis=-1)))


def gt_views(scene: Scene, *, min_side: float, min_area: float) -> pd.DataFrame:
    """Every GT view of every track that passes the box rule, on every camera.

    Parameters
    ----------
    scene : Scene
        A validated scene.
    min_side, min_area : float
        The box rule of ``nvrq pairs`` (pixels).

    Returns
    -------
    pandas.DataFrame
        G rows: ``camera, timestamp_us, track, path, x0, y0, x1, y1`` (``track``: index into
        ``scene.tracks``; the inclusive pixel box) and the geometry ``dx, dy, dz, dist``
        (:func:`viewing_geometry`), in camera, time and track order.
    """
    from nvrq.pairs import view_validity

    out = []
    images = scene.images
    for cam in scene.cameras.values():
        gt = images[(images.camera == cam.name) & (images.source == "gt")]
        if gt.empty:
            continue
        ts = gt.timestamp_us.to_numpy(np.int64)
        T_rig_world, on_traj = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, ts)
        tr_i, fr_i, T_box = track_boxes_at(scene, ts)
        keep = on_traj[fr_i]
        tr_i, fr_i, T_box = tr_i[keep], fr_i[keep], T_box[keep]
        if not len(tr_i):
            continue
        dims = np.stack([scene.tracks[k].dims_lwh for k in tr_i])
        model = camera_from_model(cam.model, where=str(scene.root / "scene.json"),
                                  field_prefix=f"cameras.{cam.name}.model.")
        T_cam_world = T_rig_world @ cam.T_sensor_rig  # camera -> world, per frame
        T_wc = invert_rigid(T_cam_world)[fr_i]
        corners = box_corners(T_box, dims)
        corners_cam = np.matmul(corners, np.swapaxes(T_wc[:, :3, :3], 1, 2)) + T_wc[:, None, :3, 3]
        code, box = view_validity(model, corners_cam, min_side=min_side, min_area=min_area)
        ok = code == 0
        d, r = viewing_geometry(T_box[ok], T_cam_world[fr_i[ok], :3, 3])
        out.append(pd.DataFrame({"camera": cam.name, "timestamp_us": ts[fr_i[ok]], "track": tr_i[ok],
                                 "path": gt.path.to_numpy(dtype=object)[fr_i[ok]],
                                 "x0": box[ok, 0], "y0": box[ok, 1], "x1": box[ok, 2], "y1": box[ok, 3],
                                 "dx": d[:, 0], "dy": d[:, 1], "dz": d[:, 2], "dist": r}))
    if not out:
        return pd.DataFrame(columns=["camera", "timestamp_us", "track", "path", "x0", "y0", "x1", "y1",
                                     "dx", "dy", "dz", "dist"])
    return pd.concat(out, ignore_index=True)


def check_floor_scene(scene: Scene) -> None:
    """A floor needs two GT views of the scene: GT images at two timestamps, or on two cameras.

    Parameters
    ----------
    scene : Scene
        A validated scene.

    Raises
    ------
    InputError
        The scene has fewer than two GT images (camera, timestamp), naming its ``images.csv``.
    """
    gt = scene.images[scene.images.source == "gt"]
    n = len(gt[["camera", "timestamp_us"]].drop_duplicates())
    if n < 2:
        raise InputError(scene.root / "images.csv", None, "GT images at two or more timestamps or on two or "
                         "more cameras for a viewpoint floor (another GT view of each object)",
                         f"{n} GT image{'' if n == 1 else 's'}", param="floor")


def _novel_views(scene: Scene, pairs: pd.DataFrame, views: pd.DataFrame) -> pd.DataFrame:
    """The distinct novel views of ``pairs`` off the recorded view (one per camera, frame, track and
    perturbation, the methods' rows merged), each with its GT view (index into ``views``), and its change of view:
    ``angle`` (degrees) and ``ratio``."""
    track_pos = {t.track_id: k for k, t in enumerate(scene.tracks)}
    p = pairs.loc[method_values(pairs) != FLOOR_METHOD]
    P = perturbation_array(p)
    q = pd.DataFrame({"row": np.arange(len(p)), "camera": p["camera"].astype(str).to_numpy(),
                      "timestamp_us": pd.to_numeric(p["timestamp_us"]).to_numpy(np.int64),
                      "track": p["track_id"].astype(str).map(track_pos).to_numpy()})
    P_cols = [f"p{j}" for j in range(6)]
    q[P_cols] = P
    q = q[(P != 0).any(axis=1)]  # the recorded view's floor is its GT crop itself: no row
    q = q.drop_duplicates(["camera", "timestamp_us", "track", *P_cols]).reset_index(drop=True)
    g = views[["camera", "timestamp_us", "track"]].reset_index().rename(columns={"index": "g0"})
    q = q.merge(g, on=["camera", "timestamp_us", "track"], how="inner")
    if q.empty:
        return q.assign(angle=np.zeros(0), ratio=np.zeros(0), nx=np.zeros(0), ny=np.zeros(0), nz=np.zeros(0))
    angle, ratio, dn = np.zeros(len(q)), np.ones(len(q)), np.zeros((len(q), 3))
    d0 = views[["dx", "dy", "dz"]].to_numpy(np.float64)[q.g0.to_numpy()]
    r0 = views["dist"].to_numpy(np.float64)[q.g0.to_numpy()]
    for cam_name, idx in q.groupby("camera").indices.items():
        cam = scene.cameras[cam_name]
        sub = q.iloc[idx]
        ts = sub.timestamp_us.to_numpy(np.int64)
        T_rig_world, _ = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, ts)
        T_sensor = perturb_T_sensor_rig(cam.T_sensor_rig, sub[P_cols].to_numpy(np.float64))  # (n, 4, 4)
        centres = (T_rig_world @ T_sensor)[:, :3, 3]
        for k, j in pd.Series(np.arange(len(sub))).groupby(sub.track.to_numpy()).indices.items():
            track = scene.tracks[k]
            T_box, _ = interpolate_poses(track.timestamps_us, pose7_to_matrix(track.poses), ts[j])
            d, r = viewing_geometry(T_box, centres[j])
            dn[idx[j]] = d
            angle[idx[j]] = _angle_deg(d, d0[idx[j]])
            ratio[idx[j]] = r / r0[idx[j]]
    return q.assign(angle=angle, ratio=ratio, nx=dn[:, 0], ny=dn[:, 1], nz=dn[:, 2])


def _match(q: pd.DataFrame, views: pd.DataFrame, *, angle_tol: float, angle_rel_tol: float,
           ratio_tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each query, the best partner GT view (index into ``views``, -1 for none), its angle
    (degrees) and distance ratio from the query's GT view."""
    best = np.full(len(q), -1, np.int64)
    b_angle, b_ratio = np.full(len(q), np.nan), np.full(len(q), np.nan)
    D = views[["dx", "dy", "dz"]].to_numpy(np.float64)
    dist = views["dist"].to_numpy(np.float64)
    v_track = views["track"].to_numpy()
    q_track, g0 = q["track"].to_numpy(), q["g0"].to_numpy()
    Dn = q[["nx", "ny", "nz"]].to_numpy(np.float64)
    a_n, lr_n = q["angle"].to_numpy(np.float64), np.log(q["ratio"].to_numpy(np.float64))
    tol_a = np.maximum(angle_tol, angle_rel_tol * a_n)
    tol_r = np.log1p(ratio_tol)
    cand_of = pd.Series(np.arange(len(views))).groupby(v_track).indices
    for k, qi in pd.Series(np.arange(len(q))).groupby(q_track).indices.items():
        cand = cand_of.get(k, np.zeros(0, np.int64))
        if len(cand) < 2:
            continue
        step = max(1, _BLOCK // len(cand))
        for s in range(0, len(qi), step):
            b = qi[s:s + step]
            ang = _angle_deg(D[g0[b]][:, None, :], D[cand][None, :, :])  # (B, C)
            lr = np.log(dist[cand][None, :] / dist[g0[b]][:, None])
            err = np.maximum(np.abs(ang - a_n[b, None]) / tol_a[b, None], np.abs(lr - lr_n[b, None]) / tol_r)
            err[cand[None, :] == g0[b][:, None]] = np.inf  # never the pair's own GT view
            # among the matches, the view closest to the novel view's own direction (its side)
            side = np.where(err <= 1.0, _angle_deg(Dn[b][:, None, :], D[cand][None, :, :]), np.inf)
            j = _best(side, err)
            ok = err[np.arange(len(b)), j] <= 1.0
            best[b[ok]] = cand[j[ok]]
            b_angle[b[ok]] = ang[np.flatnonzero(ok), j[ok]]
            b_ratio[b[ok]] = np.exp(lr[np.flatnonzero(ok), j[ok]])
    return best, b_angle, b_ratio


def _best(side: np.ndarray, err: np.ndarray) -> np.ndarray:
    """Per row of ``(B, C)``, the column of the smallest ``side``, ties broken by ``err`` then order."""
    low = side.min(axis=1, keepdims=True)
    return np.argmin(np.where(side <= low, err, np.inf), axis=1)


def floor_rows(scene: Scene, pairs: pd.DataFrame, *, min_side: float, min_area: float,
               angle_tol: float = ANGLE_TOL_DEG, angle_rel_tol: float = ANGLE_REL_TOL,
               ratio_tol: float = RATIO_TOL) -> tuple[pd.DataFrame, pd.DataFrame, FloorStats]:
    """The floor rows of a scene's pairs table (module docstring).

    Parameters
    ----------
    scene : Scene
        The scene the pairs were made from.
    pairs : pandas.DataFrame
        Its pairs table (:func:`nvrq.pairs.make_pairs`; N rows).
    min_side, min_area : float
        The box rule the pairs were made with (pixels); the partner views follow it too.
    angle_tol, angle_rel_tol, ratio_tol : float, optional
        The tolerances (:data:`ANGLE_TOL_DEG`, :data:`ANGLE_REL_TOL`, :data:`RATIO_TOL`).

    Returns
    -------
    floor : pandas.DataFrame
        One row per matched novel view, with the pairs table's columns (``method = "floor"``;
        columns it has no value for, such as per-view measures of the renders, are empty) and
        :data:`FLOOR_COLUMNS`.
    view_change : pandas.DataFrame
        ``(N, 2)``: ``view_angle_deg`` and ``view_ratio`` of each row of ``pairs`` (the change of
        viewpoint of its novel view: 0 and 1 at the recorded view; NaN where its GT view is not
        found).
    stats : FloorStats

    Raises
    ------
    InputError
        The scene has a single GT image (one timestamp on one camera): there is no other view.
    """
    check_floor_scene(scene)
    views = gt_views(scene, min_side=min_side, min_area=min_area)
    q = _novel_views(scene, pairs, views)
    best, f_angle, f_ratio = _match(q, views, angle_tol=angle_tol, angle_rel_tol=angle_rel_tol,
                                    ratio_tol=ratio_tol)
    stats = FloorStats(views=len(q), matched=int((best >= 0).sum()), gt_views=len(views))
    view_change = _view_change(scene, pairs, q)
    ok = best >= 0
    m = q.loc[ok].reset_index(drop=True)
    src = pairs.loc[method_values(pairs) != FLOOR_METHOD].iloc[m["row"].to_numpy()].reset_index(drop=True)
    partner = views.iloc[best[ok]].reset_index(drop=True)
    floor = src.copy()
    floor[METHOD_COLUMN] = FLOOR_METHOD
    floor["render_path"] = partner["path"].to_numpy(dtype=object)
    for c in ("x0", "y0", "x1", "y1"):
        floor[f"r_{c}"] = partner[c].to_numpy(np.int64)
    for c in floor.columns:  # per-view measures of the render (e.g. its visibility) do not apply
        if c not in _KEPT and c not in scene.attributes and c != METHOD_COLUMN:
            floor[c] = np.nan
    floor["view_angle_deg"] = m["angle"].to_numpy(np.float64)
    floor["view_ratio"] = m["ratio"].to_numpy(np.float64)
    floor["floor_angle_deg"] = f_angle[ok]
    floor["floor_ratio"] = f_ratio[ok]
    floor["pair_id"] = pair_ids(floor, [FLOOR_METHOD] * len(floor))
    return floor, view_change, stats


#: the pairs-table columns a floor row takes from its novel view's pair (the others are empty)
_KEPT = {"pair_id", "clip_id", "camera", "track_id", "label_class", "timestamp_us", "y_offset_m", "gt_path",
         "render_path", "gt_x0", "gt_y0", "gt_x1", "gt_y1", "r_x0", "r_y0", "r_x1", "r_y1",
         *EXTRA_PERTURBATION_COLUMNS, LABEL_COLUMN, "scene_root"}


def _view_change(scene: Scene, pairs: pd.DataFrame, q: pd.DataFrame) -> pd.DataFrame:
    """``view_angle_deg, view_ratio`` of every row of ``pairs`` from the distinct views ``q``."""
    track_pos = {t.track_id: k for k, t in enumerate(scene.tracks)}
    P = perturbation_array(pairs)
    keys = pd.DataFrame({"camera": pairs["camera"].astype(str).to_numpy(),
                         "timestamp_us": pd.to_numeric(pairs["timestamp_us"]).to_numpy(np.int64),
                         "track": pairs["track_id"].astype(str).map(track_pos).to_numpy()})
    P_cols = [f"p{j}" for j in range(6)]
    keys[P_cols] = P
    got = keys.merge(q[["camera", "timestamp_us", "track", *P_cols, "angle", "ratio"]],
                     on=["camera", "timestamp_us", "track", *P_cols], how="left")
    zero = ~(P != 0).any(axis=1)  # the recorded view: no change
    return pd.DataFrame({"view_angle_deg": np.where(zero, 0.0, got["angle"].to_numpy(np.float64)),
                         "view_ratio": np.where(zero, 1.0, got["ratio"].to_numpy(np.float64))}, index=pairs.index)


def add_floor(scene: Scene, pairs: pd.DataFrame, *, min_side: float, min_area: float,
              **tolerances: float) -> tuple[pd.DataFrame, FloorStats]:
    """``pairs`` with its floor rows (:func:`floor_rows`) and :data:`FLOOR_COLUMNS`, in the pairs
    table's order (camera, time, track, view, method).

    Parameters
    ----------
    scene : Scene
        The scene the pairs were made from.
    pairs : pandas.DataFrame
        Its pairs table (N rows).
    min_side, min_area : float
        The box rule the pairs were made with (pixels).
    **tolerances : float
        ``angle_tol``, ``angle_rel_tol``, ``ratio_tol`` of :func:`floor_rows`.

    Returns
    -------
    pairs : pandas.DataFrame
        N + F rows: the pairs (``method`` ``''`` where the scene has no methods) and the F floor
        rows; the columns of ``pairs``, then ``method`` (when new) and :data:`FLOOR_COLUMNS`
        before ``scene_root``.
    stats : FloorStats
    """
    floor, change, stats = floor_rows(scene, pairs, min_side=min_side, min_area=min_area, **tolerances)
    base = pairs.copy()
    if METHOD_COLUMN not in base.columns:
        base[METHOD_COLUMN] = ""
    base[["view_angle_deg", "view_ratio"]] = change.to_numpy()
    base["floor_angle_deg"] = np.nan
    base["floor_ratio"] = np.nan
    cols = [c for c in pairs.columns if c != "scene_root"]
    cols += [c for c in (METHOD_COLUMN, *FLOOR_COLUMNS) if c not in cols]
    cols += ["scene_root"] if "scene_root" in pairs.columns else []
    out = pd.concat([base, floor[base.columns]], ignore_index=True)[cols]
    order = [c for c in ("camera", "timestamp_us", "track_id", "y_offset_m", *EXTRA_PERTURBATION_COLUMNS,
                         METHOD_COLUMN) if c in out.columns]
    return out.sort_values(order, kind="stable").reset_index(drop=True), stats
