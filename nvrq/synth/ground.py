"""Ground and sky: a world-aligned ground texture and the per-camera sky/fog background.

Layer: nvrq core, synth (synthetic scenes).

The ground (road with lane markings, crosswalks, kerbs, sidewalks, grass) is one raster
in world x/y; a view draws it with a single homography. Because the rig stays level on
the flat road, each camera's sky, fog and headlight falloff are the same image in every
frame and at every lateral offset, so they are computed once per camera.

Convention: texel (col, row) has its centre at world ``(x0 + res*col, y0 + res*row, 0)``.

>>> A = np.array([[0.1, 0, -5.0], [0, 0.1, -2.0], [0, 0, 1]])   # res 0.1 m, origin (-5, -2)
>>> (A @ [50, 20, 1]).tolist()
[0.0, 0.0, 1.0]
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from nvrq.synth.layout import World
from nvrq.synth.textures import bgr

__all__ = ["Ground", "build_ground", "Background", "camera_background", "draw_ground"]


@dataclass
class Ground:
    """``texture: (Ht, Wt, 3)`` uint8 BGR; ``A: (3, 3)`` texel (col, row, 1) -> world (x, y, 1).

    Attributes
    ----------
    texture : (Ht, Wt, 3) uint8
        BGR ground raster.
    A : (3, 3) float64
        Texel ``(col, row, 1)`` -> world ``(x, y, 1)``, metres.
    """

    texture: np.ndarray
    A: np.ndarray


@dataclass
class Background:
    """Per camera: ground weight ``wg: (Hv, Wv, 1)`` float32, premultiplied sky/fog ``bg: (Hv, Wv, 3)``,
    and ``row0``, the first virtual-image row that can show ground.

    Attributes
    ----------
    wg : (Hv, Wv, 1) float32
        Ground weight.
    bg : (Hv, Wv, 3) float32
        Premultiplied sky/fog colour, BGR.
    row0 : int
        First virtual-image row that can show ground.
    """

    wg: np.ndarray
    bg: np.ndarray
    row0: int


def _paint_markings(col: np.ndarray, world: World, sd, grass: np.ndarray) -> None:
    """The lane lines, the median and the crosswalks into ``col (ny, nx, 3)``; ``sd``: the
    pixels' road coordinates ``s, d (ny, nx)`` and which lie on the road."""
    road = world.road
    s, d, on_road = sd
    ad = np.abs(d)
    rt = road.road_type
    white = np.array(bgr((235, 235, 230)), np.float32)
    yellow = np.array(bgr((230, 190, 40)), np.float32)
    dash = np.mod(s, 9.0) < 3.0
    m2 = road.median_w / 2
    lines = []  # (d position, half width, colour, dashed)
    if road.median_w > 0:
        col[ad < m2 - 0.2] = grass
        lines += [(m2, 0.08, yellow, False), (-m2, 0.08, yellow, False)]
    elif rt == "rural":
        lines.append((0.0, 0.07, white, True))
    else:
        lines += [(0.13, 0.06, yellow, False), (-0.13, 0.06, yellow, False)]
    for k in range(1, road.lanes_per_dir):
        for sg in (-1, 1):
            lines.append((sg * (m2 + k * road.lane_w), 0.07, white, True))
    edge = m2 + road.lanes_per_dir * road.lane_w
    lines += [(edge, 0.08, white, False), (-edge, 0.08, white, False)]
    for dl, hw, c, dashed in lines:
        m = np.abs(d - dl) < hw
        if dashed:
            m &= dash
        col[m] = c
    for sc in world.crosswalks:
        m = on_road & (np.abs(s - sc) < 2.0) & (np.mod(d, 1.0) < 0.5)
        col[m] = white


