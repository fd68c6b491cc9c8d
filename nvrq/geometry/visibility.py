"""Visible fraction of each 3D box in a camera view, by ray casting against the frame's boxes.

Layer: nvrq core, geometry.

For every box, rays are cast through a grid of pixel centres covering the box's projected
silhouette (the pixel bounding box of densely sampled projected edges, clipped to the image).
A ray belongs to the silhouette when it enters the box (slab test); it is occluded when it
enters any other box of the frame nearer along the ray. The visible fraction is the
unoccluded share of the silhouette samples. The silhouette is the projected box itself, not
its 2D rectangle, and it is exact for every camera model because only ``unproject`` and
``project`` are used.

Truncation: only the part of the silhouette inside the image counts (a box half outside the
image and otherwise unoccluded is 1.0). A box with no silhouette pixel in the image is NaN.
"""

from __future__ import annotations

import numpy as np

from nvrq.geometry.boxes import CORNER_SIGNS

__all__ = ["EDGE_SAMPLES", "GRID", "ray_box_entry", "visible_fractions"]

#: Samples per box edge used to bound the projected silhouette.
EDGE_SAMPLES = 16
#: Largest number of silhouette samples per image axis (pixel centres when the box is smaller).
GRID = 64

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
    R = T_box_cam[:, :3, :3]
    o = -np.einsum("nji,nj->ni", R, T_box_cam[:, :3, 3])  # (N, 3) camera centre in box frame
    d = np.einsum("nji,rj->nri", R, rays)  # (N, R, 3)
    half = 0.5 * np.asarray(dims_lwh, dtype=np.float64)[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - o[:, None, :]) / d
        t2 = (half - o[:, None, :]) / d
    lo = np.fmin(t1, t2)
    hi = np.fmax(t1, t2)
    # a ray parallel to a slab: inside it -> (-inf, inf), outside -> NaN (miss)
    par = d == 0
    inside = np.abs(o[:, None, :]) <= half
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


def visible_fractions(camera, T_box_cam: np.ndarray, dims_lwh: np.ndarray,
                      *, grid: int = GRID) -> np.ndarray:
    """Visible fraction (0..1, NaN when not in the image) of each box of one frame.

    Parameters
    ----------
    camera : CameraModel
        Any model of ``nvrq.geometry.cameras``.
    T_box_cam : (N, 4, 4) float64
        Box centre poses in the camera frame (all boxes of the frame: every one occludes).
    dims_lwh : (N, 3) float64
        Box length, width, height, metres.
    grid : int
        Largest number of samples per image axis.

    Returns
    -------
    (N,) float64
    """
    T = np.asarray(T_box_cam, dtype=np.float64).reshape(-1, 4, 4)
    dims = np.asarray(dims_lwh, dtype=np.float64).reshape(-1, 3)
    n = len(T)
    out = np.full(n, np.nan)
    if n == 0:
        return out
    w, h = camera.resolution
    s = np.linspace(0.0, 1.0, EDGE_SAMPLES)
    a = np.array([CORNER_SIGNS[i] for i, _ in _EDGES])
    b = np.array([CORNER_SIGNS[j] for _, j in _EDGES])
    signs = (a[:, None, :] * (1 - s[None, :, None]) + b[:, None, :] * s[None, :, None]).reshape(-1, 3)
    local = signs[None] * (0.5 * dims)[:, None, :]  # (N, E, 3)
    pts = np.einsum("nij,nkj->nki", T[:, :3, :3], local) + T[:, None, :3, 3]
    uv, ok = camera.project(pts)
    for i in range(n):
        if not ok[i].any():
            continue
        u = uv[i, ok[i], 0]
        v = uv[i, ok[i], 1]
        u0, u1 = max(np.floor(u.min()), 0), min(np.ceil(u.max()), w - 1)
        v0, v1 = max(np.floor(v.min()), 0), min(np.ceil(v.max()), h - 1)
        if u0 > u1 or v0 > v1:
            continue
        gu = _axis(u0, u1, grid)
        gv = _axis(v0, v1, grid)
        pix = np.stack(np.meshgrid(gu, gv), axis=-1).reshape(-1, 2)
        rays = camera.unproject(pix)
        good = np.isfinite(rays).all(axis=-1)
        rays = rays[good]
        if len(rays) == 0:
            continue
        t = ray_box_entry(rays, T, dims)  # (N, R)
        sil = np.isfinite(t[i])
        if not sil.any():
            continue
        others = np.delete(t[:, sil], i, axis=0)
        occluded = (others < t[i, sil]).any(axis=0) if len(others) else np.zeros(sil.sum(), bool)
        out[i] = 1.0 - occluded.mean()
    return out


def _axis(lo: float, hi: float, grid: int) -> np.ndarray:
    """Pixel centres lo..hi, or ``grid`` evenly spread samples when there are more."""
    if hi - lo + 1 <= grid:
        return np.arange(lo, hi + 1)
    return np.linspace(lo, hi, grid)
