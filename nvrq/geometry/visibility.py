"""Visible fraction of each 3D box in a camera view, by ray casting against the frame's boxes.

Layer: nvrq core, geometry.

For every box, rays are cast through a grid of pixel centres covering the box's projected
silhouette (the pixel bounding box of densely sampled projected edges, clipped to the image).
A ray belongs to the silhouette when it enters the box (slab test); it is occluded when it
enters any other box of the same frame nearer along the ray. The visible fraction is the
unoccluded share of the silhouette samples. The silhouette is the projected box itself, not
its 2D rectangle, and it is exact for every camera model because only ``unproject`` and
``project`` are used.

Only boxes that can cover the box are cast against: those nearer at their nearest point than
the box at its farthest, whose projected edges (with a margin of :data:`MARGIN_PX`) overlap
the box's, or that are not wholly projectable (a box beside or behind the camera). A box with
no such neighbour is fully visible without casting a ray. Rays are cast for many boxes at
once, in chunks of about :data:`CHUNK` ray-box tests.

Truncation: only the part of the silhouette inside the image counts (a box half outside the
image and otherwise unoccluded is 1.0). A box with no silhouette pixel in the image is NaN.
"""

from __future__ import annotations

import numpy as np

from nvrq.geometry.boxes import CORNER_SIGNS

__all__ = ["CHUNK", "EDGE_SAMPLES", "GRID", "MARGIN_PX", "pair_visibility", "pixel_rays", "ray_box_entry",
           "visible_fractions"]

#: Samples per box edge used to bound the projected silhouette.
EDGE_SAMPLES = 16
#: Largest number of silhouette samples per image axis (pixel centres when the box is smaller).
GRID = 32
#: Margin (pixels) around an occluder's sampled edges: a curved (fisheye) edge may bulge
#: between its samples.
MARGIN_PX = 2.0
#: Ray-box tests per vectorised chunk (bounds the memory of one step).
CHUNK = 400_000

_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8)
          if np.count_nonzero(CORNER_SIGNS[a] != CORNER_SIGNS[b]) == 1]


def ray_box_entry(rays: np.ndarray, T_box_cam: np.ndarray, dims_lwh: np.ndarray) -> np.ndarray:
    """Entry distance of camera-centre rays into boxes; ``inf`` where a ray misses.

    ``rays: (R, 3)`` unit directions from the camera centre (camera frame); ``T_box_cam:
    (N, 4, 4)``; ``dims_lwh: (N, 3)`` -> ``(N, R)``. A camera inside a box enters it at 0.

    >>> t = ray_box_entry(np.array([[0.0, 0, 1], [1.0, 0, 0]]),
    ...                   _shift(0, 0, 5)[None],
    ...                   np.array([[2.0, 2, 2]]))
    >>> t.tolist()
    [[4.0, inf]]
    """
    return _entry(np.asarray(rays, np.float64)[None], np.asarray(T_box_cam, np.float64)[None],
                  np.asarray(dims_lwh, np.float64)[None])[0]


def _entry(rays: np.ndarray, T: np.ndarray, dims: np.ndarray) -> np.ndarray:
    """Batched slab test: ``rays (B, R, 3)``, ``T (B, C, 4, 4)``, ``dims (B, C, 3)`` -> ``(B, C, R)``."""
    R = T[..., :3, :3]
    o = -np.einsum("bcji,bcj->bci", R, T[..., :3, 3])  # camera centre in each box frame
    d = np.einsum("bcji,brj->bcri", R, rays)  # ray directions in each box frame
    half = 0.5 * dims[:, :, None, :]
    oc = o[:, :, None, :]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t1 = (-half - oc) / d
        t2 = (half - oc) / d
    lo = np.fmin(t1, t2)
    hi = np.fmax(t1, t2)
    # a ray parallel to a slab: inside it -> (-inf, inf), outside -> a miss
    par = d == 0
    if par.any():
        inside = np.broadcast_to(np.abs(oc) <= half, par.shape)
        lo = np.where(par, np.where(inside, -np.inf, np.inf), lo)
        hi = np.where(par, np.where(inside, np.inf, -np.inf), hi)
    tnear = lo.max(axis=-1)
    tfar = hi.min(axis=-1)
    hit = (tnear <= tfar) & (tfar > 0)
    return np.where(hit, np.maximum(tnear, 0.0), np.inf)


