"""Impostor textures of people: pedestrians (front and side views) and bicycle riders.

Layer: nvrq core, synth (synthetic scenes).

Figures are drawn with OpenCV primitives (head, hair, torso, arms, legs; bicycle wheels
and frame) on a transparent :class:`~nvrq.synth.textures.Material` at 80 texels per metre.

>>> import numpy as np
>>> front, side = person_views(1.75, np.random.default_rng(0))
>>> front.shape, bool(front.alpha.any()), bool(front.alpha[0, 0])   # figure drawn, corners clear
((140, 56), True, False)
"""

from __future__ import annotations

import cv2
import numpy as np

from nvrq.synth.textures import CAR_COLOURS, Material, bgr

__all__ = ["person_views", "rider_views"]


def _human(
    m: Material,
    rng,
    *,
    side: bool,
    cx: float,
    top: float,
    scale: float,
    colours,
    seated: bool = False,
) -> None:
    """Draw a person (head, torso, arms, legs) into ``m`` (pixel units, scale px/m)."""
    skin, shirt, pants, hair = colours
    s = scale
    head_c = (int(cx), int(top + 0.12 * s))
    cv2.circle(m.albedo, head_c, int(0.11 * s), bgr(skin), -1, cv2.LINE_AA)
    cv2.ellipse(
        m.albedo,
        (head_c[0], head_c[1] - int(0.03 * s)),
        (int(0.11 * s), int(0.08 * s)),
        0,
        180,
        360,
        bgr(hair),
        -1,
        cv2.LINE_AA,
    )
    cv2.circle(m.alpha, head_c, int(0.11 * s), 255, -1)
    tw = 0.16 if side else 0.22
    t0, t1 = top + 0.25 * s, top + 0.85 * s
    torso = np.array(
        [[cx - tw * s, t0], [cx + tw * s, t0], [cx + tw * 0.85 * s, t1], [cx - tw * 0.85 * s, t1]],
        np.int32,
    )
    for img, col in ((m.albedo, bgr(shirt)), (m.alpha, 255)):
        cv2.fillConvexPoly(img, torso, col)
    phase = rng.uniform(-1, 1)
    lw = max(int(0.07 * s), 2)
    hip = t1
    if seated:
        legs = [((cx, hip), (cx + 0.25 * s, hip + 0.25 * s), (cx + 0.1 * s, hip + 0.6 * s))]
        arms = [((cx, t0 + 0.05 * s), (cx + 0.35 * s, t0 + 0.25 * s))]
    elif side:
        a = 0.25 * phase
        legs = [
            ((cx, hip), (cx + a * s, hip + 0.45 * s), (cx + 1.3 * a * s, hip + 0.88 * s)),
            ((cx, hip), (cx - a * s, hip + 0.45 * s), (cx - 1.1 * a * s, hip + 0.88 * s)),
        ]
        arms = [
            ((cx, t0 + 0.05 * s), (cx - a * s, t0 + 0.55 * s)),
            ((cx, t0 + 0.05 * s), (cx + a * s, t0 + 0.55 * s)),
        ]
    else:
        legs = [
            ((cx - 0.09 * s, hip), (cx - 0.1 * s, hip + 0.88 * s)),
            ((cx + 0.09 * s, hip), (cx + 0.1 * s, hip + 0.88 * s)),
        ]
        arms = [
            ((cx - tw * s, t0 + 0.05 * s), (cx - (tw + 0.06) * s, t0 + 0.6 * s)),
            ((cx + tw * s, t0 + 0.05 * s), (cx + (tw + 0.06) * s, t0 + 0.6 * s)),
        ]
    for chain, col, width in [(c, pants, int(lw * 1.4)) for c in legs] + [
        (c, shirt, lw) for c in arms
    ]:
        pts = [(int(x), int(y)) for x, y in chain]
        for p, q in zip(pts[:-1], pts[1:], strict=False):
            cv2.line(m.albedo, p, q, bgr(col), width, cv2.LINE_AA)
            cv2.line(m.alpha, p, q, 255, width)
        if col is shirt:  # hands
            cv2.circle(m.albedo, pts[-1], lw, bgr(skin), -1)
            cv2.circle(m.alpha, pts[-1], lw, 255, -1)


