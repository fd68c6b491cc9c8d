"""Visible fraction of each 3D box in a camera view, against the other boxes of its frame.

Layer: nvrq core, geometry.

The visible fraction of a box is the share of the pixel centres of its silhouette (the
projected box itself, not its 2D rectangle, clipped to the image) whose ray is not first
entered by another box of the same frame. It is computed in three steps:

1. **Who may cover whom.** An occluder must be nearer at its nearest point than the box at
   its farthest, and their projections must overlap: the boxes in normalised coordinates of
   their parts in front of the camera (found before any occluder is projected), and, where the
   box projects whole, the pixel boxes of the projected outlines (the occluder's, or that of
   its part inside the field of view, step 2). Boxes that cannot be such an occluder by their
   centres alone (wholly behind the near plane, or farther at their nearest point than every
   wanted box of their view at its farthest, bounded by the centre's distance and the half
   diagonal) are set aside first. Only the wanted boxes and the occluders are projected. A box
   with no such neighbour is fully visible. For disjoint boxes the depth order is the same
   along every ray through both (two disjoint convex bodies are separated by a plane: the box
   on the camera's side comes first); an occluder wholly nearer than the box (its farthest
   corner nearer than the box's nearest point) comes first, the other pairs get a
   separating-axis test, and an occluder behind the box is dropped.
2. **Silhouettes as pixel spans.** The silhouette of a box is convex on each image row; its
   span is read off the convex hull of its projected outline (the corners for an undistorted
   pinhole, whose edges stay straight; for a camera whose edges curve, the corners and the
   middle of each silhouette edge, and :data:`OUTLINE_SAMPLES` points along an edge whose
   middle lies farther than ``4 *`` :data:`STRAIGHT_PX`, or :data:`STRAIGHT_SHARE` of its
   length, from the chord of its ends). A pixel
   is covered where it lies inside a drawn occluder, row span by row span:

   - a disjoint occluder in front that projects whole: its silhouette;
   - a disjoint occluder in front that does not (a box beside or behind the camera): its part
     in front of the near plane and inside the field of view, a rectangle of normalised
     coordinates where the model is valid and does not fold, whose border stays outside the
     image (:func:`_field_of_view`); the part's silhouette in normalised coordinates is
     convex (the hull of the vertices of the box cut by five planes), its projection is
     scanned as a polygon (its edges may curve inwards, so a row may hold several spans);
   - an occluder that intersects the box (both projecting whole): the convex pieces, in
     normalised coordinates, where it is entered first (a front face of each, and the side of
     the plane where the occluder's face is nearer, :func:`_entered_first`), scanned likewise.
3. **Rays where needed.** Where an occluder is not drawn (a camera without such a field of
   view: a fisheye whose image holds pixels without a ray; an intersecting box that does not
   project whole), rays through the still uncovered pixels (at most ``4 * grid**2``, evenly
   spread; against an occluder only those its widened silhouette or, not projecting whole,
   its normalised box may hold) are slab-tested against both: the occluder covers a ray it
   enters first. A box that is itself not wholly projected is sampled by a ray grid (at most
   ``grid`` per axis). A pixel's ray is unprojected once, when first asked for, and shared by
   every view of the camera.

Under a threshold (:func:`pair_visibility`'s ``min_visible``, for a caller that drops what
falls below it), a box is only resolved until it is known to be below. Before its spans are
drawn, a bound from rectangles inside its silhouette and its occluders' (:func:`_rect_bound`:
at most ``A + W + H + 1`` pixel centres in a convex silhouette of area ``A`` and bounding box
``W x H``, and at least those of a rectangle inside both covered) may already put it below;
then the share its row spans leave uncovered bounds its fraction from above, so a box below
after step 2 casts no ray, and the rays of step 3 go in :data:`STAGES` interleaved stages,
stopping once the hits so far put it below. A box below gets one of these upper bounds (still
below the threshold); a box at or above it gets the value of a single cast, to the bit. A
novel view at the GT pose itself is the GT view: :func:`pair_visibility` gives it the GT
view's fractions.

Only ``project`` and ``unproject`` of the camera model are used, so it holds for every model
(pinhole, OpenCV, fisheye, f-theta); a dense per-pixel ray cast is the reference in the tests.
Boxes are cut at the near plane ``z = _NEAR`` before they are taken to normalised coordinates
(a ray that meets a box only nearer than 1 mm to the camera's image plane is missed).

Truncation: only the part of the silhouette inside the image counts (a box half outside the
image and otherwise unoccluded is 1.0). A box with no silhouette pixel in the image is NaN.
"""

from __future__ import annotations

import numpy as np

from nvrq.geometry.boxes import CORNER_SIGNS

__all__ = ["CHUNK", "GRID", "MARGIN_PX", "OUTLINE_SAMPLES", "STAGES", "STRAIGHT_PX", "STRAIGHT_SHARE", "pair_visibility", "pixel_rays",
           "ray_box_entry", "visible_fractions"]

#: Samples per box edge of the projected outlines of a camera whose edges curve (distortion);
#: even, so that the edge's middle is one of them.
OUTLINE_SAMPLES = 6
#: Sag (pixels) under which a projected silhouette edge is drawn through its ends and middle
#: alone: an edge whose middle lies within ``4 * STRAIGHT_PX`` of the chord of its ends (about
#: a quarter of that, ``STRAIGHT_PX``, is left between the three points of a smoothly
#: curving edge), and within :data:`STRAIGHT_SHARE` of the chord's length.
STRAIGHT_PX = 0.1
#: Largest sag of such an edge, as a share of its chord (on a small box a tenth of a pixel is
#: a share of its area).
STRAIGHT_SHARE = 0.003
#: Largest number of silhouette samples per image axis (pixel centres when the box is smaller).
GRID = 32
#: Margin (pixels) around an occluder's sampled edges: a curved (fisheye) edge may bulge
#: between its samples.
MARGIN_PX = 2.0
#: Ray-box tests per vectorised chunk (bounds the memory of one step).
CHUNK = 400_000
#: Interleaved stages of the rays cast against hard occluders where only a fraction at or
#: above a threshold (``min_visible``) must be exact: one below it stops at the first stage
#: that proves it.
STAGES = 4

_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8)
          if np.count_nonzero(CORNER_SIGNS[a] != CORNER_SIGNS[b]) == 1]
#: The two faces ``(axis, 0 for the + side or 1 for the - side)`` beside each edge of :data:`_EDGES`.
_EDGE_FACES = np.array([[ax for k in range(3) if CORNER_SIGNS[a][k] == CORNER_SIGNS[b][k]
                         for ax in (k, int(CORNER_SIGNS[a][k] < 0))] for a, b in _EDGES])
#: The near plane ``z = _NEAR`` (metres) where boxes are cut before they are projected to
#: normalised coordinates (no camera model projects a point with ``z <= 0``).
_NEAR = 1e-3
#: Margins (share of its size on each side) tried, smallest first, around the normalised
#: box of the image border's rays, for the field of view of a camera whose edges curve.
_FOV_MARGINS = (0.05, 0.1, 0.2)


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
    d = np.matmul(rays[:, None], R)  # (B, C, R, 3): ray directions in each box frame
    return _slab_entry(o[:, :, None, :], d, 0.5 * dims[:, :, None, :])