def _shift(x, y, z):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def visible_fractions(camera, T_box_cam: np.ndarray, dims_lwh: np.ndarray, *,
                      group: np.ndarray | None = None, only: np.ndarray | None = None,
                      grid: int = GRID, rays: np.ndarray | None = None) -> np.ndarray:
    """Visible fraction (0..1, NaN when not in the image) of each box in one camera view.

    Parameters
    ----------
    camera : CameraModel
        Any model of ``nvrq.geometry.cameras``.
    T_box_cam : (N, 4, 4) float64
        Box centre poses in the camera frame.
    dims_lwh : (N, 3) float64
        Box length, width, height, metres.
    group : (N,) int, optional
        The view each box is seen in (one frame in one camera pose): boxes occlude only boxes
        of their own group. Default: one group (all boxes of one frame; every one occludes).
    only : (N,) bool, optional
        The boxes whose fraction is wanted (the others still occlude; their value is NaN).
        Default: all.
    grid : int
        Largest number of samples per image axis.
    rays : (H, W, 3) float64, optional
        The camera's ray through every pixel centre (:func:`pixel_rays`), when the caller
        has it; computed when many rays are cast.

    Returns
    -------
    (N,) float64

    Convention: a box 10 m ahead covered on its left half by a nearer, wider box gives 0.5.

    >>> from nvrq.geometry.cameras import camera_from_model
    >>> cam = camera_from_model({"type": "pinhole", "resolution": [640, 480],
    ...                          "focal_length": [500, 500], "principal_point": [319.5, 239.5]})
    >>> T = np.stack([_shift(0, 0, 10), _shift(-1, 0, 5)])
    >>> visible_fractions(cam, T, np.array([[2.0, 2, 2], [2.0, 2, 0.2]])).round(2).tolist()
    [0.5, 1.0]
    """
    T = np.asarray(T_box_cam, dtype=np.float64).reshape(-1, 4, 4)
    dims = np.asarray(dims_lwh, dtype=np.float64).reshape(-1, 3)
    n = len(T)
    out = np.full(n, np.nan)
    if n == 0:
        return out
    group = np.zeros(n, np.int64) if group is None else np.asarray(group).reshape(-1)
    want = np.ones(n, bool) if only is None else np.asarray(only, bool).reshape(-1)
    w, h = camera.resolution
    # bound every silhouette by its projected edge samples
    s = np.linspace(0.0, 1.0, EDGE_SAMPLES)
    a = np.array([CORNER_SIGNS[i] for i, _ in _EDGES])
    b = np.array([CORNER_SIGNS[j] for _, j in _EDGES])
    signs = (a[:, None, :] * (1 - s[None, :, None]) + b[:, None, :] * s[None, :, None]).reshape(-1, 3)
    local = signs[None] * (0.5 * dims)[:, None, :]  # (N, E, 3)
    pts = np.einsum("nij,nkj->nki", T[:, :3, :3], local) + T[:, None, :3, 3]
    uv, ok = camera.project(pts)
    ok = ok & np.isfinite(uv).all(axis=-1)
    whole = ok.all(axis=1)
    some = ok.any(axis=1)
    with np.errstate(invalid="ignore"):
        u = np.where(ok, uv[..., 0], np.nan)
        v = np.where(ok, uv[..., 1], np.nan)
        bb = np.full((n, 4), np.nan)
        bb[some] = np.stack([np.nanmin(u[some], 1), np.nanmin(v[some], 1),
                             np.nanmax(u[some], 1), np.nanmax(v[some], 1)], axis=1)
    # the silhouette's pixel box, clipped to the image
    clip = np.stack([np.maximum(np.floor(bb[:, 0]), 0), np.maximum(np.floor(bb[:, 1]), 0),
                     np.minimum(np.ceil(bb[:, 2]), w - 1), np.minimum(np.ceil(bb[:, 3]), h - 1)], axis=1)
    in_img = some & (clip[:, 0] <= clip[:, 2]) & (clip[:, 1] <= clip[:, 3])
    targets = np.flatnonzero(want & in_img)
    if len(targets) == 0:
        return out
    # who may cover whom: nearer at the nearest point, overlapping (or not wholly projectable)
    # nearest point of each box to the camera centre (exact), and its farthest corner
    o = -np.einsum("nji,nj->ni", T[:, :3, :3], T[:, :3, 3])
    near = np.linalg.norm(o - np.clip(o, -0.5 * dims, 0.5 * dims), axis=1)
    far = np.linalg.norm(pts, axis=-1).max(axis=1)
    cand_t, cand_o = _candidates(targets, group, bb, whole, some, near, far)
    counts = np.bincount(cand_t, minlength=n)
    free = targets[counts[targets] == 0]
    out[free] = 1.0
    busy = targets[counts[targets] > 0]
    if len(busy):
        out[busy] = _cast(camera, T, dims, busy, cand_t, cand_o, bb, clip, whole, grid, rays)
    return out


