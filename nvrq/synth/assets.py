"""Textured geometry of a world: box faces (vehicles, buildings) and billboards (people, trees).

Layer: nvrq core, synth (synthetic scenes).

Vehicles are one or two textured boxes (car: body + cabin; truck: cab + trailer; bus: one
box); people and riders are camera-facing impostors whose texture (front/back or side
view) is chosen by the viewing angle; trees and lamps are camera-facing billboards.

Convention: a face is its corners ``TL, TR, BR, BL`` seen from outside; in an object's
own frame x is forward, y left, z up, origin at the box centre.

>>> c, n = box_faces(np.zeros(3), np.array([4.0, 2.0, 1.0]))
>>> c.shape, n[0].tolist()        # 5 faces (no bottom); the first faces forward (+x)
((5, 4, 3), [1.0, 0.0, 0.0])
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

import nvrq.synth.people as people
import nvrq.synth.textures as tx
from nvrq.synth.layout import World

__all__ = ["Assets", "build_assets", "box_faces", "FACE_NAMES"]

FACE_NAMES = ("front", "rear", "left", "right", "top")
_SIGNS = {  # (TL, TR, BR, BL) in units of half-dims, outward normal
    "front": ([(1, -1, 1), (1, 1, 1), (1, 1, -1), (1, -1, -1)], (1, 0, 0)),
    "rear": ([(-1, 1, 1), (-1, -1, 1), (-1, -1, -1), (-1, 1, -1)], (-1, 0, 0)),
    "left": ([(1, 1, 1), (-1, 1, 1), (-1, 1, -1), (1, 1, -1)], (0, 1, 0)),
    "right": ([(-1, -1, 1), (1, -1, 1), (1, -1, -1), (-1, -1, -1)], (0, -1, 0)),
    "top": ([(1, 1, 1), (1, -1, 1), (-1, -1, 1), (-1, 1, 1)], (0, 0, 1)),
}
_SHADE = {"front": 0.9, "rear": 0.84, "left": 0.78, "right": 0.72, "top": 1.0}


def box_faces(centre: np.ndarray, dims: np.ndarray):
    """Faces of an axis-aligned box: corners ``(5, 4, 3)`` and outward normals ``(5, 3)``.

    Parameters
    ----------
    centre : (3,) float64, metres
        Box centre, in the frame the corners are wanted in.
    dims : (3,) float64, metres
        Extent along x, y, z.

    Returns
    -------
    corners : (5, 4, 3) float64, metres
        The four sides and the top, corners TL, TR, BR, BL seen from outside.
    normals : (5, 3) float64
        Outward unit normals.
    """
    half = np.asarray(dims, float) / 2
    corners = np.array([[np.multiply(s, half) for s in _SIGNS[f][0]] for f in FACE_NAMES]) + centre
    normals = np.array([_SIGNS[f][1] for f in FACE_NAMES], float)
    return corners, normals


@dataclass
class Assets:
    """Everything the view renderer draws, in flat arrays.

    ``textures``: list of (h, w, 4) BGR-A uint8. Static faces ``static_corners (S, 4, 3)``
    world, ``static_normals (S, 3)``, ``static_tex (S,)``. Actor faces ``actor_corners
    (A, 4, 3)`` box frame, ``actor_normals (A, 3)``, ``actor_tex (A,)``, ``actor_owner (A,)``.
    Billboards ``bb_base (B, 3)``, ``bb_size (B, 2)`` [width, height] m, ``bb_tex (B,)``.
    ``impostors``: actor index -> (tex front/rear, tex side, tex side flipped, w front, w side).

    Attributes
    ----------
    textures : list of (h, w, 4) uint8
        BGR-A textures.
    static_corners : (S, 4, 3) float64
        Scenery faces, metres, world frame.
    static_normals : (S, 3) float64
        Their outward normals.
    static_tex : (S,) int
        Their texture indices.
    actor_corners : (A, 4, 3) float64
        Faces of the moving objects' boxes, metres, each in its box's own frame.
    actor_normals : (A, 3) float64
        Outward normals of those faces, box frame (rotated with the box when drawn).
    actor_tex : (A,) int
        Index into ``textures`` of each actor face.
    actor_owner : (A,) int
        The actor each face belongs to.
    bb_base : (B, 3) float64
        Billboard bottom centres, metres, world frame.
    bb_size : (B, 2) float64
        Billboard ``[width, height]``, metres.
    bb_tex : (B,) int
        Billboard texture indices.
    impostors : dict
        Actor index -> ``(tex front/rear, tex side, tex side flipped, w front, w side)``.
    """

    textures: list = field(default_factory=list)
    static_corners: np.ndarray = None
    static_normals: np.ndarray = None
    static_tex: np.ndarray = None
    actor_corners: np.ndarray = None
    actor_normals: np.ndarray = None
    actor_tex: np.ndarray = None
    actor_owner: np.ndarray = None
    bb_base: np.ndarray = None
    bb_size: np.ndarray = None
    bb_tex: np.ndarray = None
    impostors: dict = field(default_factory=dict)

    def add(
        self, material: tx.Material, lighting: str, shade: float = 1.0, *, flip: bool = False
    ) -> int:
        t = tx.finalize(material, lighting=lighting, shade=shade)
        self.textures.append(np.ascontiguousarray(t[:, ::-1]) if flip else t)
        return len(self.textures) - 1


def _vehicle_parts(cls, dims, colour, rng):
    """List of (centre (3,), dims (3,), {face: Material}) in the box frame."""
    if cls == "automobile":
        return _car_parts(dims, colour, rng)
    if cls == "bus":
        return _bus_parts(dims, colour, rng)
    return _truck_parts(dims, colour, rng)


def _car_parts(dims, colour, rng):
    """A car: body and cabin (as :func:`_vehicle_parts`)."""
    l, w, h = dims
    hb = 0.52 * h
    body_c, body_d = np.array([0, 0, -h / 2 + hb / 2]), np.array([l, w, hb])
    hc, lc = h - hb, 0.55 * l
    cab_c, cab_d = np.array([-0.05 * l, 0, -h / 2 + hb + hc / 2]), np.array([lc, 0.92 * w, hc])
    return [
        (
            body_c,
            body_d,
            {
                "side": tx.vehicle_side(l, hb, colour, rng, kind="car_body"),
                "front": tx.vehicle_end(w, hb, colour, rng, front=True, kind="car_body"),
                "rear": tx.vehicle_end(w, hb, colour, rng, front=False, kind="car_body"),
                "top": tx.plain_face(w, l, colour, rng),
            },
        ),
        (
            cab_c,
            cab_d,
            {
                "side": tx.vehicle_side(
                    lc,
                    hc,
                    colour,
                    rng,
                    kind="car_cabin",
                    window_band=(0.12, 0.92),
                    wheels=False,
                ),
                "front": tx.vehicle_end(
                    0.92 * w, hc, colour, rng, front=True, kind="car_cabin"
                ),
                "rear": tx.vehicle_end(
                    0.92 * w, hc, colour, rng, front=False, kind="car_cabin"
                ),
                "top": tx.plain_face(0.92 * w, lc, colour, rng),
            },
        ),
    ]


def _bus_parts(dims, colour, rng):
    """A bus: one box (as :func:`_vehicle_parts`)."""
    l, w, h = dims
    return [
        (
            np.zeros(3),
            np.array([l, w, h]),
            {
                "side": tx.vehicle_side(
                    l, h, colour, rng, kind="bus", window_band=(0.18, 0.55), lit_windows=0.9
                ),
                "front": tx.vehicle_end(w, h, colour, rng, front=True, kind="bus"),
                "rear": tx.vehicle_end(w, h, colour, rng, front=False, kind="bus"),
                "top": tx.plain_face(w, l, (200, 200, 200), rng, ppm=10),
            },
        )
    ]


def _truck_parts(dims, colour, rng):
    """A heavy truck: cab and trailer (as :func:`_vehicle_parts`)."""
    l, w, h = dims
    lc, hc = 2.4, 0.8 * h
    lt = l - lc - 0.5
    trailer_rgb = (
        (235, 235, 235) if rng.random() < 0.5 else tuple(int(c) for c in rng.integers(60, 230, 3))
    )
    return [
        (
            np.array([l / 2 - lc / 2, 0, -h / 2 + hc / 2]),
            np.array([lc, w, hc]),
            {
                "side": tx.vehicle_side(lc, hc, colour, rng, kind="cab", window_band=(0.08, 0.42)),
                "front": tx.vehicle_end(w, hc, colour, rng, front=True, kind="cab"),
                "rear": tx.plain_face(w, hc, colour, rng),
                "top": tx.plain_face(w, lc, colour, rng),
            },
        ),
        (
            np.array([-l / 2 + lt / 2, 0, 0]),
            np.array([lt, w, h]),
            {
                "side": tx.vehicle_side(lt, h, trailer_rgb, rng, kind="trailer"),
                "front": tx.plain_face(w, h, trailer_rgb, rng, ppm=20),
                "rear": tx.vehicle_end(w, h, trailer_rgb, rng, front=False, kind="trailer"),
                "top": tx.plain_face(w, lt, trailer_rgb, rng, ppm=10),
            },
        ),
    ]


def _add_buildings(a: Assets, world: World, rng: np.random.Generator) -> None:
    """The buildings' faces and facade textures into ``a`` (``static_*``)."""
    lit = world.lighting
    sc, sn, st = [], [], []
    for bld in world.buildings:
        corners, normals = box_faces(np.zeros(3), bld["dims"])
        c, s = np.cos(bld["yaw"]), np.sin(bld["yaw"])
        R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        lit_frac = 0.35 if lit != "daytime" else 0.0
        for j, name in enumerate(FACE_NAMES):
            if name == "top":
                mat = tx.plain_face(bld["dims"][1], bld["dims"][0], (110, 105, 100), rng, ppm=2)
            else:
                width = bld["dims"][1] if name in ("front", "rear") else bld["dims"][0]
                mat = tx.facade(width, bld["dims"][2], bld["colour"], rng, lit=lit_frac)
            sc.append(corners[j] @ R.T + bld["centre"])
            sn.append(R @ normals[j])
            st.append(a.add(mat, lit, _SHADE[name]))
    a.static_corners = np.array(sc, float).reshape(-1, 4, 3)
    a.static_normals = np.array(sn, float).reshape(-1, 3)
    a.static_tex = np.array(st, np.int64)


