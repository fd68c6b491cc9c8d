"""Render one clean view of a world: ground, sky, scenery and actors in painter's order.

Layer: nvrq core, synth (synthetic scenes).

``render_view`` works in the virtual pinhole of :mod:`nvrq.synth.renderer` and returns the
image, an object-id buffer and each actor's drawn pixel bounds (used to place artefacts).
"""

from __future__ import annotations

import numpy as np

from nvrq.synth.assets import Assets
from nvrq.synth.ground import Background, Ground, draw_ground
from nvrq.synth.layout import World
from nvrq.synth.renderer import draw_faces

__all__ = ["render_view", "billboard_quads"]

_MAX_DIST = 260.0


def billboard_quads(base: np.ndarray, size: np.ndarray, cam_pos: np.ndarray) -> np.ndarray:
    """Camera-facing vertical quads: ``base (N, 3)`` bottom centre, ``size (N, 2)`` [w, h] ->
    world corners ``(N, 4, 3)`` TL, TR, BR, BL as seen from ``cam_pos (3,)``.

    Parameters
    ----------
    base : (N, 3) float64, metres
        Bottom centres, world frame.
    size : (N, 2) float64, metres
        ``[width, height]``.
    cam_pos : (3,) float64, metres
        Camera centre, world frame.

    Returns
    -------
    (N, 4, 3) float64, metres
        World corners TL, TR, BR, BL.
    """
    d = base[:, :2] - cam_pos[:2]
    n = np.linalg.norm(d, axis=1, keepdims=True)
    d = d / np.maximum(n, 1e-6)
    right = np.stack([d[:, 1], -d[:, 0], np.zeros(len(d))], -1)  # d x z
    half = right * (size[:, :1] / 2)
    up = np.zeros_like(base)
    up[:, 2] = size[:, 1]
    return np.stack([base - half + up, base + half + up, base + half, base - half], axis=1)


def _actor_faces(world: World, assets: Assets, cam_pos: np.ndarray, frame: int):
    """The faces of the actors present at ``frame`` that face the camera: corners (F, 4, 3) in
    the world, texture ids (F,) and actor indices (F,)."""
    present = np.array([a.present[frame] for a in world.actors])
    own = assets.actor_owner
    on = present[own]
    T = np.stack([a.T_box_world[frame] for a in world.actors])[own[on]]
    local = assets.actor_corners[on]
    wc = np.einsum("nij,nkj->nki", T[:, :3, :3], local) + T[:, None, :3, 3]
    wn = np.einsum("nij,nj->ni", T[:, :3, :3], assets.actor_normals[on])
    vis = np.einsum("ij,ij->i", wn, cam_pos - wc.mean(1)) > 0
    return wc[vis], assets.actor_tex[on][vis], own[on][vis]


def _billboards(world: World, assets: Assets, cam_pos: np.ndarray, frame: int):
    """The scenery billboards and the impostors of the actors present at ``frame``, turned to
    the camera: lists of base points, sizes, texture ids and actor indices (-1: scenery)."""
    base, bsize, btex, bobj = (
        [assets.bb_base],
        [assets.bb_size],
        [assets.bb_tex],
        [np.full(len(assets.bb_tex), -1)],
    )
    for k, (t_front, t_side, t_flip, w_front, w_side) in assets.impostors.items():
        actor = world.actors[k]
        if not actor.present[frame]:
            continue
        T = actor.T_box_world[frame]
        b = T[:3, 3] - [0, 0, actor.dims[2] / 2]
        view = b[:2] - cam_pos[:2]
        view = view / max(np.linalg.norm(view), 1e-6)
        heading = T[:2, 0]
        right = np.array([view[1], -view[0]])
        if abs(heading @ view) > 0.7:
            t, w = t_front, w_front
        else:
            t, w = (t_side if heading @ right > 0 else t_flip), w_side
        base.append(b[None])
        bsize.append(np.array([[w, actor.dims[2]]]))
        btex.append(np.array([t]))
        bobj.append(np.array([k]))
    return base, bsize, btex, bobj


def render_view(
    world: World,
    assets: Assets,
    ground: Ground,
    bgd: Background,
    K: np.ndarray,
    size: tuple[int, int],
    T_cam_world: np.ndarray,
    frame: int,
):
    """Draw frame ``frame`` seen by a virtual camera at ``T_cam_world (4, 4)`` (camera -> world).

    Returns ``image (Hv, Wv, 3)`` uint8 BGR, ``ids (Hv, Wv)`` int16 actor index (-1 none)
    and ``boxes``: actor index -> [x0, y0, x1, y1] (exclusive end) of its drawn pixels.

    Parameters
    ----------
    world : World
        The clip's world.
    assets : Assets
        Its textures and faces.
    ground : Ground
        Its ground raster.
    bgd : Background
        The camera's sky and fog.
    K : (3, 3) float64
        Virtual pinhole intrinsics, pixels.
    size : (int, int)
        ``(Wv, Hv)`` pixels.
    T_cam_world : (4, 4) float64
        Camera frame to world frame (metres).
    frame : int
        Frame index.

    Returns
    -------
    image : (Hv, Wv, 3) uint8
        BGR view.
    ids : (Hv, Wv) int16
        Actor index per pixel, -1 none.
    boxes : dict
        Actor index -> ``[x0, y0, x1, y1]`` drawn pixels, exclusive end.
    """
    Wv, Hv = size
    T_world_cam = np.linalg.inv(T_cam_world)
    cam_pos = T_cam_world[:3, 3]
    image = np.empty((Hv, Wv, 3), np.uint8)
    ids = np.full((Hv, Wv), -1, np.int16)
    draw_ground(image, ground, bgd, K, T_world_cam)

    corners, tex, obj = [], [], []
    # static boxes
    sc = assets.static_corners
    if len(sc):
        centre = sc.mean(1)
        vis = (np.einsum("ij,ij->i", assets.static_normals, cam_pos - centre) > 0) & (
            np.linalg.norm(centre - cam_pos, axis=1) < _MAX_DIST
        )
        corners.append(sc[vis])
        tex.append(assets.static_tex[vis])
        obj.append(np.full(int(vis.sum()), -1))
    if len(assets.actor_owner):  # actor boxes
        for part, value in zip((corners, tex, obj), _actor_faces(world, assets, cam_pos, frame), strict=True):
            part.append(value)
    base, bsize, btex, bobj = _billboards(world, assets, cam_pos, frame)  # scenery and impostors
    base = np.concatenate(base)
    bsize = np.concatenate(bsize)
    near = np.linalg.norm(base - cam_pos, axis=1) < _MAX_DIST
    corners.append(billboard_quads(base[near], bsize[near], cam_pos))
    tex.append(np.concatenate(btex)[near])
    obj.append(np.concatenate(bobj)[near])

    corners_w = np.concatenate(corners)
    corners_c = np.einsum("ij,nkj->nki", T_world_cam[:3, :3], corners_w) + T_world_cam[:3, 3]
    boxes: dict[int, list[int]] = {}
    draw_faces(
        image, ids, K, corners_c, assets.textures, np.concatenate(tex), np.concatenate(obj), boxes
    )
    return image, ids, boxes