def _candidates(targets, group, bb, whole, some, near, far):
    """(target, occluder) index pairs that need a ray cast, target-major."""
    order = np.argsort(group, kind="stable")
    gs = group[order]
    starts = np.flatnonzero(np.r_[True, gs[1:] != gs[:-1]])
    ends = np.r_[starts[1:], len(gs)]
    is_target = np.zeros(len(group), bool)
    is_target[targets] = True
    tt, oo = [], []
    for s0, s1 in zip(starts, ends, strict=True):
        idx = order[s0:s1]
        ti = idx[is_target[idx]]
        if len(ti) == 0 or len(idx) < 2:
            continue
        oi = idx[some[idx] | ~whole[idx]]
        m = near[oi][None, :] < far[ti][:, None]
        m &= ti[:, None] != oi[None, :]
        with np.errstate(invalid="ignore"):
            lap = ((bb[oi, 0][None] - MARGIN_PX <= bb[ti, 2][:, None]) & (bb[oi, 2][None] + MARGIN_PX >= bb[ti, 0][:, None])
                   & (bb[oi, 1][None] - MARGIN_PX <= bb[ti, 3][:, None]) & (bb[oi, 3][None] + MARGIN_PX >= bb[ti, 1][:, None]))
        m &= lap | ~whole[oi][None, :]
        r, c = np.nonzero(m)
        tt.append(ti[r])
        oo.append(oi[c])
    if not tt:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(tt), np.concatenate(oo)