def build_assets(world: World, rng: np.random.Generator) -> Assets:
    """Textures and face tables of every actor and every piece of scenery.

    Parameters
    ----------
    world : World
        The clip's world.
    rng : numpy.random.Generator
        Source of the textures' randomness.

    Returns
    -------
    Assets
    """
    lit = world.lighting
    a = Assets()
    ac, an, at, ao = [], [], [], []
    for k, actor in enumerate(world.actors):
        if actor.label_class in ("person", "rider"):
            if actor.label_class == "person":
                front, side = people.person_views(float(actor.dims[2]), rng)
            else:
                front, side = people.rider_views(float(actor.dims[0]), float(actor.dims[2]), rng)
            ids = (a.add(front, lit, 0.9), a.add(side, lit, 0.9), a.add(side, lit, 0.9, flip=True))
            a.impostors[k] = ids + (front.shape[1] / 80.0, side.shape[1] / 80.0)
            continue
        for centre, dims, mats in _vehicle_parts(actor.label_class, actor.dims, actor.colour, rng):
            corners, normals = box_faces(centre, dims)
            for j, name in enumerate(FACE_NAMES):
                mat = mats["side"] if name in ("left", "right") else mats[name]
                ac.append(corners[j])
                an.append(normals[j])
                at.append(a.add(mat, lit, _SHADE[name], flip=(name == "right")))
                ao.append(k)
    a.actor_corners = np.array(ac, float).reshape(-1, 4, 3)
    a.actor_normals = np.array(an, float).reshape(-1, 3)
    a.actor_tex = np.array(at, np.int64)
    a.actor_owner = np.array(ao, np.int64)

    _add_buildings(a, world, rng)

    tree_ids = [a.add(tx.tree_texture(9.0, rng), lit, 0.85) for _ in range(6)]
    lamp_id = a.add(tx.lamp_texture(7.5), lit, 0.9)
    if lit != "daytime":  # a soft glow around lit lamp heads
        t = a.textures[lamp_id]
        glow = cv2.GaussianBlur(t[..., :3], (0, 0), 3)
        t[..., :3] = np.maximum(t[..., :3], glow)
    bb, bs, bt = [], [], []
    for item in world.billboards:
        h = item["height"]
        if item["kind"] == "tree":
            tid = tree_ids[int(rng.integers(len(tree_ids)))]
        else:
            tid = lamp_id
        tex = a.textures[tid]
        bb.append(item["base"])
        bs.append((h * tex.shape[1] / tex.shape[0], h))
        bt.append(tid)
    a.bb_base = np.array(bb, float).reshape(-1, 3)
    a.bb_size = np.array(bs, float).reshape(-1, 2)
    a.bb_tex = np.array(bt, np.int64)
    return a
