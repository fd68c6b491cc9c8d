"""3D boxes: corners from centre poses, and the pixel box of projected corners.

Layer: nvrq core, geometry.

Convention: a box's own frame has x along its length, y along its width, z along its
height, origin at the box centre. Corner ``i`` has signs ``(sx, sy, sz)`` =
``CORNER_SIGNS[i]``, i.e. corner = centre + R @ (sx*l/2, sy*w/2, sz*h/2).

Pixel boxes are inclusive integer indices (docs/FORMATS.md §3):
``x0 = floor(min u), y0 = floor(min v), x1 = ceil(max u), y1 = ceil(max v)`` and the crop
is ``image[y0:y1 + 1, x0:x1 + 1]``. Worked number: corners spanning u in [10.2, 49.5]
give ``x0 = 10, x1 = 50`` and a crop 41 pixels wide.

>>> import numpy as np
>>> c = box_corners(np.eye(4)[None], np.array([[4.0, 2.0, 1.0]]))
>>> c.shape, c[0].min(axis=0).tolist(), c[0].max(axis=0).tolist()
((1, 8, 3), [-2.0, -1.0, -0.5], [2.0, 1.0, 0.5])
>>> pixel_box(np.array([[[10.2, 5.0], [49.5, 7.9]]])).tolist()
[[10, 5, 50, 8]]
"""

from __future__ import annotations

import numpy as np

__all__ = ["CORNER_SIGNS", "MAX_PIXEL", "box_corners", "pixel_box", "box_sides"]

#: Sign pattern of the 8 corners in the box frame, shape (8, 3).
CORNER_SIGNS = np.array(
    [[sx, sy, sz] for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)], dtype=np.float64
)


def box_corners(T_box_world: np.ndarray, dims_lwh: np.ndarray) -> np.ndarray:
    """World corners of boxes.

    ``T_box_world: (..., 4, 4)`` box centre poses, ``dims_lwh: (..., 3)`` -> ``(..., 8, 3)``.

    Parameters
    ----------
    T_box_world : (..., 4, 4) float64
        Box centre poses, box frame to world frame (metres).
    dims_lwh : (..., 3) float64, metres
        Length, width, height.

    Returns
    -------
    (..., 8, 3) float64
        Corners in the world frame, metres, in the order of ``CORNER_SIGNS``.
    """
    T = np.asarray(T_box_world, dtype=np.float64)
    half = 0.5 * np.asarray(dims_lwh, dtype=np.float64)
    local = CORNER_SIGNS * half[..., None, :]  # (..., 8, 3)
    return np.einsum("...ij,...kj->...ki", T[..., :3, :3], local) + T[..., None, :3, 3]


#: Largest pixel coordinate :func:`pixel_box` accepts (far beyond any image, far below int64).
MAX_PIXEL = 2.0**53


def pixel_box(uv: np.ndarray) -> np.ndarray:
    """Inclusive integer box ``[x0, y0, x1, y1]`` of points ``uv: (..., K, 2)`` -> ``(..., 4)`` int64.

    Raises ``ValueError`` for a coordinate that is not finite or beyond :data:`MAX_PIXEL`
    (casting it would give an arbitrary integer): callers mask points outside the image first.

    Parameters
    ----------
    uv : (..., K, 2) float
        Pixel coordinates ``u, v`` of K points.

    Returns
    -------
    (..., 4) int64
        Inclusive pixel boxes ``x0, y0, x1, y1`` (floor of the minima, ceil of the maxima).
    """
    uv = np.asarray(uv, dtype=np.float64)
    if uv.size and not (np.abs(uv) <= MAX_PIXEL).all():
        raise ValueError("pixel_box: every coordinate must be finite and within "
                         f"{MAX_PIXEL:.0f} px; mask points outside the image first")
    lo = np.floor(uv.min(axis=-2))
    hi = np.ceil(uv.max(axis=-2))
    return np.concatenate([lo, hi], axis=-1).astype(np.int64)


def box_sides(box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Width and height in pixels of inclusive boxes ``(..., 4)``: ``x1 - x0 + 1``, ``y1 - y0 + 1``.

    Parameters
    ----------
    box : (..., 4) int
        Inclusive pixel boxes ``[x0, y0, x1, y1]``.

    Returns
    -------
    width, height : (...,) int, pixels

    >>> [s.tolist() for s in box_sides(np.array([[10, 5, 50, 8]]))]
    [[41], [4]]
    """
    box = np.asarray(box)
    return box[..., 2] - box[..., 0] + 1, box[..., 3] - box[..., 1] + 1