def _slab(rays: np.ndarray, R: np.ndarray, o: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Entry distance of rays ``(P, 3)`` into one box each (rotation ``R (P, 3, 3)`` box ->
    camera, camera centre in the box frame ``o (P, 3)``, half sizes ``half (P, 3)``); ``inf``
    where a ray misses. float32 arithmetic."""
    d = np.einsum("pji,pj->pi", R, rays)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t1 = (-half - o) / d
        t2 = (half - o) / d
    lo = np.fmin(t1, t2)
    hi = np.fmax(t1, t2)
    par = d == 0
    if par.any():
        inside = np.abs(o) <= half
        lo = np.where(par, np.where(inside, -np.inf, np.inf), lo)
        hi = np.where(par, np.where(inside, np.inf, -np.inf), hi)
    tnear = lo.max(axis=-1)
    tfar = hi.min(axis=-1)
    return np.where((tnear <= tfar) & (tfar > 0), np.maximum(tnear, 0.0), np.inf)


def _chunked_slab(rays, box, R, o, half):
    """:func:`_slab` of ``rays (P, 3)`` against boxes ``box (P,)``, in chunks of :data:`CHUNK`."""
    out = np.empty(len(rays), np.float32)
    for a in range(0, len(rays), CHUNK):
        b = box[a:a + CHUNK]
        out[a:a + CHUNK] = _slab(rays[a:a + CHUNK], R[b], o[b], half[b])
    return out


def _cast(camera, T, dims, busy, cand_t, cand_o, bb, clip, whole, grid, lut):
    """Visible fractions of the ``busy`` boxes, cast against their candidate occluders.

    Each busy box gets a grid of rays over its clipped pixel box (pixel centres, or ``grid``
    evenly spread samples per axis where there are more). Every ray is tested against the box
    itself; against an occluder, only the rays inside the occluder's sampled pixel box (plus
    :data:`MARGIN_PX`; all rays for an occluder not wholly projectable)."""
    lo_u, hi_u, lo_v, hi_v = clip[busy, 0], clip[busy, 2], clip[busy, 1], clip[busy, 3]
    nu = np.minimum(hi_u - lo_u + 1, grid).astype(np.int64)
    nv = np.minimum(hi_v - lo_v + 1, grid).astype(np.int64)
    su = np.where(hi_u - lo_u + 1 <= grid, 1.0, (hi_u - lo_u) / max(grid - 1, 1))
    sv = np.where(hi_v - lo_v + 1 <= grid, 1.0, (hi_v - lo_v) / max(grid - 1, 1))
    size = nu * nv
    off = np.r_[0, np.cumsum(size)]
    owner = np.repeat(np.arange(len(busy)), size)  # target of each ray
    k = np.arange(off[-1]) - off[owner]
    # pixel centres (a subset of the image's pixels when the box has more than grid per axis)
    pu = (lo_u[owner] + np.rint((k % nu[owner]) * su[owner])).astype(np.int64)
    pv = (lo_v[owner] + np.rint((k // nu[owner]) * sv[owner])).astype(np.int64)
    if lut is None and len(pu) > camera.resolution[0] * camera.resolution[1] // 2:
        lut = pixel_rays(camera)
    rays = lut[pv, pu] if lut is not None else camera.unproject(np.stack([pu, pv], axis=1).astype(np.float64))
    good = np.isfinite(rays).all(axis=-1)
    rays = np.where(good[:, None], rays, 0.0).astype(np.float32)
    half = (0.5 * dims).astype(np.float32)
    Rb = T[:, :3, :3].astype(np.float32)
    ob = (-np.einsum("nji,nj->ni", T[:, :3, :3], T[:, :3, 3])).astype(np.float32)
    t_own = np.where(good, _chunked_slab(rays, busy[owner], Rb, ob, half), np.float32(np.inf))
    sil = np.isfinite(t_own)
    # (target, occluder) pairs -> the target's rays inside the occluder's pixel box
    pos = np.searchsorted(busy, cand_t)
    o = cand_o
    u0 = np.where(whole[o], bb[o, 0] - MARGIN_PX, -np.inf)
    u1 = np.where(whole[o], bb[o, 2] + MARGIN_PX, np.inf)
    v0 = np.where(whole[o], bb[o, 1] - MARGIN_PX, -np.inf)
    v1 = np.where(whole[o], bb[o, 3] + MARGIN_PX, np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        iu0 = np.clip(np.ceil((u0 - lo_u[pos]) / su[pos]), 0, nu[pos]).astype(np.int64)
        iu1 = np.clip(np.floor((u1 - lo_u[pos]) / su[pos]) + 1, 0, nu[pos]).astype(np.int64)
        iv0 = np.clip(np.ceil((v0 - lo_v[pos]) / sv[pos]), 0, nv[pos]).astype(np.int64)
        iv1 = np.clip(np.floor((v1 - lo_v[pos]) / sv[pos]) + 1, 0, nv[pos]).astype(np.int64)
    wu = np.maximum(iu1 - iu0, 0)
    wv = np.maximum(iv1 - iv0, 0)
    cnt = wu * wv
    covered = np.zeros(len(rays), bool)
    pairs = np.flatnonzero(cnt > 0)
    # in batches of pairs whose entries fit one chunk
    csum = np.cumsum(cnt[pairs])
    start = 0
    while start < len(pairs):
        stop = max(int(np.searchsorted(csum, (csum[start - 1] if start else 0) + CHUNK, side="right")), start + 1)
        pp = pairs[start:stop]
        c = cnt[pp]
        e_pair = np.repeat(pp, c)
        j = np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c)
        ray = off[pos[e_pair]] + (iv0[e_pair] + j // wu[e_pair]) * nu[pos[e_pair]] + iu0[e_pair] + j % wu[e_pair]
        keep = sil[ray] & ~covered[ray]
        ray, e_pair = ray[keep], e_pair[keep]
        ob_ = o[e_pair]
        t_occ = _slab(rays[ray], Rb[ob_], ob[ob_], half[ob_])
        covered[ray[t_occ < t_own[ray]]] = True
        start = stop
    n_sil = np.bincount(owner, weights=sil, minlength=len(busy))
    n_cov = np.bincount(owner, weights=covered & sil, minlength=len(busy))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n_sil > 0, 1.0 - n_cov / n_sil, np.nan)


def pixel_rays(camera) -> np.ndarray:
    """Unit rays ``(H, W, 3)`` through every pixel centre ``(u, v)`` (``rays[v, u]``); NaN
    where the model has no ray (beyond a fisheye's valid angle).

    >>> from nvrq.geometry.cameras import camera_from_model
    >>> cam = camera_from_model({"type": "pinhole", "resolution": [3, 3], "focal_length": [1, 1],
    ...                          "principal_point": [1, 1]})
    >>> pixel_rays(cam)[1, 1].tolist()
    [0.0, 0.0, 1.0]
    """
    w, h = camera.resolution
    uu, vv = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    return camera.unproject(np.stack([uu, vv], axis=-1))


def pair_visibility(camera, T_gt_world: np.ndarray, T_view_gt: np.ndarray, frame_index: np.ndarray,
                    T_box_world: np.ndarray, dims_lwh: np.ndarray, box_index: np.ndarray,
                    view_index: np.ndarray, *, min_visible: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Visible fractions of candidate pairs in the GT view and in their novel view.

    Every box of a frame occludes the others in that frame, in the GT view and in each novel
    view (boxes that fail the pair criteria too).

    Parameters
    ----------
    camera : CameraModel
        The camera (the novel views use the same model).
    T_gt_world : (F, 4, 4) float64
        World -> GT camera frame, per frame.
    T_view_gt : (K, 4, 4) float64
        GT camera frame -> view ``k``'s camera frame.
    frame_index : (M,) int64
        Each box's frame.
    T_box_world : (M, 4, 4) float64
        Box centre poses (box -> world).
    dims_lwh : (M, 3) float64
        Box sizes (metres).
    box_index, view_index : (C,) int64
        The candidates: a box and the novel view it is paired with.
    min_visible : float, optional
        Candidates less visible than this in the GT view are not cast in the novel view
        (their ``novel_visible`` is NaN).

    Returns
    -------
    gt_visible, novel_visible : (C,) float64
        0..1; NaN where the box has no silhouette pixel in the image.
    """
    box_index = np.asarray(box_index, np.int64)
    view_index = np.asarray(view_index, np.int64)
    fr = np.asarray(frame_index, np.int64)
    if len(box_index) == 0:
        return np.zeros(0), np.zeros(0)
    T_cam = np.matmul(T_gt_world[fr], T_box_world)  # (M, 4, 4) boxes in the GT camera
    need = np.zeros(len(fr), bool)
    need[box_index] = True
    lut = pixel_rays(camera)
    gt = visible_fractions(camera, T_cam, dims_lwh, group=fr, only=need, rays=lut)[box_index]
    nv = np.full(len(box_index), np.nan)
    go = np.flatnonzero(gt >= min_visible) if min_visible > 0 else np.arange(len(box_index))
    if len(go) == 0:
        return gt, nv
    box_index, view_index = box_index[go], view_index[go]
    # novel views: every (frame, view) holding a candidate, with all boxes of that frame
    views = np.unique(np.stack([fr[box_index], view_index], axis=1), axis=0)
    order = np.argsort(fr, kind="stable")
    starts = np.searchsorted(fr[order], np.arange(fr.max() + 2))
    members = [order[starts[f]:starts[f + 1]] for f in views[:, 0]]
    sizes = np.array([len(m) for m in members])
    box_of = np.concatenate(members)
    grp = np.repeat(np.arange(len(views)), sizes)
    T_nv = np.matmul(T_view_gt[views[grp, 1]], T_cam[box_of])
    # position of each candidate in the stacked views: its group's start + the box's rank there
    start_of = np.r_[0, np.cumsum(sizes)[:-1]]
    g_of = np.searchsorted(views[:, 0] * (len(T_view_gt) + 1) + views[:, 1],
                           fr[box_index] * (len(T_view_gt) + 1) + view_index)
    rank = np.empty(len(fr), np.int64)
    rank[order] = np.arange(len(fr)) - starts[fr[order]]
    pos = start_of[g_of] + rank[box_index]
    want = np.zeros(len(box_of), bool)
    want[pos] = True
    nv[go] = visible_fractions(camera, T_nv, dims_lwh[box_of], group=grp, only=want, rays=lut)[pos]
    return gt, nv
