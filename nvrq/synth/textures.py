"""Procedural textures of the synthetic scenes: vehicles, buildings, trees and lamps.

Layer: nvrq core, synth (synthetic scenes).

A texture is drawn as a :class:`Material` (albedo, emissive light, alpha) and turned into
the final ``(H, W, 4)`` uint8 **BGR-A** image by :func:`finalize` for the clip's lighting
(day: albedo times a flat-shading factor; night: dim albedo plus the lit lamps).
All colours in this module are written RGB and converted with :func:`bgr`.

Convention: a texture's column axis runs along the face's first edge (left to right seen
from outside the object), its row axis downwards; ``PPM`` texels per metre.

>>> m = Material.blank(10, 20, (200, 10, 10))
>>> finalize(m, lighting="daytime", shade=1.0).shape
(10, 20, 4)
>>> tuple(int(v) for v in finalize(m, lighting="daytime", shade=1.0)[0, 0])  # BGR-A
(10, 10, 200, 255)
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = [
    "Material",
    "finalize",
    "bgr",
    "PPM",
    "CAR_COLOURS",
    "vehicle_side",
    "vehicle_end",
    "plain_face",
    "tree_texture",
    "lamp_texture",
    "facade",
]

PPM = 40  # texels per metre on vehicles
CAR_COLOURS = [(200, 30, 30), (30, 60, 170), (230, 230, 230), (25, 25, 25), (150, 150, 155),
               (20, 110, 50), (220, 180, 20), (120, 20, 30), (90, 140, 200), (200, 100, 30)]


def bgr(rgb) -> tuple[int, int, int]:
    """RGB triple -> BGR triple of ints (OpenCV's drawing order).

    Parameters
    ----------
    rgb : (3,) int
        Red, green, blue.

    Returns
    -------
    (int, int, int)
        Blue, green, red.
    """
    return int(rgb[2]), int(rgb[1]), int(rgb[0])


@dataclass
class Material:
    """albedo, emissive: (H, W, 3) uint8 BGR; alpha: (H, W) uint8.

    Attributes
    ----------
    albedo : (H, W, 3) uint8
        BGR reflectance.
    emissive : (H, W, 3) uint8
        BGR light emitted at night.
    alpha : (H, W) uint8
        Coverage.
    """

    albedo: np.ndarray
    emissive: np.ndarray
    alpha: np.ndarray

    @classmethod
    def blank(cls, h: int, w: int, rgb, *, alpha: int = 255) -> Material:
        h, w = max(int(h), 2), max(int(w), 2)
        alb = np.empty((h, w, 3), np.uint8)
        alb[:] = bgr(rgb)
        return cls(alb, np.zeros((h, w, 3), np.uint8), np.full((h, w), alpha, np.uint8))

    @property
    def shape(self) -> tuple[int, int]:
        return self.albedo.shape[:2]


def _noise(m: Material, rng: np.random.Generator, amp: float) -> None:
    """Add low-frequency albedo noise (in place) so surfaces are not flat."""
    h, w = m.shape
    small = rng.normal(0.0, amp, (max(h // 8, 2), max(w // 8, 2), 1)).astype(np.float32)
    big = cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)[..., None]
    m.albedo[:] = np.clip(m.albedo.astype(np.float32) + big, 0, 255).astype(np.uint8)


def finalize(m: Material, *, lighting: str, shade: float) -> np.ndarray:
    """Material -> (H, W, 4) uint8 BGR-A texture for ``lighting`` in {'daytime', 'nighttime'}.

    Parameters
    ----------
    m : Material
        The drawn material: albedo, emissive parts and alpha.
    lighting : str
        ``{'daytime', 'nighttime'}``; at night the albedo dims to 16 % and the emissive parts
        are added.
    shade : float
        Flat-shading factor of the face, on the albedo.

    Returns
    -------
    (H, W, 4) uint8
        BGR-A texture, alpha from ``m``.
    """
    gain = shade if lighting == "daytime" else 0.16 * shade
    rgb = m.albedo.astype(np.float32) * gain
    if lighting != "daytime":
        rgb += m.emissive.astype(np.float32)
    out = np.empty(m.shape + (4,), np.uint8)
    out[..., :3] = np.clip(rgb, 0, 255).astype(np.uint8)
    out[..., 3] = m.alpha
    return out


def vehicle_side(
    length: float,
    height: float,
    rgb,
    rng,
    *,
    kind: str,
    window_band=(0.0, 0.0),
    wheels: bool = True,
    lit_windows: float = 0.0,
) -> Material:
    """Side of a vehicle part (length x height metres), optional window band and wheels.

    ``window_band`` = (top, bottom) as fractions of the height; ``kind`` in
    {'car_body', 'car_cabin', 'bus', 'cab', 'trailer'}.

    Parameters
    ----------
    length, height : float, metres
        Size of the face.
    rgb : (3,) int
        Body colour.
    rng : numpy.random.Generator
        Source of the texture's randomness.
    kind : str
        ``{'car_body', 'car_cabin', 'bus', 'cab', 'trailer'}``.
    window_band : (float, float), optional
        ``(top, bottom)`` of the windows, fractions of the height.
    wheels : bool, optional
        Draw wheels.
    lit_windows : float, optional
        Fraction of windows lit at night.

    Returns
    -------
    Material
    """
    w, h = int(length * PPM), int(height * PPM)
    m = Material.blank(h, w, rgb)
    _noise(m, rng, 6.0)
    top, bot = window_band
    if bot > top:
        y0, y1 = int(top * h), int(bot * h)
        if kind == "car_cabin":
            pts = np.array(
                [[int(0.12 * w), y1], [int(0.3 * w), y0], [int(0.78 * w), y0], [int(0.95 * w), y1]],
                np.int32,
            )
            cv2.fillConvexPoly(m.albedo, pts, bgr((40, 55, 70)))
            cv2.line(m.albedo, (int(0.55 * w), y0), (int(0.55 * w), y1), bgr(rgb), 3)
        else:
            n = max(int(length / 1.3), 1)
            for i in range(n):
                x0 = int((i + 0.1) * w / n)
                x1 = int((i + 0.9) * w / n)
                cv2.rectangle(m.albedo, (x0, y0), (x1, y1), bgr((45, 60, 75)), -1)
                if rng.random() < lit_windows:
                    cv2.rectangle(m.emissive, (x0, y0), (x1, y1), bgr((150, 140, 90)), -1)
    if kind in ("car_body", "bus", "trailer"):  # a darker stripe and door lines
        cv2.line(m.albedo, (0, int(0.55 * h)), (w, int(0.55 * h)), bgr((50, 50, 50)), 2)
    if kind == "bus":
        cv2.rectangle(
            m.albedo, (int(0.08 * w), int(0.2 * h)), (int(0.16 * w), h - 2), bgr((60, 60, 60)), 3
        )
    if wheels:
        r = int(0.36 * PPM) if kind in ("car_body",) else int(0.5 * PPM)
        xs = (0.17, 0.8) if kind != "trailer" else (0.62, 0.74, 0.86)
        for fx in xs:
            c = (int(fx * w), h - r // 3)
            cv2.circle(m.albedo, c, r, bgr((15, 15, 15)), -1, cv2.LINE_AA)
            cv2.circle(m.albedo, c, int(r * 0.55), bgr((160, 160, 165)), -1, cv2.LINE_AA)
            cv2.circle(m.albedo, c, int(r * 0.2), bgr((60, 60, 60)), -1, cv2.LINE_AA)
    return m


def vehicle_end(width: float, height: float, rgb, rng, *, front: bool, kind: str) -> Material:
    """Front or rear face of a vehicle part with lights (lit at night), grille, windscreen.

    Parameters
    ----------
    width, height : float, metres
        Size of the face.
    rgb : (3,) int
        Body colour.
    rng : numpy.random.Generator
        Draws the face's low-frequency noise.
    front : bool
        Front (white headlights, grille) or rear (red tail lights).
    kind : str
        The vehicle part, as for :func:`vehicle_side`; it places the lamps, windscreen and plate.

    Returns
    -------
    Material
        The face, ``PPM`` pixels per metre.
    """
    w, h = int(width * PPM), int(height * PPM)
    m = Material.blank(h, w, rgb)
    _noise(m, rng, 5.0)
    lamp = (255, 250, 220) if front else (230, 20, 20)
    ly = int(0.45 * h) if kind == "car_body" else int(0.82 * h)
    lr = max(int(0.09 * PPM), 2)
    for fx in (0.15, 0.85):
        c = (int(fx * w), ly)
        cv2.ellipse(m.albedo, c, (lr * 2, lr), 0, 0, 360, bgr(lamp), -1)
        cv2.ellipse(m.emissive, c, (lr * 2, lr), 0, 0, 360, bgr(lamp), -1)
    if kind in ("car_body", "cab", "bus") and front:
        cv2.rectangle(
            m.albedo,
            (int(0.3 * w), ly - lr),
            (int(0.7 * w), min(ly + 2 * lr, h - 1)),
            bgr((30, 30, 30)),
            -1,
        )
    if kind in ("car_cabin", "cab", "bus"):
        y0 = int(0.08 * h)
        y1 = int((0.9 if kind == "car_cabin" else 0.45) * h)
        cv2.rectangle(m.albedo, (int(0.08 * w), y0), (int(0.92 * w), y1), bgr((50, 65, 80)), -1)
    # number plate
    if kind in ("car_body", "bus", "cab", "trailer"):
        py = int(0.7 * h) if kind == "car_body" else int(0.9 * h)
        cv2.rectangle(
            m.albedo,
            (int(0.38 * w), py - 4),
            (int(0.62 * w), min(py + 4, h - 1)),
            bgr((235, 235, 225)),
            -1,
        )
    return m


def plain_face(width: float, height: float, rgb, rng, *, ppm: float = PPM) -> Material:
    """An untextured face (roof, plain trailer side) with a little noise.

    Parameters
    ----------
    width, height : float, metres
        Size of the face.
    rgb : (3,) int
        Colour.
    rng : numpy.random.Generator
        Source of the noise.
    ppm : float, optional
        Texels per metre.

    Returns
    -------
    Material
    """
    m = Material.blank(int(height * ppm), int(width * ppm), rgb)
    _noise(m, rng, 5.0)
    return m


def tree_texture(height: float, rng) -> Material:
    """A tree billboard: trunk and a blobby crown (alpha cut-out).

    Parameters
    ----------
    height : float, metres
        Tree height.
    rng : numpy.random.Generator
        Source of the texture's randomness.

    Returns
    -------
    Material
    """
    ppm = 12
    h, w = int(height * ppm), int(height * 0.6 * ppm)
    m = Material.blank(h, w, (0, 0, 0), alpha=0)
    tw = max(int(0.3 * ppm), 2)
    for img, col in ((m.albedo, bgr((90, 60, 35))), (m.alpha, 255)):
        cv2.rectangle(img, (w // 2 - tw // 2, int(0.5 * h)), (w // 2 + tw // 2, h - 1), col, -1)
    green = np.array([(40, 110, 40), (60, 130, 50), (30, 90, 35), (80, 140, 60)])
    for _ in range(14):
        c = (int(rng.uniform(0.25, 0.75) * w), int(rng.uniform(0.12, 0.55) * h))
        ax = (int(rng.uniform(0.12, 0.25) * w), int(rng.uniform(0.08, 0.16) * h))
        col = green[int(rng.integers(len(green)))]
        cv2.ellipse(m.albedo, c, ax, 0, 0, 360, bgr(col), -1)
        cv2.ellipse(m.alpha, c, ax, 0, 0, 360, 255, -1)
    return m


def lamp_texture(height: float) -> Material:
    """A street-lamp billboard: pole and a head that glows at night.

    Parameters
    ----------
    height : float, metres
        Lamp height.

    Returns
    -------
    Material
    """
    ppm = 20
    h, w = int(height * ppm), int(1.2 * ppm)
    m = Material.blank(h, w, (0, 0, 0), alpha=0)
    for img, col in ((m.albedo, bgr((110, 110, 115))), (m.alpha, 255)):
        cv2.rectangle(img, (w // 2 - 2, 4), (w // 2 + 2, h - 1), col, -1)
        cv2.rectangle(img, (2, 2), (w - 3, 9), col, -1)
    cv2.rectangle(m.emissive, (2, 2), (w - 3, 9), bgr((255, 230, 170)), -1)
    cv2.rectangle(m.albedo, (2, 6), (w - 3, 9), bgr((250, 240, 200)), -1)
    return m


def facade(width: float, height: float, rgb, rng, *, lit: float) -> Material:
    """A building facade with a grid of windows (a fraction ``lit`` glows at night).

    Parameters
    ----------
    width, height : float, metres
        Size of the facade.
    rgb : (3,) int
        Wall colour.
    rng : numpy.random.Generator
        Source of the texture's randomness.
    lit : float
        Fraction of windows lit at night.

    Returns
    -------
    Material
    """
    ppm = 10
    m = plain_face(width, height, rgb, rng, ppm=ppm)
    h, w = m.shape
    nx, ny = max(int(width / 3.0), 1), max(int(height / 3.2), 1)
    glass = bgr((60, 75, 95))
    for i in range(nx):
        for j in range(ny):
            x0, x1 = int((i + 0.25) * w / nx), int((i + 0.75) * w / nx)
            y0, y1 = int((j + 0.25) * h / ny), int((j + 0.7) * h / ny)
            cv2.rectangle(m.albedo, (x0, y0), (x1, y1), glass, -1)
            if rng.random() < lit:
                cv2.rectangle(m.emissive, (x0, y0), (x1, y1), bgr((200, 170, 100)), -1)
    cv2.rectangle(m.albedo, (0, h - 4), (w - 1, h - 1), bgr((70, 70, 70)), -1)
    return m
