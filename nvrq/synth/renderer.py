"""Painter's-algorithm renderer of a synthetic world (numpy + OpenCV, no ray tracing).

Layer: nvrq core, synth (synthetic scenes).

Each view is drawn in an ideal *virtual pinhole* camera: the ground plane is one
homography warp of a world-aligned ground texture, the sky a per-camera gradient, and
every visible face (box faces and camera-facing billboards) is warped from its texture
with :func:`cv2.warpPerspective` into its bounding box, far faces first; faces that cross
the near plane are clipped there. Distorted cameras (``opencv_pinhole``, ``ftheta``) are
then produced by one :func:`cv2.remap` with a grid built once per camera from the real
model's ``unproject``; pixels the model cannot see (beyond ``max_angle``) stay black.

Convention: camera frame x right, y down, z forward; ``T_world_cam`` maps world points
into the camera frame; the virtual image has pixel centres at integer coordinates.

>>> K = np.array([[100.0, 0, 49.5], [0, 100.0, 29.5], [0, 0, 1]])
>>> H = face_homography(K, np.array([[-1.0, -1, 10], [1, -1, 10], [1, 1, 10], [-1, 1, 10]]), (11, 11))
>>> np.round(H @ [10, 10, 1] / (H @ [10, 10, 1])[2], 6).tolist()  # texel (10, 10) -> corner (1, 1, 10)
[59.5, 39.5, 1.0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from nvrq.geometry.cameras import camera_from_model

__all__ = ["VirtualCamera", "virtual_camera", "face_homography", "draw_faces", "clip_near"]

NEAR = 0.2  # metres


@dataclass
class VirtualCamera:
    """Ideal pinhole ``K: (3, 3)`` of ``size (Wv, Hv)`` and the remap to the real camera.

    ``map1, map2``: fixed-point remap tables (``None`` when the real camera is this pinhole);
    ``real_size (W, H)``.

    Attributes
    ----------
    K : (3, 3) float64
        Ideal pinhole intrinsics, pixels.
    size : (int, int)
        ``(Wv, Hv)`` of the virtual image, pixels.
    real_size : (int, int)
        ``(W, H)`` of the real camera, pixels.
    map1, map2 : ndarray or None
        ``cv2.remap`` fixed-point tables, virtual to real image.
    """

    K: np.ndarray
    size: tuple[int, int]
    real_size: tuple[int, int]
    map1: np.ndarray | None
    map2: np.ndarray | None

    def to_real(self, image: np.ndarray, *, nearest: bool = False) -> np.ndarray:
        """Virtual image ``(Hv, Wv, ...)`` -> real camera image ``(H, W, ...)``."""
        if self.map1 is None:
            return image
        interp = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
        return cv2.remap(
            image, self.map1, self.map2, interp, borderMode=cv2.BORDER_CONSTANT, borderValue=0
        )


def virtual_camera(model: dict, *, pixel_budget: float = 1.35) -> VirtualCamera:
    """Build the virtual pinhole for a scene.json camera ``model`` dict.

    The virtual focal length is the real one at the image centre, reduced when needed so
    the virtual image covers every visible ray with at most ``pixel_budget * W * H`` pixels.

    Parameters
    ----------
    model : dict
        A ``scene.json`` camera model.
    pixel_budget : float, optional
        Largest virtual image, as a multiple of the real ``W * H``.

    Returns
    -------
    VirtualCamera
    """
    W, H = (int(v) for v in model["resolution"])
    if model["type"] == "pinhole":
        (fx, fy), (cx, cy) = model["focal_length"], model["principal_point"]
        K = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], float)
        return VirtualCamera(K, (W, H), (W, H), None, None)
    cam = camera_from_model(model)
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    rays = cam.unproject(np.stack([u, v], -1))
    valid = np.isfinite(rays).all(-1) & (rays[..., 2] > 0.05)
    x = np.where(valid, rays[..., 0] / np.where(valid, rays[..., 2], 1.0), np.nan)
    y = np.where(valid, rays[..., 1] / np.where(valid, rays[..., 2], 1.0), np.nan)
    cx, cy = (float(c) for c in model["principal_point"])
    c0, c1 = cam.unproject(np.array([[cx, cy], [cx + 1.0, cy]]))
    f_centre = 1.0 / max(math.acos(float(np.clip(c0 @ c1, -1, 1))), 1e-9)
    x0, x1, y0, y1 = np.nanmin(x), np.nanmax(x), np.nanmin(y), np.nanmax(y)
    f = min(f_centre, math.sqrt(pixel_budget * W * H / ((x1 - x0) * (y1 - y0))))
    Wv, Hv = int(math.ceil((x1 - x0) * f)) + 3, int(math.ceil((y1 - y0) * f)) + 3
    K = np.array([[f, 0, -x0 * f + 1], [0, f, -y0 * f + 1], [0, 0, 1]])
    mx = np.where(valid, f * x + K[0, 2], -10.0).astype(np.float32)
    my = np.where(valid, f * y + K[1, 2], -10.0).astype(np.float32)
    m1, m2 = cv2.convertMaps(mx, my, cv2.CV_16SC2)
    return VirtualCamera(K, (Wv, Hv), (W, H), m1, m2)


def face_homography(
    K: np.ndarray, corners_cam: np.ndarray, tex_size: tuple[int, int]
) -> np.ndarray:
    """Homography texel -> virtual pixel of a parallelogram face.

    ``corners_cam: (4, 3)`` camera-frame corners TL, TR, BR, BL (seen from outside);
    ``tex_size (tw, th)``: texel (0, 0) is the TL corner and (tw-1, th-1) the BR corner.
    Exact for points in front of the camera, even when other corners are behind it.

    Parameters
    ----------
    K : (3, 3) float64
        Virtual pinhole intrinsics, pixels.
    corners_cam : (4, 3) float64, metres
        Face corners TL, TR, BR, BL in the camera frame.
    tex_size : (int, int)
        ``(tw, th)`` texels.

    Returns
    -------
    (3, 3) float64
        Texel ``(col, row, 1)`` -> virtual pixel ``(u, v, 1)``.
    """
    tw, th = tex_size
    O = corners_cam[0]
    U = (corners_cam[1] - O) / max(tw - 1, 1)
    V = (corners_cam[3] - O) / max(th - 1, 1)
    return K @ np.stack([U, V, O], axis=1)


def clip_near(poly: np.ndarray, near: float = NEAR) -> np.ndarray:
    """Clip a camera-frame polygon ``(N, 3)`` to ``z >= near`` (Sutherland-Hodgman); ``(M, 3)``.

    Parameters
    ----------
    poly : (N, 3) float64, metres
        Polygon in the camera frame.
    near : float, metres, optional
        The near plane.

    Returns
    -------
    (M, 3) float64
        The clipped polygon (empty when wholly behind).
    """
    out = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        ina, inb = a[2] >= near, b[2] >= near
        if ina:
            out.append(a)
        if ina != inb:
            t = (near - a[2]) / (b[2] - a[2])
            out.append(a + t * (b - a))
    return np.array(out).reshape(-1, 3)


def _draw_order(K: np.ndarray, corners_cam: np.ndarray, size: tuple[int, int]):
    """The faces to draw, far to near (frustum and size culled), with their projected corners
    ``u, v (N, 4)`` and whether all four lie in front of the near plane ``allin (N,)``."""
    Wv, Hv = size
    z = corners_cam[..., 2]
    keep = (z >= NEAR).any(1)
    # frustum test on corners in front of the camera (conservative for clipped faces)
    zc = np.maximum(z, NEAR)
    u = K[0, 0] * corners_cam[..., 0] / zc + K[0, 2]
    v = K[1, 1] * corners_cam[..., 1] / zc + K[1, 2]
    allin = (z >= NEAR).all(1)
    off = allin & ((u.max(1) < 0) | (u.min(1) > Wv - 1) | (v.max(1) < 0) | (v.min(1) > Hv - 1))
    tiny = allin & ((u.max(1) - u.min(1)) * (v.max(1) - v.min(1)) < 2.0)
    keep &= ~off & ~tiny
    depth = np.linalg.norm(corners_cam.mean(1), axis=1)
    order = np.flatnonzero(keep)
    order = order[np.argsort(-depth[order], kind="stable")]
    return order, u, v, allin


def draw_faces(
    image: np.ndarray,
    ids: np.ndarray,
    K: np.ndarray,
    corners_cam: np.ndarray,
    textures: list[np.ndarray],
    tex_ids: np.ndarray,
    obj_ids: np.ndarray,
    boxes: dict[int, list[int]],
) -> None:
    """Draw faces far to near into ``image (Hv, Wv, 3)`` and object ids into ``ids (Hv, Wv)``.

    ``corners_cam: (N, 4, 3)`` TL, TR, BR, BL in the camera frame; ``tex_ids, obj_ids:
    (N,)`` (obj -1 = scenery). ``boxes`` collects each object's drawn pixel bounds
    ``[x0, y0, x1, y1]`` (exclusive end) — updated in place.

    Parameters
    ----------
    image : (Hv, Wv, 3) uint8
        The view, drawn in place.
    ids : (Hv, Wv) int16
        Object-id buffer, drawn in place.
    K : (3, 3) float64
        Virtual pinhole intrinsics, pixels.
    corners_cam : (N, 4, 3) float64, metres
        Face corners TL, TR, BR, BL in the camera frame.
    textures : list of (h, w, 4) uint8
        BGR-A textures.
    tex_ids, obj_ids : (N,) int
        Texture and object (-1 scenery) of each face.
    boxes : dict
        Object -> drawn pixel bounds ``[x0, y0, x1, y1]`` (exclusive end), updated in place.
    """
    Hv, Wv = image.shape[:2]
    if len(corners_cam) == 0:
        return
    order, u, v, allin = _draw_order(K, corners_cam, (Wv, Hv))
    for i in order:
        c = corners_cam[i]
        if allin[i]:
            pu, pv = u[i], v[i]
            poly = None
        else:
            clipped = clip_near(c)
            if len(clipped) < 3:
                continue
            pu = K[0, 0] * clipped[:, 0] / clipped[:, 2] + K[0, 2]
            pv = K[1, 1] * clipped[:, 1] / clipped[:, 2] + K[1, 2]
            poly = np.stack([pu, pv], -1)
        x0 = max(int(math.floor(pu.min())), 0)
        y0 = max(int(math.floor(pv.min())), 0)
        x1 = min(int(math.ceil(pu.max())) + 1, Wv)
        y1 = min(int(math.ceil(pv.max())) + 1, Hv)
        if x1 <= x0 or y1 <= y0 or (x1 - x0) * (y1 - y0) < 3:
            continue
        tex = textures[tex_ids[i]]
        Hm = face_homography(K, c, (tex.shape[1], tex.shape[0]))
        Hm[0] -= x0 * Hm[2]
        Hm[1] -= y0 * Hm[2]
        warped = cv2.warpPerspective(
            tex,
            Hm,
            (x1 - x0, y1 - y0),
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(0, 0, 0, 0),
        )
        mask = warped[..., 3] > 127
        if poly is not None:
            pm = np.zeros(mask.shape, np.uint8)
            pts = np.clip(poly - [x0, y0], -1e6, 1e6).round().astype(np.int32)
            cv2.fillConvexPoly(pm, pts, 1)
            mask &= pm.astype(bool)
        np.copyto(image[y0:y1, x0:x1], warped[..., :3], where=mask[..., None])
        k = int(obj_ids[i])
        if k >= 0:
            ids[y0:y1, x0:x1][mask] = k
            b = boxes.get(k)
            boxes[k] = (
                [x0, y0, x1, y1]
                if b is None
                else [min(b[0], x0), min(b[1], y0), max(b[2], x1), max(b[3], y1)]
            )