def _light_pools(col: np.ndarray, world: World, origin, res: float) -> None:
    """Night: darken ``col (ny, nx, 3)`` but for the pools of light under the lamps
    (``origin``: the world x, y of pixel (0, 0); ``res`` metres per pixel)."""
    ny, nx = col.shape[:2]
    x0, y0 = origin
    pool = np.zeros((ny, nx), np.float32)
    for bb in world.billboards:
        if bb["kind"] != "lamp":
            continue
        cx, cy = (bb["base"][0] - x0) / res, (bb["base"][1] - y0) / res
        r = 9.0 / res
        ia, ib = int(max(cy - 2 * r, 0)), int(min(cy + 2 * r, ny))
        ja, jb = int(max(cx - 2 * r, 0)), int(min(cx + 2 * r, nx))
        if ia >= ib or ja >= jb:
            continue
        yy, xx = np.mgrid[ia:ib, ja:jb].astype(np.float32)
        pool[ia:ib, ja:jb] += np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / (r * r))
    col *= (0.16 * (1.0 + 3.5 * np.minimum(pool, 1.0)))[..., None]


def build_ground(
    world: World, rng: np.random.Generator, *, res: float = 0.08, max_side: int = 6000
) -> Ground:
    """Rasterise the clip's ground (see module docstring).

    Parameters
    ----------
    world : World
        The clip's world.
    rng : numpy.random.Generator
        Source of the texture's randomness.
    res : float, optional
        Metres per texel.
    max_side : int, optional
        Largest raster side, texels.

    Returns
    -------
    Ground
    """
    road = world.road
    kerb = road.half_width
    s_lo, s_hi = world.s_range
    ss = np.linspace(s_lo, s_hi, 200)
    span = kerb + 45.0
    xs, ys = [], []
    for d in (-span, span):
        x, y, _ = road.to_world(ss, np.full_like(ss, d))
        xs.append(x)
        ys.append(y)
    x0, x1 = float(np.min(xs)), float(np.max(xs))
    y0, y1 = float(np.min(ys)), float(np.max(ys))
    res = max(res, (x1 - x0) / max_side, (y1 - y0) / max_side)
    nx, ny = int((x1 - x0) / res) + 1, int((y1 - y0) / res) + 1
    X = (x0 + res * np.arange(nx, dtype=np.float64))[None, :].astype(np.float32)
    Y = (y0 + res * np.arange(ny, dtype=np.float64))[:, None].astype(np.float32)
    s, d = road.to_road(np.broadcast_to(X, (ny, nx)), np.broadcast_to(Y, (ny, nx)))
    s = s.astype(np.float32)
    d = d.astype(np.float32)
    ad = np.abs(d)
    rt = road.road_type
    col = np.empty((ny, nx, 3), np.float32)
    grass = np.array(bgr((85, 120, 60) if rt != "rural" else (120, 130, 70)), np.float32)
    paving = np.array(bgr((150, 148, 142)), np.float32)
    col[:] = grass if rt != "urban" else np.array(bgr((120, 118, 112)), np.float32)
    if rt in ("urban", "residential"):
        side = (ad > kerb) & (ad < kerb + 4.0)
        col[side] = paving
        joints = side & ((np.mod(s, 1.2) < 0.06) | (np.mod(ad - kerb, 1.2) < 0.06))
        col[joints] = paving * 0.8
        col[(ad >= kerb) & (ad < kerb + 0.25)] = np.array(bgr((185, 185, 180)), np.float32)
    elif rt == "rural":
        col[(ad > kerb) & (ad < kerb + 1.2)] = np.array(bgr((125, 110, 85)), np.float32)  # gravel
    on_road = ad <= kerb
    col[on_road] = np.array(bgr((78, 78, 82)), np.float32)
    _paint_markings(col, world, (s, d, on_road), grass)
    # low-frequency stains and fine grain
    small = rng.normal(0.0, 10.0, (max(ny // 40, 2), max(nx // 40, 2))).astype(np.float32)
    col += cv2.resize(small, (nx, ny), interpolation=cv2.INTER_CUBIC)[..., None]
    col += rng.integers(-9, 10, (ny, nx, 1)).astype(np.float32)
    if world.lighting != "daytime":
        _light_pools(col, world, (x0, y0), res)
    tex = np.clip(col, 0, 255).astype(np.uint8)
    A = np.array([[res, 0, x0], [0, res, y0], [0, 0, 1]])
    return Ground(tex, A)


def camera_background(
    K: np.ndarray, size: tuple[int, int], T_sensor_rig: np.ndarray, *, lighting: str
) -> Background:
    """Sky gradient, distance fog and (at night) headlight falloff for one virtual camera.

    ``K: (3, 3)``, ``size (Wv, Hv)``; the rig is level with its origin on the ground.

    Parameters
    ----------
    K : (3, 3) float64
        Virtual pinhole intrinsics, pixels.
    size : (int, int)
        ``(Wv, Hv)`` pixels.
    T_sensor_rig : (4, 4) float64
        Camera mounting, sensor frame to rig frame (metres).
    lighting : str
        ``{'daytime', 'nighttime'}``.

    Returns
    -------
    Background
    """
    Wv, Hv = size
    u, v = np.meshgrid(np.arange(Wv, dtype=np.float32), np.arange(Hv, dtype=np.float32))
    Ki = np.linalg.inv(K).astype(np.float32)
    R = T_sensor_rig[:3, :3].astype(np.float32) @ Ki
    dx = R[0, 0] * u + R[0, 1] * v + R[0, 2]
    dy = R[1, 0] * u + R[1, 1] * v + R[1, 2]
    dz = R[2, 0] * u + R[2, 1] * v + R[2, 2]
    horiz = np.hypot(dx, dy)
    height = float(T_sensor_rig[2, 3])
    ground = dz < -1e-4
    dist = np.where(ground, height * horiz / np.where(ground, -dz, 1.0), np.inf)
    elev = np.arctan2(dz, horiz)
    if lighting == "daytime":
        low, top = (
            np.array(bgr((200, 215, 230)), np.float32),
            np.array(bgr((70, 125, 205)), np.float32),
        )
        fog = np.clip((dist - 40.0) / 200.0, 0.0, 1.0)
        gain = np.ones_like(fog)
    else:
        low, top = np.array(bgr((28, 30, 42)), np.float32), np.array(bgr((4, 6, 14)), np.float32)
        fog = np.clip((dist - 30.0) / 120.0, 0.0, 1.0)
        lateral = np.abs(dy / np.maximum(np.abs(dx), 1e-3))
        gain = 1.0 + 3.0 * np.exp(-((dist / 28.0) ** 2)) * np.exp(-((lateral / 0.35) ** 2))
    t = np.clip(elev / 0.45, 0.0, 1.0)[..., None]
    sky = low * (1 - t) + top * t
    wg = np.where(ground, (1.0 - fog) * gain, 0.0).astype(np.float32)[..., None]
    bg = np.where(ground[..., None], fog[..., None] * low, sky).astype(np.float32)
    rows = np.flatnonzero(ground.any(1))
    row0 = int(rows[0]) if len(rows) else Hv
    return Background(wg, bg, row0)


def draw_ground(
    image: np.ndarray, ground: Ground, bgd: Background, K: np.ndarray, T_world_cam: np.ndarray
) -> None:
    """Fill ``image (Hv, Wv, 3)`` with ground and sky for the camera ``T_world_cam (4, 4)``.

    Parameters
    ----------
    image : (Hv, Wv, 3) uint8
        The view, filled in place.
    ground : Ground
        The clip's ground raster.
    bgd : Background
        The camera's sky and fog.
    K : (3, 3) float64
        Virtual pinhole intrinsics, pixels.
    T_world_cam : (4, 4) float64
        World frame to camera frame (metres).
    """
    Hv, Wv = image.shape[:2]
    r0 = bgd.row0
    if r0 > 0:
        image[:r0] = bgd.bg[:r0].astype(np.uint8)
    if r0 >= Hv:
        return
    P = T_world_cam[:3]
    H = K @ np.stack([P[:, 0], P[:, 1], P[:, 3]], axis=1) @ ground.A
    H[1] -= r0 * H[2]
    warped = cv2.warpPerspective(
        ground.texture,
        H,
        (Wv, Hv - r0),
        flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=(60, 60, 60),
    )
    out = warped.astype(np.float32) * bgd.wg[r0:] + bgd.bg[r0:]
    np.clip(out, 0, 255, out=out)
    image[r0:] = out.astype(np.uint8)