def _slab_entry(o: np.ndarray, d: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Entry distance along rays ``d (..., 3)`` from ``o (..., 3)`` into the box of half sizes
    ``half (..., 3)`` (all in the box frame, broadcast together); ``inf`` where a ray misses,
    0 from inside the box."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t1 = (-half - o) / d
        t2 = (half - o) / d
    lo = np.fmin(t1, t2)
    hi = np.fmax(t1, t2)
    # a ray parallel to a slab: inside it -> (-inf, inf), outside -> a miss
    par = d == 0
    if par.any():
        inside = np.broadcast_to(np.abs(o) <= half, par.shape)
        lo = np.where(par, np.where(inside, -np.inf, np.inf), lo)
        hi = np.where(par, np.where(inside, np.inf, -np.inf), hi)
    # over the three slabs (elementwise: a reduction over a length-3 axis is slow)
    tnear = np.maximum(np.maximum(lo[..., 0], lo[..., 1]), lo[..., 2])
    tfar = np.minimum(np.minimum(hi[..., 0], hi[..., 1]), hi[..., 2])
    return np.where((tnear <= tfar) & (tfar > 0), np.maximum(tnear, 0.0), np.inf)


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
    return _visible_fractions(camera, T_box_cam, dims_lwh, group=group, only=only, grid=grid,
                              rays=_Rays(camera, rays))


class _Rays:
    """The camera's rays through pixel centres (:func:`pixel_rays`), unprojected as they are
    asked for (:meth:`at`) and then kept: one camera's views share them, and no pixel is
    unprojected twice. ``rays``: all of them, when the caller has them."""

    def __init__(self, camera, rays: np.ndarray | None = None):
        w, h = camera.resolution
        self.camera, self.width = camera, w
        self.rays = None if rays is None else np.asarray(rays, np.float64).reshape(h * w, 3)
        self.have = None  # (H * W,) bool: the pixels unprojected so far (None: all, or none asked yet)
        self._fov = False  # not found yet

    @property
    def fov(self) -> tuple[float, float, float, float, float] | None:
        """The camera's field of view in normalised coordinates (:func:`_field_of_view`),
        found once."""
        if self._fov is False:
            self._fov = _field_of_view(self.camera)
        return self._fov

    def at(self, pv: np.ndarray, pu: np.ndarray) -> np.ndarray:
        """Rays ``(P, 3)`` through pixels ``(pu, pv)``; a pixel's ray does not depend on the
        others unprojected with it, so the kept rays equal :func:`pixel_rays`'."""
        idx = pv * self.width + pu
        if self.rays is None:
            w, h = self.camera.resolution
            self.rays, self.have = np.empty((h * w, 3)), np.zeros(h * w, bool)  # read only where had
        if self.have is not None:
            miss = np.unique(idx[~self.have[idx]])
            if len(miss):
                uv = np.stack([miss % self.width, miss // self.width], axis=1).astype(np.float64)
                self.rays[miss] = self.camera.unproject(uv)
                self.have[miss] = True
        return self.rays[idx]


def _visible_fractions(camera, T_box_cam, dims_lwh, *, group, only, grid, rays: _Rays, below: float = 0.0) -> np.ndarray:
    """:func:`visible_fractions`, the image's rays (``rays``) shared between calls; a fraction
    found below ``below`` before any ray is cast is left at that upper bound (not cast)."""
    T = np.asarray(T_box_cam, dtype=np.float64).reshape(-1, 4, 4)
    dims = np.asarray(dims_lwh, dtype=np.float64).reshape(-1, 3)
    n, out = len(T), np.full(len(T), np.nan)
    if n == 0:
        return out
    group = np.zeros(n, np.int64) if group is None else np.asarray(group).reshape(-1)
    want = np.ones(n, bool) if only is None else np.asarray(only, bool).reshape(-1)
    # nearest point of each box to the camera centre (exact)
    o = -np.einsum("nji,nj->ni", T[:, :3, :3], T[:, :3, 3])
    near = np.linalg.norm(o - np.clip(o, -0.5 * dims, 0.5 * dims), axis=1)
    may = _may_matter(T, dims, group, want, near)
    if may.all():
        return _fractions_of(camera, (T, dims, near), group, want, (grid, rays, below))
    sub = np.flatnonzero(may)
    out[sub] = _fractions_of(camera, (T[sub], dims[sub], near[sub]), group[sub], want[sub], (grid, rays, below))
    return out


def _may_matter(T: np.ndarray, dims: np.ndarray, group: np.ndarray, want: np.ndarray, near: np.ndarray) -> np.ndarray:
    """``(N,) bool``: the wanted boxes, and those that may cover one: not wholly behind the
    near plane (the centre's depth plus the half diagonal reaches it) and nearer at their
    nearest point ``near`` than a wanted box of their group at its farthest (bounded by its
    centre's distance plus its half diagonal). A superset of every candidate occluder
    (:func:`_candidates`), found without a box's corners; the bounds are widened by 1e-9 of
    themselves against rounding."""
    reach = np.linalg.norm(0.5 * dims, axis=1)
    far = np.linalg.norm(T[:, :3, 3], axis=1) + reach
    _, g = np.unique(group, return_inverse=True)
    g_far = np.full(g.max() + 1, -np.inf)
    np.maximum.at(g_far, g[want], far[want])
    ahead = T[:, 2, 3] + reach * (1 + 1e-9) >= _NEAR
    return want | (ahead & (near < g_far[g] * (1 + 1e-9)))


def _fractions_of(camera, boxes, group: np.ndarray, want: np.ndarray, how) -> np.ndarray:
    """:func:`_visible_fractions` of the boxes ``(T, dims, near)`` that may matter
    (:func:`_may_matter`); ``how``: ``(grid, rays, below)``."""
    T, dims, near = boxes
    grid, rays, below = how
    n, out = len(T), np.full(len(T), np.nan)
    # who may cover whom: nearer at the nearest point, overlapping (or not wholly projectable);
    # the farthest corner of each wanted box
    corners = np.matmul(CORNER_SIGNS[None] * (0.5 * dims)[:, None, :], np.swapaxes(T[:, :3, :3], 1, 2)) \
        + T[:, None, :3, 3]
    wanted = np.flatnonzero(want)
    far = np.full(n, np.nan)
    far[wanted] = np.linalg.norm(corners[wanted], axis=-1).max(axis=1)
    nb = _normalized_boxes(corners)
    cand_t, cand_o = _candidates(wanted, group, near, far, nb)
    # bound every silhouette by its projected outline (corners, or sampled edges that curve):
    # first the wanted boxes', then those of the boxes that may cover one of them
    ol = _Outlines(camera, T, dims)
    in_img = _in_image(ol, corners, want, cand_t)
    targets = np.flatnonzero(want & in_img)
    if len(targets) == 0:
        return out
    keep = in_img[cand_t]
    cand_t, cand_o = cand_t[keep], cand_o[keep]
    rest = np.unique(cand_o[~ol.done[cand_o]])
    ol.add(rest)
    whole = ol.whole
    # wholly projected pairs: their pixel boxes (with a margin for curved edges) overlap too
    bb = ol.bb
    keep = ~(whole[cand_t] & whole[cand_o]) | _overlap(bb[cand_o], bb[cand_t])
    cand_t, cand_o = cand_t[keep], cand_o[keep]
    # depth order: an occluder wholly nearer than the box (its farthest corner nearer than the
    # box's nearest point) comes first along every ray through both; the other pairs by a
    # separating-axis test (an occluder behind the box cannot cover it)
    apart, o_front = _depth_order((T, dims, corners), (near, far), cand_t, cand_o)
    keep = ~apart | o_front
    cand_t, cand_o, apart = cand_t[keep], cand_o[keep], apart[keep]
    # a disjoint occluder in front that does not project whole, of a target that does: its
    # part inside the field of view is drawn too (or covers nothing in the image)
    cut = apart & whole[cand_t] & ~whole[cand_o]
    if cut.any() and rays.fov is not None:
        ol.cut(np.unique(cand_o[cut]), corners, rays.fov)
        keep = ~cut | _overlap(ol.cut_bb[cand_o], bb[cand_t]) | ~ol.cut_done[cand_o]  # none in view (NaN): dropped
        cand_t, cand_o, apart = cand_t[keep], cand_o[keep], apart[keep]
    counts = np.bincount(cand_t, minlength=n)
    out[targets[counts[targets] == 0]] = 1.0
    # wholly projected boxes: their silhouette's pixel centres (raster); the others: ray grids
    busy = targets[counts[targets] > 0]
    ras = busy[whole[busy]]
    ray = busy[~whole[busy]]
    if len(ras):
        sel = np.isin(cand_t, ras)
        out[ras] = _raster((T, dims, nb), ol, ras, (cand_t[sel], cand_o[sel], apart[sel]), rays,
                           (4 * grid * grid, below))
    if len(ray):
        sel = np.isin(cand_t, ray)
        out[ray] = _cast(camera, T, dims, ray, cand_t[sel], cand_o[sel], bb, _reach_clip(ol, ray, corners, rays.fov),
                         whole, grid, rays)
    return out


def _in_image(ol: _Outlines, corners: np.ndarray, want: np.ndarray, cand_t: np.ndarray) -> np.ndarray:
    """``(N,) bool``: the wanted boxes (``want``) with a silhouette pixel box in the image, their
    outlines projected into ``ol``. A wanted box without a candidate occluder (``cand_t``: the
    targets of the candidates) and with a corner (``corners (N, 8, 3)``) well inside the image is
    in it (that corner is a point of its outline), and needs no outline."""
    quiet = want.copy()
    quiet[cand_t] = False
    seen = np.zeros(len(want), bool)
    seen[quiet] = _corner_inside(ol.camera, corners[quiet])
    ol.add(np.flatnonzero(want & ~seen))
    clip = ol.clip()
    return seen | (ol.seen & (clip[:, 0] <= clip[:, 2]) & (clip[:, 1] <= clip[:, 3]))


def _depth_order(boxes, reach, cand_t: np.ndarray, cand_o: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(apart, o_front)`` of the candidate pairs (:func:`_separated`'s) of boxes ``(T, dims,
    corners)`` at distances ``(near, far)`` (``far`` NaN where not found yet, filled here): an
    occluder wholly nearer than its target (its farthest corner nearer than the target's
    nearest point) comes first along every ray through both; the other pairs get a
    separating-axis test."""
    T, dims, corners = boxes
    near, far = reach
    occ = np.unique(cand_o)
    occ = occ[np.isnan(far[occ])]
    far[occ] = np.linalg.norm(corners[occ], axis=-1).max(axis=1)
    test = np.flatnonzero(~(far[cand_o] < near[cand_t]))
    apart, o_front = np.ones(len(cand_t), bool), np.ones(len(cand_t), bool)
    apart[test], o_front[test] = _separated(T, 0.5 * dims, cand_t[test], cand_o[test])
    return apart, o_front


def _reach_clip(ol: _Outlines, boxes: np.ndarray, corners: np.ndarray, fov) -> np.ndarray:
    """Pixel boxes ``(N, 4)`` that hold the silhouettes of the ``boxes`` not wholly projected
    (the others' rows as :meth:`_Outlines.clip`): the pixel box of the outline of their part
    inside the field of view ``fov`` where it has one, the whole image otherwise (the points of
    a box that project do not bound its silhouette: its edges that cross behind the camera run
    off to the image's border)."""
    w, h = ol.camera.resolution
    clip = ol.clip()
    if fov is not None:
        todo = boxes[~ol.cut_done[boxes]]
        if len(todo):
            ol.cut(todo, corners, fov)
        cut = ol.drawn_clip()
        has = ol.cut_done[boxes]
        clip[boxes[has]] = cut[boxes[has]]
        boxes = boxes[~has]
    clip[boxes] = [0, 0, w - 1, h - 1]
    return clip


def _corner_inside(camera, corners: np.ndarray) -> np.ndarray:
    """``(N,) bool``: a corner of each box (``(N, 8, 3)``, camera frame) projects at least half
    a pixel inside the image's pixel centres (a margin against the rounding of another
    computation of the same point)."""
    w, h = camera.resolution
    uv, ok = camera.project(corners.reshape(-1, 3))
    with np.errstate(invalid="ignore"):
        inside = ok & (uv[:, 0] >= 0.5) & (uv[:, 0] <= w - 1.5) & (uv[:, 1] >= 0.5) & (uv[:, 1] <= h - 1.5)
    return inside.reshape(-1, 8).any(axis=1)


def _overlap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether pixel boxes ``a (P, 4)`` (an occluder's, :data:`MARGIN_PX` larger on each side:
    a curved edge may bulge between its samples) and ``b (P, 4)`` overlap; False with NaN."""
    return ((a[:, 0] - MARGIN_PX <= b[:, 2]) & (a[:, 2] + MARGIN_PX >= b[:, 0])
            & (a[:, 1] - MARGIN_PX <= b[:, 3]) & (a[:, 3] + MARGIN_PX >= b[:, 1]))


class _Outlines:
    """The projected outlines of boxes, projected as they are asked for (:meth:`add`)
    (:func:`_project_outlines`): ``seen (N,)`` (a point of the box's outline projects),
    ``all_ok (N,)`` (every point does), the pixel boxes ``bb (N, 4)`` of the points that
    project (NaN where none), ``done (N,)`` and the outline points of the boxes projected
    whole (:meth:`points`); for boxes that do not project whole, the outline of their part
    inside the field of view (:meth:`cut`)."""

    def __init__(self, camera, T: np.ndarray, dims: np.ndarray):
        self.camera, self.T, self.dims = camera, T, dims
        self.samples = 1 if _straight(camera) else OUTLINE_SAMPLES
        self.seen = np.zeros(len(T), bool)
        self.all_ok = np.zeros(len(T), bool)
        self.bb = np.full((len(T), 4), np.nan)
        self.done = np.zeros(len(T), bool)
        self._pts: dict[int, np.ndarray] = {}  # box -> its outline points (K, 2) float32, projected whole
        self.cut_pts: dict[int, np.ndarray] = {}  # box -> its cut outline, a polygon (pixels, in order)
        self.cut_bb = np.full((len(T), 4), np.nan)  # the pixel boxes of those outlines
        self.cut_done = np.zeros(len(T), bool)

    def add(self, sel: np.ndarray) -> None:
        """Project the boxes ``sel``."""
        if len(sel) == 0:
            return
        uv, ok, count = _project_outlines(self.camera, self.T[sel], self.dims[sel], self.samples)
        first = np.r_[0, np.cumsum(count)[:-1]]
        self.done[sel] = True
        self.seen[sel] = np.logical_or.reduceat(ok, first)
        self.all_ok[sel] = np.logical_and.reduceat(ok, first)
        with np.errstate(invalid="ignore"):
            self.bb[sel] = np.c_[np.fmin.reduceat(uv, first), np.fmax.reduceat(uv, first)]
        flat = uv.astype(np.float32)
        for i in np.flatnonzero(self.all_ok[sel]).tolist():
            self._pts[int(sel[i])] = flat[first[i]:first[i] + count[i]]

    @property
    def whole(self) -> np.ndarray:
        """``(N,) bool``: the boxes projected, every outline point of them projectable."""
        return self.all_ok & self.done

    def cut(self, sel: np.ndarray, corners: np.ndarray, fov) -> None:
        """Outline the parts of the boxes ``sel`` (corners ``(N, 8, 3)``, camera frame) inside
        the field of view ``fov`` (:func:`_fov_outlines`); ``cut_done``: where that was done
        (a box with no such part keeps a NaN ``cut_bb``)."""
        pts = _fov_outlines(self.camera, self.T[sel], self.dims[sel], corners[sel], fov)
        done = np.array([p is not None for p in pts], bool)
        self.cut_done[sel] = done
        has = [i for i, p in enumerate(pts) if p is not None and len(p)]
        if has:
            self.cut_pts.update((int(sel[i]), pts[i]) for i in has)
            flat = np.concatenate([pts[i] for i in has])
            at = np.cumsum([0] + [len(pts[i]) for i in has])[:-1]
            self.cut_bb[sel[has]] = np.c_[np.minimum.reduceat(flat, at), np.maximum.reduceat(flat, at)]

    def drawn(self) -> np.ndarray:
        """``(N,) bool``: the boxes with a whole outline or one cut to the field of view."""
        return self.whole | np.isfinite(self.cut_bb[:, 0])

    def points(self, boxes: np.ndarray) -> list[np.ndarray]:
        """The outline points ``(K, 2)`` float32 of each of ``boxes`` (projected whole)."""
        return [self._pts[b] for b in boxes.tolist()]

    def clip(self, bb: np.ndarray | None = None) -> np.ndarray:
        """The silhouettes' pixel boxes ``(N, 4)`` (default ``bb``), clipped to the image."""
        w, h = self.camera.resolution
        bb = self.bb if bb is None else bb
        return np.stack([np.maximum(np.floor(bb[:, 0]), 0), np.maximum(np.floor(bb[:, 1]), 0),
                         np.minimum(np.ceil(bb[:, 2]), w - 1), np.minimum(np.ceil(bb[:, 3]), h - 1)], axis=1)

    def drawn_clip(self) -> np.ndarray:
        """:meth:`clip` of the drawn boxes' outlines (the cut one where a box has it)."""
        return self.clip(np.where(np.isfinite(self.cut_bb[:, :1]), self.cut_bb, self.bb))


def _field_of_view(camera) -> tuple[float, float, float, float, float] | None:
    """A rectangle ``x0, y0, x1, y1`` of normalised coordinates ``(x / z, y / z)`` holding the
    ray of every pixel centre, and the longest step between outline samples along a straight
    line in it (``inf`` for an undistorted pinhole, whose lines stay straight), such that the
    camera projects the whole rectangle (it lies where the model is valid and does not fold)
    and its border, sampled at that step, stays outside the image: a polygon clipped to it
    and projected keeps every pixel centre of the unclipped silhouette. ``None`` where no
    such rectangle is found (a pixel without a ray: a fisheye's border); the boxes that do
    not project whole are then ray-cast.

    >>> from nvrq.geometry.cameras import camera_from_model
    >>> cam = camera_from_model({"type": "pinhole", "resolution": [5, 3], "focal_length": [1, 1],
    ...                          "principal_point": [2, 1]})
    >>> _field_of_view(cam)
    (-3.5, -2.5, 3.5, 2.5, inf)
    """
    w, h = camera.resolution
    if _straight(camera):  # the image rectangle, 1 pixel larger on each side
        (fx, fy), (cx, cy) = camera.focal_length, camera.principal_point
        return (float((-1.5 - cx) / fx), float((-1.5 - cy) / fy), float((w + 0.5 - cx) / fx),
                float((h + 0.5 - cy) / fy), float("inf"))
    u, v = np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64)
    border = np.concatenate([np.stack([u, np.zeros(w)], 1), np.stack([u, np.full(w, h - 1.0)], 1),
                             np.stack([np.zeros(h), v], 1), np.stack([np.full(h, w - 1.0), v], 1)])
    r = camera.unproject(border)
    if not (np.isfinite(r).all() and (r[:, 2] > 0).all()):
        return None
    xy = r[:, :2] / r[:, 2:]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    fine = np.linspace(0.0, 1.0, 1025)[:, None]
    for m in _FOV_MARGINS:
        x0, y0 = lo - m * (hi - lo)
        x1, y1 = hi + m * (hi - lo)
        step = min(x1 - x0, y1 - y0) / 16
        sides = [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]
        ok, out, sag = True, np.inf, 0.0
        for a, b in sides:
            a, b = np.array(a), np.array(b)
            pts = a + fine * (b - a)
            uv, good = camera.project(np.c_[pts, np.ones(len(pts))])
            if not good.all():
                ok = False
                break
            # how far outside the image (pixel centres' rectangle, half a pixel larger)
            dist = np.max([-0.5 - uv[:, 0], uv[:, 0] - (w - 0.5), -0.5 - uv[:, 1], uv[:, 1] - (h - 0.5)], axis=0)
            out = min(out, dist.min())
            k = max(2, 2 * int(step / np.hypot(*(b - a)) * (len(fine) - 1) / 2))  # fine samples per step
            sag = max(sag, np.hypot(*(uv[k // 2:len(uv) - k // 2] - 0.5 * (uv[:-k] + uv[k:])).T).max())
        if ok and out > sag + 1.0:
            return float(x0), float(y0), float(x1), float(y1), float(step)
    return None


def _fov_outlines(camera, T: np.ndarray, dims: np.ndarray, corners: np.ndarray, fov) -> list[np.ndarray]:
    """The outlines (pixels, ``(K, 2)`` float32 each; empty where none, ``None`` where a point
    did not project) of the parts of boxes
    inside the field of view ``fov`` (:func:`_field_of_view`) and in front of ``z = _NEAR``.

    That part is a convex polyhedron (the box cut by five planes: the near plane and the
    four through the camera centre and the rectangle's sides), and its silhouette in
    normalised coordinates is the convex hull of its vertices: the box corners inside the
    five half-spaces, the points where box edges cross one of the planes, and those where the
    lines of two planes (the rectangle's corner rays, its sides on the near plane) enter and
    leave the box; a vertex of the planes alone (a corner ray on the near plane, inside the box)
    sees the same ray leave the box. For a camera whose edges curve, the hull's edges are
    sampled (at most ``fov``'s step apart, :data:`OUTLINE_SAMPLES` per edge at least) and
    projected; every point projected lies inside the rectangle."""
    x0, y0, x1, y1, step = fov
    n_pl = np.array([[0.0, 0, 1], [1, 0, -x0], [-1, 0, x1], [0, 1, -y0], [0, -1, y1]])
    c_pl = np.array([_NEAR, 0, 0, 0, 0])
    a = corners[:, [i for i, _ in _EDGES]]
    b = corners[:, [j for _, j in _EDGES]]
    sa, sb = a @ n_pl.T - c_pl, b @ n_pl.T - c_pl  # (N, 12, 5)
    cross = sa * sb < 0
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(cross, sa / np.where(cross, sa - sb, 1.0), np.nan)
    on_edges = a[:, :, None] + t[..., None] * (b - a)[:, :, None]  # (N, 12, 5, 3)
    # the lines of two planes: origin and direction
    p0 = np.array([[0.0, 0, 0]] * 4 + [[x0 * _NEAR, 0, _NEAR], [x1 * _NEAR, 0, _NEAR],
                                       [0, y0 * _NEAR, _NEAR], [0, y1 * _NEAR, _NEAR]])
    d = np.array([[x0, y0, 1.0], [x1, y0, 1], [x1, y1, 1], [x0, y1, 1], [0, 1, 0], [0, 1, 0], [1, 0, 0], [1, 0, 0]])
    R = T[:, :3, :3]
    o = np.einsum("nji,nlj->nli", R, p0[None] - T[:, None, :3, 3])  # (N, 8, 3) in the box frames
    dl = np.einsum("nji,lj->nli", R, d)
    half = 0.5 * dims[:, None, :]
    with np.errstate(invalid="ignore", divide="ignore"):
        t1, t2 = (-half - o) / dl, (half - o) / dl
    par = dl == 0
    inside = np.abs(o) <= half
    lo = np.where(par, np.where(inside, -np.inf, np.inf), np.fmin(t1, t2)).max(axis=-1)
    hi = np.where(par, np.where(inside, np.inf, -np.inf), np.fmax(t1, t2)).min(axis=-1)
    meet = np.isfinite(lo) & np.isfinite(hi) & (lo <= hi)
    tl = np.where(meet[..., None], np.stack([lo, hi], axis=-1), np.nan)  # (N, 8, 2)
    on_lines = p0[None, :, None] + tl[..., None] * d[None, :, None]  # (N, 8, 2, 3)
    pts = np.concatenate([corners, on_edges.reshape(len(T), -1, 3), on_lines.reshape(len(T), -1, 3)], axis=1)
    tol = 1e-9 * (1.0 + np.abs(pts).max(axis=-1, initial=0.0, where=np.isfinite(pts)))
    with np.errstate(invalid="ignore"):
        good = np.isfinite(pts).all(axis=-1) & (pts @ n_pl.T - c_pl >= -tol[..., None]).all(axis=-1)
    xy = np.zeros(pts.shape[:2] + (2,))
    xy[good] = pts[good][:, :2] / pts[good][:, 2:]
    xy[..., 0] = np.clip(xy[..., 0], x0, x1)
    xy[..., 1] = np.clip(xy[..., 1], y0, y1)
    import cv2

    # the hull in normalised coordinates, its edges sampled where they curve in the image
    hulls = [cv2.convexHull(xy[i][good[i]].astype(np.float32)).reshape(-1, 2).astype(np.float64)
             if good[i].any() else np.zeros((0, 2)) for i in range(len(T))]
    ne = np.array([len(hh) for hh in hulls], np.int64)
    if not ne.sum():
        return [np.zeros((0, 2)) for _ in hulls]
    return _project_polygons(camera, hulls, step)


def _project_polygons(camera, polys: list[np.ndarray], step: float) -> list[np.ndarray | None]:
    """Closed polygons ``(K, 2)`` in normalised coordinates, in order, projected to pixels:
    their vertices, and for a camera whose edges curve (a finite ``step``) points along each
    edge at most ``step`` apart (:data:`OUTLINE_SAMPLES` per edge at least); ``None`` for a
    polygon with a point that does not project (not expected inside the field of view)."""
    ne = np.array([len(hh) for hh in polys], np.int64)
    if not ne.sum():
        return [np.zeros((0, 2)) for _ in polys]
    p = np.concatenate(polys)
    q = np.concatenate([np.roll(hh, -1, axis=0) for hh in polys])
    ns = np.ones(len(p), np.int64) if not np.isfinite(step) else \
        np.maximum(np.ceil(np.hypot(*(q - p).T) / step), OUTLINE_SAMPLES).astype(np.int64)
    e = np.repeat(np.arange(len(p)), ns)
    f = (np.arange(ns.sum()) - np.repeat(np.cumsum(ns) - ns, ns)) / ns[e]
    flat = p[e] + f[:, None] * (q - p)[e]
    uv, ok = camera.project(np.c_[flat, np.ones(len(flat))])
    split = np.cumsum(np.bincount(np.repeat(np.arange(len(polys)), ne), weights=ns,
                                  minlength=len(polys)).astype(np.int64))[:-1]
    bad = np.bincount(np.repeat(np.arange(len(polys)), np.diff(np.r_[0, split, len(uv)])), weights=~ok,
                      minlength=len(polys))
    return [None if b else u for u, b in zip(np.split(uv, split), bad, strict=True)]


#: Each face of a box ``(axis, sign)`` and its corners in the box frame's signs, in order.
_FACES = [(a, s, np.array([[s if i == a else (c0 if i == (a + 1) % 3 else c1) for i in range(3)]
                           for c0, c1 in ((1, 1), (1, -1), (-1, -1), (-1, 1))], np.float64))
          for a in range(3) for s in (1.0, -1.0)]


def _front_faces(T: np.ndarray, half: np.ndarray):
    """The faces of boxes (wholly in front of the camera) that face the camera: ``front (N,
    6)``, their corners in normalised coordinates ``(N, 6, 4, 2)`` and their planes ``n . p =
    d`` in the camera frame, ``n (N, 6, 3)`` (outwards) and ``d (N, 6)``."""
    R, c = T[:, :3, :3], T[:, :3, 3]
    o = -np.einsum("nji,nj->ni", R, c)  # the camera in the box frames
    front = np.stack([s * o[:, a] > half[:, a] for a, s, _ in _FACES], axis=1)
    quad = np.stack([np.einsum("nij,nkj->nki", R, sq[None] * half[:, None]) for _, _, sq in _FACES], axis=1) \
        + c[:, None, None]
    n = np.stack([s * R[:, :, a] for a, s, _ in _FACES], axis=1)
    d = np.einsum("nfi,nfi->nf", n, c[:, None] + n * np.stack([half[:, a] for a, _, _ in _FACES], axis=1)[..., None])
    return front, quad[..., :2] / quad[..., 2:], n, d


def _clip_half_planes(P: np.ndarray, n: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Convex polygons ``P (M, K, 2)`` (the first ``n (M,)`` vertices, in order) cut to the
    half-planes ``H (M, 3)``: ``a x + b y + c <= 0`` -> ``(M, K + 1, 2)`` and the new counts.

    >>> sq = np.array([[[0.0, 0], [2, 0], [2, 2], [0, 2]]])
    >>> P, n = _clip_half_planes(sq, np.array([4]), np.array([[1.0, 0, -1]]))  # x <= 1
    >>> P[0, :n[0]].tolist()
    [[0.0, 0.0], [1.0, 0.0], [1.0, 2.0], [0.0, 2.0]]
    """
    M, K = P.shape[:2]
    i = np.arange(K)[None]
    valid = i < n[:, None]
    nxt = np.where(i + 1 < n[:, None], i + 1, 0)
    Q = np.take_along_axis(P, nxt[..., None], axis=1)
    s = P[..., 0] * H[:, :1] + P[..., 1] * H[:, 1:2] + H[:, 2:]
    sq = np.take_along_axis(s, nxt, axis=1)
    cross = valid & ((s <= 0) != (sq <= 0))
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(cross, s / np.where(cross, s - sq, 1.0), 0.0)
    out = np.stack([P, P + t[..., None] * (Q - P)], axis=2).reshape(M, 2 * K, 2)
    ok = np.stack([valid & (s <= 0), cross], axis=2).reshape(M, 2 * K)
    order = np.argsort(~ok, axis=1, kind="stable")
    return np.take_along_axis(out, order[..., None], axis=1)[:, :K + 1], ok.sum(axis=1)


def _entered_first(T: np.ndarray, half: np.ndarray, t: np.ndarray, o: np.ndarray):
    """Where the rays enter box ``o[p]`` before box ``t[p]`` (intersecting boxes, both wholly
    in front of the camera), in normalised coordinates: convex pieces, one for each front face
    ``f`` of ``t`` and ``g`` of ``o`` (a ray through a silhouette enters its box at the front
    face whose projection holds it): the projections of both faces, less the side where ``f``
    is nearer (a ray ``X = (x, y, 1)`` meets the plane ``n . p = d`` at depth
    ``d / (n . X)``, so ``g`` is nearer where ``(d_g n_f - d_f n_g) . X < 0``). Returns the
    pieces ``(M, 9, 2)``, their vertex counts and their pairs."""
    some, inv = np.unique(np.r_[t, o], return_inverse=True)
    front, quad, n, d = _front_faces(T[some], half[some])
    t, o = inv[:len(t)], inv[len(t):]
    pf, ff, gg = np.nonzero(front[t][:, :, None] & front[o][:, None, :])
    P, cnt = quad[t[pf], ff], np.full(len(pf), 4)
    Gq = quad[o[pf], gg]
    area = np.sum(Gq[:, :, 0] * np.roll(Gq[:, :, 1], -1, 1) - np.roll(Gq[:, :, 0], -1, 1) * Gq[:, :, 1], axis=1)
    sign = np.sign(area)
    for k in range(4):  # inside face g's projection: left of each edge (its orientation's side)
        a, b = Gq[:, k], Gq[:, (k + 1) % 4]
        e = b - a
        H = -sign[:, None] * np.stack([-e[:, 1], e[:, 0], e[:, 1] * a[:, 0] - e[:, 0] * a[:, 1]], axis=1)
        P, cnt = _clip_half_planes(P, cnt, H)
    P, cnt = _clip_half_planes(P, cnt, d[o[pf], gg][:, None] * n[t[pf], ff] - d[t[pf], ff][:, None] * n[o[pf], gg])
    keep = (cnt >= 3) & (sign != 0)
    return P[keep], cnt[keep], pf[keep]


def _scan_spans(polys: list[np.ndarray], v0: np.ndarray, v1: np.ndarray):
    """Row spans of closed polygons ``(K, 2)`` (pixels, in order, not necessarily convex) on
    their rows ``v0 .. v1``: the pixel centres inside (even-odd rule; an edge meets the rows
    from its lower end, included, to its upper end, excluded). A row may hold several
    intervals: layer ``k`` of a polygon holds the ``k``-th interval of each of its rows.
    Returns ``(owner, first row, offsets, lo, hi)`` of the layers (:func:`_box_spans`'s
    layout, ``owner``: each layer's polygon, ascending).

    >>> u = np.array([[1.0, 0], [7, 0], [7, 4], [5, 4], [5, 1], [3, 1], [3, 4], [1, 4]])  # a U
    >>> owner, first, off, lo, hi = _scan_spans([u], np.array([0]), np.array([4]))
    >>> owner.tolist(), off.tolist()
    ([0, 0], [0, 5, 10])
    >>> lo.tolist(), hi.tolist()  # rows 0..4 of the first layer, then of the second
    ([1.0, 1.0, 1.0, 1.0, inf, inf, 5.0, 5.0, 5.0, inf], [7.0, 3.0, 3.0, 3.0, -inf, -inf, 7.0, 7.0, 7.0, -inf])
    """
    ne = np.array([len(p) for p in polys], np.int64)
    v0, v1 = np.asarray(v0).astype(np.int64), np.asarray(v1).astype(np.int64)
    p = np.concatenate(polys) if len(polys) else np.zeros((0, 2))
    nxt = np.arange(1, len(p) + 1)
    nxt[np.cumsum(ne)[ne > 0] - 1] = (np.cumsum(ne) - ne)[ne > 0]
    q = p[nxt]
    e_poly = np.repeat(np.arange(len(polys)), ne)
    r0 = np.maximum(np.ceil(np.minimum(p[:, 1], q[:, 1])), v0[e_poly]).astype(np.int64)
    r1 = np.minimum(np.ceil(np.maximum(p[:, 1], q[:, 1])) - 1, v1[e_poly]).astype(np.int64)
    cnt = np.maximum(r1 - r0 + 1, 0)
    e = np.repeat(np.arange(len(p)), cnt)
    v = r0[e] + np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    x = p[e, 0] + (v - p[e, 1]) * (q[e, 0] - p[e, 0]) / (q[e, 1] - p[e, 1])
    poly = e_poly[e]
    order = np.lexsort((x, v, poly))
    poly, v, x = poly[order], v[order], x[order]
    new = np.r_[True, (poly[1:] != poly[:-1]) | (v[1:] != v[:-1])] if len(v) else np.zeros(0, bool)
    grp = np.cumsum(new) - 1
    head = np.flatnonzero(new)
    rank = np.arange(len(v)) - head[grp]
    size = np.diff(np.r_[head, len(v)])
    s = np.flatnonzero((rank % 2 == 0) & (rank + 1 < size[grp]))  # each interval's left end
    layer = rank[s] // 2
    n_layer = np.zeros(len(polys), np.int64)
    np.maximum.at(n_layer, poly[s], layer + 1)
    owner = np.repeat(np.arange(len(polys)), n_layer)
    ent_first = np.cumsum(n_layer) - n_layer
    nrow = np.maximum(v1 - v0 + 1, 0)[owner]
    off = np.r_[0, np.cumsum(nrow)]
    lo, hi = np.full(off[-1], np.inf), np.full(off[-1], -np.inf)
    pos = off[ent_first[poly[s]] + layer] + v[s] - v0[poly[s]]
    lo[pos] = np.ceil(x[s] - 1e-9)
    hi[pos] = np.floor(x[s + 1] + 1e-9)
    return owner, v0[owner], off, lo, hi


def _straight(camera) -> bool:
    """An undistorted pinhole: the projected edges of a box stay straight."""
    from nvrq.geometry.cameras.pinhole import PinholeCamera

    return type(camera) is PinholeCamera


def _project_outlines(camera, T: np.ndarray, dims: np.ndarray, samples: int):
    """Projected outline points of the boxes (:func:`_outline_local`: corners alone for an
    undistorted pinhole, whose edges stay straight; up to ``samples`` points per edge
    otherwise), box by box: ``uv (P, 2)`` (NaN where a point does not project), which points
    projected ``(P,)`` and each box's number of points ``(N,)``.

    Of a box wholly in front of the camera only its corners and the points of its silhouette
    edges (those between a face that faces the camera and one that does not, or one seen
    edge-on) are projected: the others lie inside its silhouette. Of such an edge, only its
    middle where that lies within ``4 *`` :data:`STRAIGHT_PX` of the chord of its ends and
    within :data:`STRAIGHT_SHARE` of the chord's length."""
    local = _outline_local(samples)  # (K, 3)
    half = 0.5 * dims
    R = T[:, :3, :3]
    pick = np.ones((len(T), len(local)), bool)
    if samples > 1:
        o = -np.einsum("nji,nj->ni", R, T[:, :3, 3])  # the camera in the box frames
        corners_z = np.einsum("nj,nkj->nk", R[:, 2], CORNER_SIGNS[None] * half[:, None]) + T[:, None, 2, 3]
        # facing: +1 the face faces the camera, -1 it does not, 0 edge-on (or too near to tell)
        gap = np.stack([o - half, -o - half], axis=-1)  # (N, 3, 2): sign s = +1, -1
        facing = np.where(np.abs(gap) <= 1e-9 * (1 + np.abs(o)[..., None]), 0, np.sign(gap))
        f1 = facing[:, _EDGE_FACES[:, 0], _EDGE_FACES[:, 1]]
        f2 = facing[:, _EDGE_FACES[:, 2], _EDGE_FACES[:, 3]]
        rim = (f1 != f2) | (f1 == 0) | (f2 == 0)  # (N, 12)
        front = (corners_z > 0).all(axis=1)
        rim |= ~front[:, None]
        pick[:, 8:] = np.repeat(rim, samples - 1, axis=1)
    # the box's axes scaled to its half sizes: a point of signs s lies at centre + axes @ s
    frame = (T[:, :3, 3], R * half[:, None, :], local)
    uv = np.full((len(T), len(local), 2), np.nan)
    ok = np.zeros(uv.shape[:2], bool)
    if samples > 1:
        # first the corners and the middle sample of each edge; a rim edge of a box in front
        # whose middle lies near the chord of its ends keeps that one sample (it curves too
        # little for more), the others get every sample
        mid = 8 + np.arange(12) * (samples - 1) + (samples - 1) // 2
        first = np.zeros_like(pick)
        first[:, :8] = True
        first[:, mid] = rim
        first[~front] = pick[~front]
        _project_at(camera, frame, first, (uv, ok))
        a, b, m = uv[:, [i for i, _ in _EDGES]], uv[:, [j for _, j in _EDGES]], uv[:, mid]
        chord = b - a
        length = np.hypot(chord[..., 0], chord[..., 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            sag = np.abs(chord[..., 0] * (m - a)[..., 1] - chord[..., 1] * (m - a)[..., 0]) / np.maximum(length, 1e-12)
        curved = rim & front[:, None] & ~(sag <= np.minimum(4 * STRAIGHT_PX, STRAIGHT_SHARE * length))  # NaN: curved
        pick = first.copy()
        pick[:, 8:] |= np.repeat(curved, samples - 1, axis=1)
        _project_at(camera, frame, pick & ~first, (uv, ok))
    else:
        _project_at(camera, frame, pick, (uv, ok))
    uv, ok = uv[pick], ok[pick]
    ok &= np.isfinite(uv[:, 0]) & np.isfinite(uv[:, 1])
    return np.where(ok[:, None], uv, np.nan), ok, pick.sum(axis=1)


def _project_at(camera, frame, pick: np.ndarray, into) -> None:
    """Project the outline points ``pick`` (``(N, K)`` bool) of boxes ``frame = (centres (N,
    3), axes (N, 3, 3) scaled to the half sizes, local signs (K, 3))`` into ``(uv, ok)``."""
    centre, axes, local = frame
    uv, ok = into
    at = np.flatnonzero(pick)
    if len(at):
        box, k = np.divmod(at, local.shape[0])
        s, ax = local[k], axes[box]
        pts = centre[box] + s[:, :1] * ax[:, :, 0] + s[:, 1:2] * ax[:, :, 1] + s[:, 2:] * ax[:, :, 2]
        uv.reshape(-1, 2)[at], ok.reshape(-1)[at] = camera.project(pts)


def _normalized_boxes(corners: np.ndarray) -> np.ndarray:
    """Bounding boxes ``(N, 4)`` of each box's part in front of the camera (``z >= eps``), in
    normalised image coordinates ``(x / z, y / z)``, from its corners ``(N, 8, 3)`` (camera
    frame); NaN for a box wholly behind. Every pixel's ray has ``z > 0`` (the camera models
    project nothing else), and a convex body in front of the camera maps to the convex hull of
    its vertices, so the box of the clipped vertices (corners in front, and edges cut at
    ``z = eps``) bounds every ray that can enter it."""
    eps = _NEAR
    out = np.full((len(corners), 4), np.nan)
    ahead = corners[..., 2] >= eps
    front = ahead.all(axis=1)  # wholly in front: the box of its corners
    c = corners[front]
    x, y = c[..., 0] / c[..., 2], c[..., 1] / c[..., 2]
    out[front] = np.c_[x.min(1), y.min(1), x.max(1), y.max(1)]
    part = ~front & ahead.any(axis=1)  # partly in front (wholly behind: NaN)
    c = corners[part]
    a = c[:, [i for i, _ in _EDGES]]
    b = c[:, [j for _, j in _EDGES]]
    za, zb = a[..., 2], b[..., 2]
    cut = (za - eps) * (zb - eps) < 0
    f = np.where(cut, (eps - za) / np.where(cut, zb - za, 1.0), 0.0)
    pts = np.concatenate([np.where((c[..., 2:] >= eps), c, np.nan),
                          np.where(cut[..., None], a + f[..., None] * (b - a), np.nan)], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        xy = pts[..., :2] / pts[..., 2:]
    out[part] = np.stack([np.nanmin(xy[..., 0], 1), np.nanmin(xy[..., 1], 1),
                          np.nanmax(xy[..., 0], 1), np.nanmax(xy[..., 1], 1)], axis=1)
    return out


def _candidates(targets, group, near, far, nb):
    """(target, occluder) index pairs that may cover, target-major: the occluder is nearer at
    its nearest point than the target at its farthest, and their normalised boxes ``nb``
    overlap (a box wholly behind the camera covers nothing). Found without projecting any
    occluder (the pixel boxes of wholly projected pairs are checked next); every target
    against every box of its group, in batches of about :data:`CHUNK` pairs."""
    order = np.argsort(group, kind="stable")
    gs = group[order]
    starts = np.flatnonzero(np.r_[True, gs[1:] != gs[:-1]])
    size = np.diff(np.r_[starts, len(gs)])
    is_target = np.zeros(len(group), bool)
    is_target[targets] = True
    t_pos = np.flatnonzero(is_target[order])  # the targets, group by group
    t_run = np.repeat(np.arange(len(starts)), size)[t_pos]
    n_o = size[t_run]
    csum = np.cumsum(n_o)
    tt, oo = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    a = 0
    while a < len(t_pos):
        b = max(int(np.searchsorted(csum, (csum[a - 1] if a else 0) + CHUNK, side="right")), a + 1)
        ti = order[np.repeat(t_pos[a:b], n_o[a:b])]
        oi = order[_ranges(starts[t_run[a:b]], n_o[a:b])]
        with np.errstate(invalid="ignore"):
            m = (np.isfinite(nb[oi, 0]) & (near[oi] < far[ti]) & (ti != oi)
                 & (nb[oi, 0] <= nb[ti, 2]) & (nb[oi, 2] >= nb[ti, 0]) & (nb[oi, 1] <= nb[ti, 3]) & (nb[oi, 3] >= nb[ti, 1]))
        tt.append(ti[m])
        oo.append(oi[m])
        a = b
    return np.concatenate(tt), np.concatenate(oo)


def _outline_local(samples: int) -> np.ndarray:
    """Outline points of a box in box-local signs ``(8 + 12 * (samples - 1), 3)``: its eight
    corners, then ``samples - 1`` evenly spread points inside each of its twelve edges (the
    projected silhouette is the hull of the projected edges).

    >>> _outline_local(1).shape, _outline_local(3).shape
    ((8, 3), (32, 3))
    """
    a = CORNER_SIGNS[[i for i, _ in _EDGES]]  # (12, 3)
    b = CORNER_SIGNS[[j for _, j in _EDGES]]
    s = (np.arange(1, samples) / samples)[None, :, None]
    inner = (a[:, None, :] * (1 - s) + b[:, None, :] * s).reshape(-1, 3)
    return np.concatenate([CORNER_SIGNS.astype(np.float64), inner])


def _separated(T: np.ndarray, half: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Separating-axis test of box pairs ``(a[p], b[p])`` in the camera frame.

    Returns ``apart (P,)`` (the boxes are disjoint: a separating plane exists among the 15
    box axes and their cross products) and ``b_front (P,)``: the camera centre lies on
    ``b``'s side of that plane, so along every ray through both, ``b`` comes first (two
    disjoint convex bodies keep one depth order over the rays through both)."""
    Ra, Rb = T[a, :3, :3], T[b, :3, :3]
    ha, hb = half[a], half[b]
    # the six face axes first; the nine cross products only for the pairs they do not separate
    L = np.concatenate([np.swapaxes(Ra, 1, 2), np.swapaxes(Rb, 1, 2)], axis=1)  # (P, 6, 3)
    gap, proj = _gaps(L, np.ones(L.shape[:2], bool), (Ra, Rb), (T[a, :3, 3], T[b, :3, 3]), (ha, hb))
    rest = np.flatnonzero(gap.max(axis=1) <= 1e-9)
    if len(rest):
        X = np.stack([np.cross(Ra[rest, :, i], Rb[rest, :, j]) for i in range(3) for j in range(3)], axis=1)
        norm = np.linalg.norm(X, axis=-1)
        ok = norm > 1e-9
        g2, p2 = _gaps(X / np.where(ok, norm, 1.0)[..., None], ok, (Ra[rest], Rb[rest]),
                       (T[a[rest], :3, 3], T[b[rest], :3, 3]), (ha[rest], hb[rest]))
        gap = np.concatenate([gap, np.full((len(a), 9), -np.inf)], axis=1)
        gap[rest, 6:] = g2
        proj = [np.concatenate([v, np.zeros((len(a), 9))], axis=1) for v in proj]
        for v, v2 in zip(proj, p2, strict=True):
            v[rest, 6:] = v2
    pa, pb, ra, rb = proj
    k = gap.argmax(axis=1)
    r = np.arange(len(a))
    apart = gap[r, k] > 1e-9
    # the plane sits mid-gap; the camera (the origin) projects to 0
    lo_a = pa[r, k] < pb[r, k]
    mid = np.where(lo_a, (pa[r, k] + ra[r, k] + pb[r, k] - rb[r, k]) / 2,
                   (pb[r, k] + rb[r, k] + pa[r, k] - ra[r, k]) / 2)
    cam_low = 0.0 < mid
    b_front = np.where(lo_a, ~cam_low, cam_low)
    return apart, b_front


def _gaps(L: np.ndarray, ok: np.ndarray, R, c, half):
    """Gaps between box pairs along unit axes ``L (P, K, 3)`` (``-inf`` where not ``ok``):
    ``R``, ``c``, ``half``: the two boxes' rotations, centres and half sizes. Returns the gaps
    ``(P, K)`` and the centres' projections and the boxes' radii on the axes ``[pa, pb, ra, rb]``."""
    (Ra, Rb), (ca, cb), (ha, hb) = R, c, half
    ra = (np.abs(np.einsum("pkj,pji->pki", L, Ra)) * ha[:, None, :]).sum(-1)
    rb = (np.abs(np.einsum("pkj,pji->pki", L, Rb)) * hb[:, None, :]).sum(-1)
    pa = np.einsum("pkj,pj->pk", L, ca)
    pb = np.einsum("pkj,pj->pk", L, cb)
    return np.where(ok, np.abs(pa - pb) - ra - rb, -np.inf), [pa, pb, ra, rb]


def _hull_table(ol: _Outlines, boxes: np.ndarray):
    """The silhouette polygons (:func:`_hulls`) of the wholly projected ``boxes`` (sorted):
    ``(boxes, p, q, edge counts, first edge of each)``."""
    p, q, ne = _hulls(ol.points(boxes))
    return boxes, p, q, ne, np.r_[0, np.cumsum(ne)[:-1]].astype(np.int64)


def _hull_rows(hulls, boxes: np.ndarray):
    """The polygons ``(p, q, edge counts)`` of ``boxes`` (sorted, all in the table ``hulls``)."""
    table, p, q, ne, first = hulls
    at = np.searchsorted(table, boxes)
    e = _ranges(first[at], ne[at])
    return p[e], q[e], ne[at]


def _rect_bound(polys, t_poly: np.ndarray, pairs, resolution) -> np.ndarray:
    """Upper bounds ``(T,)`` of the visible fractions of targets (their polygons ``t_poly``)
    from their disjoint occluders in front (``pairs``: each pair's target, by position, and
    its occluder's polygon), the polygons ``polys = (p, q, edge counts)`` stacked (an
    occluder's in order, convex or the cut outline of a convex part, whose kernel, the side
    of every edge inside it, lies in it).

    A target's silhouette ``K`` (convex) holds at most ``A + W + H + 1`` pixel centres (``A``
    its area, ``W x H`` its bounding box: the pixel squares of those centres lie in ``K``
    grown by half a pixel). Of those an occluder covers at least the centres of a rectangle
    inside both: the largest one of the shape where their bounding boxes meet, about the
    middle of where their own inscribed rectangles meet (each polygon's: the largest of its
    bounding box's shape about the mean of its vertices), on the inner side of every edge
    of both, shrunk by 1e-6 px, in the image. A target counts the two occluders that cover
    most there (the union of their rectangles). The bound is ``1 - covered / (A + W + H + 1)``.

    >>> sq = lambda x0, y0, x1, y1: np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], np.float32)
    >>> _, p, q, ne, _ = _hull_table(_Points([sq(0, 0, 9, 9), sq(5, 0, 20, 9)]), np.array([0, 1]))
    >>> _rect_bound((p, q, ne), np.array([0]), (np.array([0]), np.array([1])), (100, 100)).round(3).tolist()
    [0.76]

    (the square's 100 pixel centres, 50 of them covered: 0.5; the bound counts 100 at most,
    and the 3 x 8 centres strictly inside both rectangles covered)
    """
    p, q, ne = polys
    n_b = len(ne)
    first = np.r_[0, np.cumsum(ne)[:-1]].astype(np.int64)
    e_box = np.repeat(np.arange(n_b), ne)
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    area2 = np.bincount(e_box, weights=cross, minlength=n_b)  # twice the signed area
    lo = np.c_[np.minimum.reduceat(p[:, 0], first), np.minimum.reduceat(p[:, 1], first)]
    hi = np.c_[np.maximum.reduceat(p[:, 0], first), np.maximum.reduceat(p[:, 1], first)]
    size = hi - lo
    c = np.c_[np.bincount(e_box, weights=p[:, 0], minlength=n_b),
              np.bincount(e_box, weights=p[:, 1], minlength=n_b)] / ne[:, None]
    # the inscribed rectangle of each polygon: the largest of its bounding box's shape about c
    e = q - p
    sign = np.sign(area2)[e_box]
    half = 0.5 * _scale_in((p, e, sign, first, e_box), c, size)[:, None] * size
    r_lo, r_hi = c - half, c + half
    # each pair's, inside both polygons (the edges of one pair's two after the other's)
    pt, b = pairs
    a = t_poly[pt]
    m_lo, m_hi = np.maximum(r_lo[a], r_lo[b]), np.minimum(r_hi[a], r_hi[b])
    mid = 0.5 * (m_lo + m_hi)
    shape = np.minimum(hi[a], hi[b]) - np.maximum(lo[a], lo[b])
    ends = np.r_[a, b]
    e_at = _ranges(first[ends], ne[ends])
    e_pair = np.repeat(np.r_[np.arange(len(a)), np.arange(len(a))], ne[ends])
    order = np.argsort(e_pair, kind="stable")
    e_at, e_pair = e_at[order], e_pair[order]
    scale = _scale_in((p[e_at], e[e_at], sign[e_at], np.searchsorted(e_pair, np.arange(len(a))), e_pair),
                      mid, shape)
    half = np.where(np.all(m_lo <= m_hi, axis=1)[:, None], 0.5 * scale[:, None] * shape - 1e-6, -1.0)
    # its pixel centres in the image: columns x0..x1, rows y0..y1
    w, h = resolution
    rect = np.c_[np.ceil(np.maximum(mid - half, 0)), np.floor(np.minimum(mid + half, [w - 1, h - 1]))]
    count = _centres(rect)
    # the two of each target that cover most, and the centres of their union
    order = np.lexsort((-count, pt))
    pt, rect, count = pt[order], rect[order], count[order]
    top = np.r_[True, pt[1:] != pt[:-1]] if len(pt) else np.zeros(0, bool)
    second = np.r_[False, top[:-1]] & ~top
    covered = np.zeros(len(t_poly))
    covered[pt[top]] = count[top]
    both = np.c_[np.maximum(rect[second, :2], rect[np.flatnonzero(second) - 1, :2]),
                 np.minimum(rect[second, 2:], rect[np.flatnonzero(second) - 1, 2:])]
    covered[pt[second]] += count[second] - _centres(both)
    grow = 1 + 2e-6  # the spans count pixel centres up to 1e-9 px outside
    most = 0.5 * np.abs(area2[t_poly]) + grow * size[t_poly].sum(axis=1) + grow * grow
    return 1.0 - covered / most


def _centres(rect: np.ndarray) -> np.ndarray:
    """The pixel centres of rectangles ``(M, 4)`` of columns ``x0..x1`` and rows ``y0..y1``."""
    return np.maximum(rect[:, 2] - rect[:, 0] + 1, 0) * np.maximum(rect[:, 3] - rect[:, 1] + 1, 0)


def _scale_in(edges, c: np.ndarray, size: np.ndarray) -> np.ndarray:
    """The largest scale ``k`` in [0, inf) (``(M,)``) of the rectangle ``c +- k size / 2``
    (``(M, 2)`` each) whose corners lie on the inner side of every edge of its polygon(s):
    ``edges = (start (E, 2), vector (E, 2), orientation (E,), first edge of each rectangle's
    (M,), the rectangle of each edge (E,))``, grouped by rectangle."""
    p, e, sign, first, of = edges
    inner = sign * (e[:, 0] * (c[of, 1] - p[:, 1]) - e[:, 1] * (c[of, 0] - p[:, 0]))
    reach = 0.5 * (np.abs(e[:, 1]) * size[of, 0] + np.abs(e[:, 0]) * size[of, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(reach > 0, inner / reach, np.where(inner >= 0, np.inf, 0.0))
    return np.maximum(np.minimum.reduceat(k, first), 0.0) if len(k) else np.zeros(len(c))


class _Points:
    """Stand-in for :class:`_Outlines` in examples: ``points(boxes)`` of given polygons."""

    def __init__(self, polys: list[np.ndarray]):
        self.polys = polys

    def points(self, boxes: np.ndarray) -> list[np.ndarray]:
        """The outline points of ``boxes``."""
        return [self.polys[int(b)] for b in boxes]


def _hulls(points: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The silhouette polygons of projected boxes: the convex hulls of their projected outline
    points (each ``(K, 2)`` float32) -> their edges ``(p, q)``, each ``(E, 2)``, stacked box
    by box, and the edge count of each box ``(B,)``."""
    import cv2

    hulls = [cv2.convexHull(pts) for pts in points]
    ne = np.array([len(h) for h in hulls], np.int64)
    if not hulls:
        return np.zeros((0, 2)), np.zeros((0, 2)), ne
    p = np.concatenate(hulls).reshape(-1, 2).astype(np.float64)
    nxt = np.arange(1, len(p) + 1)
    nxt[np.cumsum(ne) - 1] = np.cumsum(ne) - ne  # each hull's last vertex joins its first
    return p, p[nxt], ne


def _box_spans(points: list[np.ndarray], v0: np.ndarray, v1: np.ndarray):
    """Row spans of the silhouettes of boxes (their outline points, each ``(K, 2)`` float32)
    on their rows ``v0 .. v1`` (each ``(B,)``), stacked: ``(first row (B,), offsets (B + 1,),
    lo, hi)``, box ``i``'s spans being ``lo[offsets[i]:offsets[i + 1]]`` from row ``first[i]``
    on: the first and last column whose pixel centre lies inside the silhouette polygon
    (:func:`_hulls`; first > last where none). Edge by edge: each hull edge meets only the
    rows between its ends.

    >>> square = np.array([[0.5, 0.0], [4.0, 0.0], [4.0, 2.0], [0.5, 2.0]], np.float32)
    >>> first, off, lo, hi = _box_spans([square], np.array([0.0]), np.array([3.0]))
    >>> first.tolist(), lo.tolist(), hi.tolist()
    ([0], [1.0, 1.0, 1.0, inf], [4.0, 4.0, 4.0, -inf])
    """
    return _hull_spans(_hulls(points), v0, v1)


def _hull_spans(hulls, v0: np.ndarray, v1: np.ndarray):
    """:func:`_box_spans` of the silhouette polygons ``hulls = (p, q, edge counts)``
    (:func:`_hulls`)."""
    p, q, ne = hulls
    e_box = np.repeat(np.arange(len(ne)), ne)
    v0 = np.asarray(v0).astype(np.int64)
    v1 = np.asarray(v1).astype(np.int64)
    nrow = np.maximum(v1 - v0 + 1, 0)
    off = np.r_[0, np.cumsum(nrow)]
    y0, y1 = p[:, 1], q[:, 1]
    r0 = np.maximum(np.ceil(np.minimum(y0, y1)), v0[e_box]).astype(np.int64)
    r1 = np.minimum(np.floor(np.maximum(y0, y1)), v1[e_box]).astype(np.int64)
    cnt = np.maximum(r1 - r0 + 1, 0)
    lo, hi = np.full(off[-1], np.inf), np.full(off[-1], -np.inf)
    # a convex polygon meets a row at its two chains: the edges going down on one side of it
    # and those going up on the other (which side, by the polygon's orientation); an edge
    # ending on the row gives its end, as does the next edge of its chain there
    area = np.bincount(e_box, weights=p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1], minlength=len(ne))
    dy = y1 - y0
    right = (dy > 0) == (area >= 0)[e_box]
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = (q[:, 0] - p[:, 0]) / dy
        x0 = p[:, 0] + (r0 - y0) * slope  # at each edge's first row
    first = off[e_box] + r0 - v0[e_box]  # where its first row's span is
    for side, span in ((~right, lo), (right, hi)):
        ed = np.flatnonzero(side & (dy != 0) & (cnt > 0))
        c = cnt[ed]
        j = np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c)
        span[np.repeat(first[ed], c) + j] = np.repeat(x0[ed], c) + j * np.repeat(slope[ed], c)
    flat = np.flatnonzero((dy == 0) & (cnt > 0))  # a horizontal edge on the row: both its ends
    if len(flat):
        np.minimum.at(lo, first[flat], np.minimum(p[flat, 0], q[flat, 0]))
        np.maximum.at(hi, first[flat], np.maximum(p[flat, 0], q[flat, 0]))
    return v0, off, np.ceil(lo - 1e-9), np.floor(hi + 1e-9)


def _raster(boxes3, ol: _Outlines, targets, cands, rays: _Rays, limits):
    """Visible fractions of wholly projected ``targets``: the pixel centres of the target's
    silhouette (its projected outline ``ol``, row by row), less those inside a disjoint
    occluder in front that is drawn (its outline, whole or cut to the field of view), less
    those whose ray enters another occluder first (one not drawn, or one that intersects the
    target: slab tests on the pixels still uncovered, at most ``cap`` of them, evenly spread,
    and of those only the rays inside the occluder's normalised box ``nb``). ``boxes3``:
    ``(T, dims, nb)``; ``cands``: the (target, occluder, disjoint) candidate arrays;
    ``limits``: ``(cap, below)``, a target whose uncovered share is already below ``below``
    keeps that upper bound (its rays are not cast; :func:`_cast_hard`). All targets' rows are
    stacked, and the simple occluders' spans on them listed (:func:`_uncovered_runs`). Under a threshold (``below > 0``) a target whose
    bound from rectangles (:func:`_rect_bound`) is below it keeps that bound, and is not
    scanned."""
    cand_t, cand_o, cand_apart = cands
    below = limits[1]
    out = np.full(len(targets), np.nan)
    order = np.argsort(cand_t, kind="stable")
    ct, co, ca = cand_t[order], cand_o[order], cand_apart[order]
    whole = ol.whole
    sw = ca & ol.drawn()[co] & whole[co]  # the disjoint occluders in front, projected whole
    hulls = _hull_table(ol, np.unique(np.r_[targets, co[sw]]))
    kept = np.ones(len(targets), bool)
    if below > 0:
        # the polygons: the hulls of the targets and of their whole occluders, then the cut
        # outlines of the others drawn (disjoint, in front)
        sc = ca & ol.drawn()[co] & ~whole[co]
        cut = np.unique(co[sc])
        table, hp, hq, ne, _ = hulls
        cp = [ol.cut_pts[b] for b in cut.tolist()]
        polys = (np.concatenate([hp, *cp]) if cp else hp,
                 np.concatenate([hq, *[np.roll(c, -1, axis=0) for c in cp]]) if cp else hq,
                 np.r_[ne, [len(c) for c in cp]].astype(np.int64))
        occ = np.r_[np.searchsorted(table, co[sw]), len(table) + np.searchsorted(cut, co[sc])]
        pair_t = np.searchsorted(targets, np.r_[ct[sw], ct[sc]])
        bound = _rect_bound(polys, np.searchsorted(table, targets), (pair_t, occ), ol.camera.resolution)
        kept = ~(bound < below)
        out[~kept] = bound[~kept]
    if kept.any():
        sel = kept[np.searchsorted(targets, ct)]
        out[kept] = _raster_spans(boxes3, ol, targets[kept], (ct[sel], co[sel], ca[sel]), rays, (limits, hulls))
    return out


def _raster_spans(boxes3, ol: _Outlines, targets, cands, rays: _Rays, limits):
    """:func:`_raster` of the targets that its bound leaves (``limits``: ``((cap, below),
    hulls)``, :func:`_hull_table`), their candidates sorted by target."""
    ct, co, ca = cands
    (cap, below), hulls = limits
    out = np.full(len(targets), np.nan)
    whole = ol.whole
    fov = rays.fov
    # intersecting boxes, both wholly projected: the pieces where the occluder is entered first
    inter = ~ca & whole[co] & whole[ct] & (fov is not None)
    simple = (ca & ol.drawn()[co]) | inter
    clip = ol.clip()
    (b_v0, b_off, b_lo, b_hi), at, pair_t, pair_o = _simple_spans(ol, targets, (ct, co, ca, simple, inter),
                                                                   (*boxes3[:2], fov), hulls)
    # the stacked rows of every target, its span on each
    nrow = b_off[at + 1] - b_off[at]
    r_off = np.r_[0, np.cumsum(nrow)]
    row_t = np.repeat(np.arange(len(targets)), nrow)  # the target of each stacked row
    src = b_off[at[row_t]] + np.arange(r_off[-1]) - r_off[row_t]
    lo = np.maximum(b_lo[src], clip[targets[row_t], 0])
    hi = np.minimum(b_hi[src], clip[targets[row_t], 2])
    # the simple occluders' spans on their targets' rows (the rows both have)
    t_pos = np.searchsorted(targets, pair_t)
    ob = pair_o
    v0 = np.maximum(b_v0[at[t_pos]], b_v0[ob])
    n_r = np.maximum(np.minimum(b_v0[at[t_pos]] + nrow[t_pos], b_v0[ob] + b_off[ob + 1] - b_off[ob]) - v0, 0)
    e_pair = np.repeat(np.arange(len(ob)), n_r)
    i = v0[e_pair] + np.arange(n_r.sum()) - np.repeat(np.cumsum(n_r) - n_r, n_r)  # image row
    g = r_off[t_pos[e_pair]] + i - b_v0[at[t_pos[e_pair]]]  # stacked row
    o_src = b_off[ob[e_pair]] + i - b_v0[ob[e_pair]]
    width = ol.camera.resolution[0]
    occ = (g, b_lo[o_src], b_hi[o_src])
    area = np.bincount(row_t, weights=np.maximum(hi - lo + 1, 0), minlength=len(targets))
    free = area - np.bincount(row_t, weights=_covered(lo, hi, occ, width), minlength=len(targets))
    # spans alone: the covered length of each row (an upper bound where rays are still cast)
    ok = area > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        val = 1.0 - (area - free) / area
    out[ok] = val[ok]
    # the targets with hard occluders, uncovered pixels and (for the rule) not yet below it
    hard_first = np.searchsorted(ct[~simple], targets)
    hard_last = np.searchsorted(ct[~simple], targets, side="right")
    jj = np.flatnonzero(ok & (hard_first != hard_last) & (free != 0) & ~(val < below))
    if len(jj):
        # their uncovered runs, row by row (their stacked rows renumbered from 0)
        in_jj = np.zeros(len(targets), bool)
        in_jj[jj] = True
        rsel = in_jj[row_t]
        renum = np.cumsum(rsel) - 1
        osel = rsel[g]
        r_row, r_start, r_len = _uncovered_runs(lo[rsel], hi[rsel], (renum[g[osel]], occ[1][osel], occ[2][osel]),
                                                width)
        run_t = row_t[rsel][r_row]
        run_off = np.searchsorted(run_t, jj)
        n_runs = np.searchsorted(run_t, jj, side="right") - run_off
        j_first = np.r_[0, np.cumsum(nrow[jj])][:-1]  # each one's first renumbered row
        runs = ((r_row - np.repeat(j_first, n_runs), r_start, r_len),
                np.r_[0, np.cumsum(n_runs)], clip[targets[jj], 1].astype(np.int64), cap)
        h_o = co[~simple]
        out[jj] = _cast_hard(jj, (area[jj], free[jj]), runs, targets,
                             (h_o, ca[~simple], hard_first, hard_last, _reach(ol, h_o, clip[ct[~simple]])), boxes3,
                             rays, below)
    return out


def _reach(ol: _Outlines, occ: np.ndarray, rows: np.ndarray):
    """Where the rays that may enter the wholly projected occluders among ``occ`` lie: the row
    spans (:func:`_box_spans`) of their outlines grown by :data:`MARGIN_PX` on every side (a
    curved edge may bulge between its samples; the hull of the outline shifted to the
    corners of a square holds every point that near it), on the rows ``rows`` (``(P, 4)``
    pixel boxes: those of each occluder's target in ``occ``). Returns ``(boxes, first row,
    offsets, lo, hi)``; a box not among them (not projected whole) may cover any pixel."""
    whole = ol.whole[occ]
    boxes, inv = np.unique(occ[whole], return_inverse=True)
    w, h = ol.camera.resolution
    r0 = np.full(len(boxes), np.inf)
    r1 = np.full(len(boxes), -np.inf)
    np.minimum.at(r0, inv, rows[whole, 1])
    np.maximum.at(r1, inv, rows[whole, 3])
    r0 = np.maximum(r0, np.maximum(np.floor(ol.bb[boxes, 1] - MARGIN_PX), 0))
    r1 = np.minimum(r1, np.minimum(np.ceil(ol.bb[boxes, 3] + MARGIN_PX), h - 1))
    shifts = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], np.float32)[:, None] * np.float32(MARGIN_PX)
    pts = [(p[None] + shifts).reshape(-1, 2) for p in ol.points(boxes)]
    return (boxes, *_box_spans(pts, r0, r1))


def _simple_spans(ol: _Outlines, targets: np.ndarray, pairs, poses, hulls):
    """The row spans of :func:`_raster`'s targets and of their simple occluders (an
    occluder's only on its targets' rows): convex silhouettes (the hull of a whole outline,
    :func:`_box_spans`), then the layers (:func:`_scan_spans`) of the outlines cut to the
    field of view and of the intersecting pairs' pieces (:func:`_entered_first`; their edges
    may curve inwards). ``pairs``: the (target, occluder, disjoint, simple, intersecting and
    drawn) arrays; ``poses``: ``(T, dims, fov)``; ``hulls``: the silhouette polygons of the
    targets and their whole simple occluders (:func:`_hull_table`). Returns the spans ``(first row, offsets, lo,
    hi)``, each target's spans and each simple pair's target and spans (a pair has one for
    each layer of its cut outline or pieces)."""
    ct, co, ca, simple, inter = pairs
    whole, clip = ol.whole, ol.clip()
    sw, sc = simple & ca & whole[co], simple & ca & ~whole[co]
    boxes = np.unique(np.r_[targets, co[sw]])
    r0, r1 = _rows_needed(boxes, co[sw], clip[ct[sw]], ol.clip())
    is_t = np.isin(boxes, targets)
    r0, r1 = np.where(is_t, clip[boxes, 1], r0), np.where(is_t, clip[boxes, 3], r1)
    spans = _hull_spans(_hull_rows(hulls, boxes), r0, r1)
    cut = np.unique(co[sc])
    c0, c1 = _rows_needed(cut, co[sc], clip[ct[sc]], ol.drawn_clip())
    polys = [ol.cut_pts[b] for b in cut.tolist()]
    # the pieces of the intersecting pairs (on their targets' rows)
    T, dims, fov = poses
    piece, n_v, pair = _entered_first(T, 0.5 * dims, ct[inter], co[inter])
    pp = _project_polygons(ol.camera, [q[:m] for q, m in zip(piece, n_v, strict=True)], fov[4] if fov else np.inf)
    good = np.array([q is not None for q in pp], bool)  # all: the target lies where the model is valid
    polys += [q for q, g in zip(pp, good, strict=True) if g]
    piece_t = ct[inter][pair[good]]
    c0, c1 = np.r_[c0, clip[piece_t, 1]], np.r_[c1, clip[piece_t, 3]]
    owner, *layers = _scan_spans(polys, c0, c1)
    b_v0, b_lo, b_hi = (np.r_[spans[i], layers[i]] for i in (0, 2, 3))
    b_off = np.r_[spans[1], spans[1][-1] + layers[1][1:]]
    at = np.searchsorted(boxes, targets)
    # each simple pair's occluder: its spans, or each layer of its cut outline, or of its pieces
    poly_t = np.r_[ct[sc], piece_t]
    k = np.r_[np.searchsorted(cut, co[sc]), len(cut) + np.arange(len(piece_t))]
    l_first, l_n = np.searchsorted(owner, k), np.searchsorted(owner, k, side="right") - np.searchsorted(owner, k)
    pair_t = np.r_[ct[sw], np.repeat(poly_t, l_n)]
    pair_o = np.r_[np.searchsorted(boxes, co[sw]), len(boxes) + _ranges(l_first, l_n)]
    return (b_v0, b_off, b_lo, b_hi), at, pair_t, pair_o


def _rows_needed(boxes: np.ndarray, occ: np.ndarray, t_clip: np.ndarray, clip: np.ndarray):
    """The rows ``(r0, r1)`` of the occluders ``boxes`` (pixel boxes ``clip (N, 4)``) that
    their targets have: ``occ`` the occluder of each pair, ``t_clip`` its target's pixel box."""
    at = np.searchsorted(boxes, occ)
    r0, r1 = np.full(len(boxes), np.inf), np.full(len(boxes), -np.inf)
    np.minimum.at(r0, at, t_clip[:, 1])
    np.maximum.at(r1, at, t_clip[:, 3])
    return np.maximum(r0, clip[boxes, 1]), np.minimum(r1, clip[boxes, 3])


def _covered(lo: np.ndarray, hi: np.ndarray, spans, width: int) -> np.ndarray:
    """The number of pixel centres of each row's target span ``[lo, hi] (H,)`` inside one of
    the occluder spans ``spans`` (:func:`_uncovered_runs`' arguments): ``(H,)`` float64, the
    row's span length less its uncovered runs' lengths, to the bit (integers). A row with one
    occluder span needs no sort.

    >>> _covered(np.array([0.0, 0]), np.array([9.0, 3]),
    ...          (np.array([0, 0, 1]), np.array([4.0, 2, 5]), np.array([6.0, 3, 8])), 10).tolist()
    [5.0, 0.0]
    """
    g, a, b = spans
    a, b = np.maximum(a, lo[g]), np.minimum(b, hi[g])
    keep = a <= b
    g, a, b = g[keep], a[keep], b[keep]
    many = np.bincount(g, minlength=len(lo))[g] > 1
    out = np.bincount(g[~many], weights=(b - a + 1)[~many], minlength=len(lo)).astype(np.float64)
    g, a, b = g[many], a[many], b[many]
    if len(g):
        # rows of several spans, in column order: each adds the columns past the furthest end
        # of the row's earlier spans (an earlier row's ends lie below the row's first column)
        stride = width + 2
        order = np.argsort(g * stride + a.astype(np.int64), kind="stable")
        g, a, b = g[order], a[order], b[order]
        base = g * stride
        reach = np.maximum.accumulate(b + base)
        before = np.r_[-np.inf, reach[:-1]] - base
        out += np.bincount(g, weights=np.maximum(b - np.maximum(a, before + 1) + 1, 0), minlength=len(lo))
    return out


def _uncovered_runs(lo: np.ndarray, hi: np.ndarray, spans, width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The runs of pixel centres of the rows' target spans ``[lo, hi] (H,)`` inside none of the
    occluder spans ``spans``: ``(row, a, b)`` arrays, any number per row, in any order; the
    rows' columns lie in ``0 .. width - 1``. Returns the runs row-major and left to right (an
    empty one where two occluder spans touch): their row, first column and length.

    >>> row, start, length = _uncovered_runs(np.array([0.0, 0]), np.array([9.0, 3]),
    ...                                      (np.array([0, 0]), np.array([4.0, 2]), np.array([6.0, 3])), 10)
    >>> [(int(r), float(s), float(n)) for r, s, n in zip(row, start, length) if n]
    [(0, 0.0, 2.0), (0, 7.0, 3.0), (1, 0.0, 4.0)]
    """
    g, a, b = spans
    a, b = np.maximum(a, lo[g]), np.minimum(b, hi[g])
    keep = a <= b
    g, a, b = g[keep], a[keep], b[keep]
    stride = width + 2  # rows apart in one sorted key: row * stride + column (columns -1 .. width)
    order = np.argsort(g * stride + a.astype(np.int64), kind="stable")
    g, a, b = g[order], a[order], b[order]
    base = g * stride
    # the last covered column before each span: the row's earlier spans' furthest end (or lo - 1)
    reach = np.maximum.accumulate(b + base) if len(b) else b
    before = np.maximum(np.r_[-np.inf, reach[:-1]] - base, lo[g] - 1)
    # each row: the gap before each of its spans, then the tail after its last
    n_rows = len(lo)
    count = np.bincount(g, minlength=n_rows)
    last = np.full(n_rows, -np.inf)
    last[g] = reach - base  # sorted: the row's last span holds its furthest end
    end = np.maximum(last, lo - 1)
    pos = np.arange(len(g)) + g  # one tail for each earlier row
    tail = np.cumsum(count) + np.arange(n_rows)
    row = np.empty(len(g) + n_rows, np.int64)
    start = np.empty(len(row))
    stop = np.empty(len(row))
    row[pos], start[pos], stop[pos] = g, before + 1, a - 1
    row[tail], start[tail], stop[tail] = np.arange(n_rows), end + 1, hi
    length = np.maximum(stop - start + 1, 0)
    return row, np.where(length > 0, start, 0), length


def _cast_hard(n, sizes, runs, targets, hard, boxes, rays: _Rays, below: float) -> np.ndarray:
    """Visible fractions of the targets ``targets[n]`` (``sizes``: their silhouettes' pixel
    counts and those not covered by their simple occluders; ``runs``: these pixels, the
    arguments of :func:`_pick_pixels`) against their hard occluders (``hard``: occluders and
    disjointness, the target ``n``'s from ``first[n]`` to ``last[n]``, and where the occluders
    may cover, :func:`_reach`), the rays of all targets unprojected and cast together, those
    of the pixels that one of their target's hard occluders may cover (the others are not
    covered). Where ``below > 0`` the picked pixels are cast in
    :data:`STAGES` interleaved stages, and a target whose hits so far put it below ``below``
    keeps that upper bound (a ray's hit does not depend on the others cast with it, and
    every step of the fraction is monotone in the hit count: the last stage gives the
    value of a single cast)."""
    h_o, h_apart, first, last, (r_box, r_v0, r_off, r_lo, r_hi) = hard
    area, free = sizes
    # (cast target, hard occluder) pairs
    k = last[n] - first[n]
    p_i = np.repeat(np.arange(len(n)), k)
    p_h = first[n][p_i] + np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)
    stages = STAGES if below > 0 else 1
    hits = np.zeros(len(n), np.int64)
    out = np.full(len(n), np.nan)
    todo = np.arange(len(n))
    for s in range(stages):
        pv, pu, g, count = _pick_pixels(*runs, (s, stages, todo))
        at = np.full(len(n), -1)
        at[todo] = np.arange(len(todo))
        sel = at[p_i] >= 0
        # only the pixels that one of their target's hard occluders may cover have a ray cast
        q = np.flatnonzero(sel)
        pf = np.searchsorted(g, np.arange(len(n) + 1))
        n_px = pf[p_i[q] + 1] - pf[p_i[q]]
        px = _ranges(pf[p_i[q]], n_px)
        occ = np.repeat(h_o[p_h[q]], n_px)
        inside = np.ones(len(occ), bool)
        if len(r_box):
            k = np.minimum(np.searchsorted(r_box, occ), len(r_box) - 1)
            drawn = r_box[k] == occ
            idx = pv[px] - r_v0[k]
            in_r = np.flatnonzero(drawn & (idx >= 0) & (idx < r_off[k + 1] - r_off[k]))
            inside[drawn] = False
            j = r_off[k[in_r]] + idx[in_r]
            inside[in_r] = (r_lo[j] <= pu[px[in_r]]) & (pu[px[in_r]] <= r_hi[j])
        need = np.zeros(len(pv), bool)
        need[px[inside]] = True
        r = np.full((len(pv), 3), np.nan)
        r[need] = rays.at(pv[need], pu[need])
        hit = _hard_hits(r, np.bincount(at[g], minlength=len(todo)),
                         targets[n[todo]], (at[p_i[sel]], h_o[p_h[sel]], h_apart[p_h[sel]]), boxes)
        hits[todo] += np.bincount(at[g], weights=hit, minlength=len(todo)).astype(np.int64)
        out[todo] = 1.0 - (area[todo] - free[todo] + hits[todo] / count[todo] * free[todo]) / area[todo]
        todo = todo[out[todo] >= below]
        if not len(todo):
            break
    return out


def _pick_pixels(runs, seg, v0, cap, part=(0, 1, None)) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The uncovered pixel centres ``runs`` (:func:`_uncovered_runs`) of several targets, target
    ``g``'s runs from ``seg[g]`` to ``seg[g + 1]``, its rows counted from ``v0[g]``: at most
    ``cap`` of each target's are picked, evenly spread. Returns the rows, columns and targets
    ``(pv, pu, g)`` of the picked pixels of ``part`` ``(s, step, targets)`` (the ``s``-th,
    ``s + step``-th, ... picked pixel of each of those targets, target by target; default:
    all), and the picked count of every target.

    >>> runs = (np.array([0, 1, 0]), np.array([3.0, 0.0, 5.0]), np.array([2.0, 1.0, 4.0]))
    >>> pv, pu, g, count = _pick_pixels(runs, np.array([0, 2, 3]), np.array([10, 20]), 2)
    >>> pv.tolist(), pu.tolist(), g.tolist(), count.tolist()
    ([10, 11, 20, 20], [3, 0, 5, 8], [0, 0, 1, 1], [2, 2])
    >>> _pick_pixels(runs, np.array([0, 2, 3]), np.array([10, 20]), 2, (1, 2, np.array([1])))[1].tolist()
    [8]
    """
    row, start, length = runs
    csum = np.cumsum(length).astype(np.int64)
    base = np.r_[0, csum][seg]  # the pixels before each target's
    free = np.diff(base)
    count = np.minimum(free, cap)
    s, step, sel = part
    sel = np.arange(len(free)) if sel is None else sel
    m = np.maximum(count[sel] - s + step - 1, 0) // step  # picks s, s + step, ... below the count
    pick = s + step * (np.arange(m.sum()) - np.repeat(np.cumsum(m) - m, m))
    big = free[sel] > cap
    if big.any():
        spread = np.repeat(big, m)
        pick[spread] = np.linspace(0, free[sel][big] - 1, cap)[s::step].round().astype(np.int64).T.ravel()
    g = np.repeat(sel, m)
    at = base[g] + pick
    run = np.searchsorted(csum, at, side="right")
    pu = (start[run] + at - (csum[run] - length[run])).astype(np.int64)
    return row[run] + v0[g], pu, g, count


def _hard_hits(r, counts, tgt, pairs, boxes) -> np.ndarray:
    """Which rays ``r (P, 3)`` (NaN: no ray; ``counts (G,)`` consecutive ones of each target
    ``tgt (G,)``) first enter one of their target's hard occluders (``pairs``: target
    position, ascending, occluder and disjointness arrays): a disjoint one (in front) wherever
    they enter it, an intersecting one where they enter it before their target. Only the rays
    inside an occluder's normalised box, and not yet hit by the target's earlier occluders,
    are slab-tested against it (the first occluder of every target at once, then the second,
    ..., in batches of :data:`CHUNK`). ``boxes``: ``(T, dims, nb)``."""
    T, dims, nb = boxes
    pg, po, pa = pairs
    good = np.isfinite(r).all(axis=1)
    r = np.where(good[:, None], r, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        x, y = r[:, 0] / r[:, 2], r[:, 1] / r[:, 2]
    off = np.r_[0, np.cumsum(counts)]
    hit = np.zeros(len(r), bool)
    rank = np.arange(len(pg)) - np.searchsorted(pg, pg)  # the occluder's rank among its target's
    for k in range(int(rank.max()) + 1 if len(pg) else 0):
        pk = np.flatnonzero(rank == k)
        csum = np.cumsum(counts[pg[pk]])
        start = 0
        while start < len(pk):
            stop = max(int(np.searchsorted(csum, (csum[start - 1] if start else 0) + CHUNK, side="right")), start + 1)
            q = pk[start:stop]
            n_p = counts[pg[q]]
            e_pair = np.repeat(np.arange(len(q)), n_p)
            ray = _ranges(off[pg[q]], n_p)
            b = [np.repeat(nb[po[q], i], n_p) for i in range(4)]
            xr, yr = x[ray], y[ray]
            keep = good[ray] & ~hit[ray] & (xr >= b[0]) & (xr <= b[2]) & (yr >= b[1]) & (yr <= b[3])
            ray, e_pair = ray[keep], e_pair[keep]
            e = _segment_entry(r[ray], np.searchsorted(e_pair, np.arange(len(q) + 1)), po[q], (T, dims))
            cover = np.isfinite(e)
            sub = np.flatnonzero(~pa[q][e_pair])  # intersecting: entered before the target
            if len(sub):
                e_t = _segment_entry(r[ray[sub]], np.searchsorted(e_pair[sub], np.arange(len(q) + 1)),
                                     tgt[pg[q]], (T, dims))
                cover[sub] = e[sub] < e_t
            hit[ray[cover]] = True
            start = stop
    return hit


def _segment_entry(r: np.ndarray, bounds: np.ndarray, box: np.ndarray, boxes) -> np.ndarray:
    """Entry distances (:func:`ray_box_entry`) of consecutive segments of rays ``r (P, 3)``
    (segment ``i`` from ``bounds[i]`` to ``bounds[i + 1]``), each into its box ``box[i]``
    (``boxes``: ``(T, dims)``): one matrix product per segment (a row's product does not
    depend on the other rows), then one slab test of all."""
    T, dims = boxes
    d = np.empty_like(r)
    o = np.empty((len(box), 3))
    for i, b in enumerate(box):
        R = T[b, :3, :3]
        o[i] = -(T[b, :3, 3] @ R)
        if bounds[i + 1] > bounds[i]:
            d[bounds[i]:bounds[i + 1]] = r[bounds[i]:bounds[i + 1]] @ R
    seg = np.repeat(np.arange(len(box)), np.diff(bounds))
    return _slab_entry(o[seg], d, 0.5 * dims[box][seg])


def _ranges(start: np.ndarray, length: np.ndarray) -> np.ndarray:
    """The indices ``start[i] .. start[i] + length[i] - 1`` of every range, one after the other.

    >>> _ranges(np.array([5, 0]), np.array([2, 3])).tolist()
    [5, 6, 0, 1, 2]
    """
    return np.repeat(start - np.cumsum(length) + length, length) + np.arange(length.sum())


def _slab(rays: np.ndarray, R: np.ndarray, o: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Entry distance of rays ``(P, 3)`` into one box each (rotation ``R (P, 3, 3)`` box ->
    camera, camera centre in the box frame ``o (P, 3)``, half sizes ``half (P, 3)``); ``inf``
    where a ray misses (:func:`_slab_entry`)."""
    return _slab_entry(o, np.matmul(rays[:, None, :], R)[:, 0], half)


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
    rays = lut.at(pv, pu)
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
                    T_box_world: np.ndarray, dims_lwh: np.ndarray, candidates: np.ndarray, *,
                    min_visible: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
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
    candidates : (C, 2) int64
        The candidates: a box and the novel view it is paired with.
    min_visible : float, optional
        The rule's threshold, for a caller that drops the candidates below it in either view:
        candidates less visible than this in the GT view are not cast in the novel view (their
        ``novel_visible`` is NaN), and a fraction found below it before its rays are cast is
        returned as that upper bound (still below ``min_visible``). 0: every value exact.

    Returns
    -------
    gt_visible, novel_visible : (C,) float64
        0..1; NaN where the box has no silhouette pixel in the image.
    """
    cand = np.asarray(candidates, np.int64).reshape(-1, 2)
    box_index, view_index = cand[:, 0], cand[:, 1]
    fr = np.asarray(frame_index, np.int64)
    if len(box_index) == 0:
        return np.zeros(0), np.zeros(0)
    T_cam = np.matmul(T_gt_world[fr], T_box_world)  # (M, 4, 4) boxes in the GT camera
    need = np.zeros(len(fr), bool)
    need[box_index] = True
    lut = _Rays(camera)  # the image's rays, shared by the GT and the novel views
    gt = _visible_fractions(camera, T_cam, dims_lwh, group=fr, only=need, grid=GRID, rays=lut,
                            below=min_visible)[box_index]
    nv = np.full(len(box_index), np.nan)
    go = np.flatnonzero(gt >= min_visible) if min_visible > 0 else np.arange(len(box_index))
    # a view at the GT pose (the identity) is the GT view: its fractions are the GT's, to the bit
    same = np.all(np.asarray(T_view_gt, np.float64).reshape(-1, 4, 4) == np.eye(4), axis=(1, 2))[view_index[go]]
    nv[go[same]] = gt[go[same]]
    go = go[~same]
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
    nv[go] = _visible_fractions(camera, T_nv, dims_lwh[box_of], group=grp, only=want, grid=GRID, rays=lut,
                                below=min_visible)[pos]
    return gt, nv