def _person_colours(rng):
    skins = [(240, 200, 170), (200, 150, 110), (140, 95, 60), (90, 60, 40)]
    shirts = [(200, 40, 40), (40, 80, 180), (240, 240, 240), (40, 40, 40),
              (230, 200, 40), (40, 150, 80), (160, 60, 160), (240, 130, 40)]
    pants = [(30, 30, 60), (40, 40, 40), (90, 90, 100), (120, 90, 60), (20, 60, 120)]
    hairs = [(30, 20, 10), (90, 60, 30), (200, 170, 90), (60, 60, 60)]
    pick = lambda lst: lst[int(rng.integers(len(lst)))]  # noqa: E731
    return pick(skins), pick(shirts), pick(pants), pick(hairs)


def person_views(height: float, rng) -> tuple[Material, Material]:
    """(front, side) impostor views of a pedestrian; alpha marks the figure.

    Parameters
    ----------
    height : float, metres
        The pedestrian's height; the figure is drawn at 80 px per metre.
    rng : numpy.random.Generator
        Picks the clothing colours and the figure's details.

    Returns
    -------
    front, side : Material
        RGBA views ``int(80 height)`` px high and 56 px wide.
    """
    ppm = 80
    h = int(height * ppm)
    cols = _person_colours(rng)
    views = []
    for side in (False, True):
        w = int(0.7 * ppm)
        m = Material.blank(h, w, (0, 0, 0), alpha=0)
        _human(m, rng, side=side, cx=w / 2, top=0, scale=ppm * height / 1.75 * 0.98, colours=cols)
        views.append(m)
    return views[0], views[1]


def rider_views(length: float, height: float, rng) -> tuple[Material, Material]:
    """(rear, side) impostor views of a bicycle rider; alpha marks rider and bicycle.

    Parameters
    ----------
    length, height : float, metres
        The rider box's length (the side view's width) and height.
    rng : numpy.random.Generator
        Picks the rider's colours and the bicycle frame's colour.

    Returns
    -------
    rear, side : Material
        Views at 80 px per metre.
    """
    ppm = 80
    h = int(height * ppm)
    cols = _person_colours(rng)
    frame_rgb = CAR_COLOURS[int(rng.integers(len(CAR_COLOURS)))]
    # side view
    w = int(length * ppm)
    side = Material.blank(h, w, (0, 0, 0), alpha=0)
    r = int(0.34 * ppm)
    wheels = [(r + 2, h - r - 2), (w - r - 2, h - r - 2)]
    for c in wheels:
        for img, col in ((side.albedo, bgr((20, 20, 20))), (side.alpha, 255)):
            cv2.circle(img, c, r, col, 4, cv2.LINE_AA)
            cv2.line(img, (c[0] - r, c[1]), (c[0] + r, c[1]), col, 1)
    seat = (int(0.42 * w), int(h - 0.95 * ppm))
    bar = (int(0.78 * w), int(h - 1.05 * ppm))
    crank = (int(0.5 * w), h - r - 2)
    for p, q in (
        (wheels[0], seat),
        (seat, crank),
        (crank, wheels[0]),
        (seat, bar),
        (crank, bar),
        (bar, wheels[1]),
    ):
        cv2.line(side.albedo, p, q, bgr(frame_rgb), 4, cv2.LINE_AA)
        cv2.line(side.alpha, p, q, 255, 4)
    _human(
        side,
        rng,
        side=True,
        cx=seat[0] + 0.08 * ppm,
        top=seat[1] - 0.95 * ppm,
        scale=ppm * 1.1,
        colours=cols,
        seated=True,
    )
    # rear view: narrow figure above a thin wheel
    wr = int(0.7 * ppm)
    rear = Material.blank(h, wr, (0, 0, 0), alpha=0)
    for img, col in ((rear.albedo, bgr((20, 20, 20))), (rear.alpha, 255)):
        cv2.rectangle(img, (wr // 2 - 3, h - 2 * r - 2), (wr // 2 + 3, h - 1), col, -1)
    cv2.circle(rear.albedo, (wr // 2, h - int(0.55 * ppm)), 5, bgr((230, 20, 20)), -1)
    cv2.circle(rear.emissive, (wr // 2, h - int(0.55 * ppm)), 5, bgr((255, 40, 40)), -1)
    _human(
        rear, rng, side=False, cx=wr / 2, top=seat[1] - 0.95 * ppm, scale=ppm * 1.05, colours=cols
    )
    return rear, side
