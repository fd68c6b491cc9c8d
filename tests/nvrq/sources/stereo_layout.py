"""A small synthetic rectified stereo pair written as ``nvrq import stereo`` reads one (the
Argoverse layout: JPEG/PNG images, a uint16 objects-only disparity PNG with value = 256 * d,
a JSON calibration), built from a known scene so tests get it back.

The scene (pixels, fx = fy = 300, cx = 160, cy = 120, baseline 0.5 m): a textured background
at disparity 8 (the right image is the left one moved 8 px left) and two textured objects,
``A`` over columns 60..120, rows 80..150 at disparity 30 (Z = 300 * 0.5 / 30 = 5 m) and ``B``
over columns 180..260, rows 100..180 at disparity 15 (Z = 10 m). The disparity map holds one
LiDAR-like scan line every 5 rows on each object.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

W, H = 320, 240
FX, CX, CY = 300.0, 160.0, 120.0
BASELINE = 0.5
BACKGROUND_D = 8
#: name -> (x0, y0, x1, y1) inclusive in the left image, disparity
OBJECTS = {"A": ((60, 80, 120, 150), 30), "B": ((180, 100, 260, 180), 15)}


def _texture(rng, h, w):
    import cv2

    t = rng.integers(0, 256, (h, w, 3)).astype(np.uint8)
    return cv2.GaussianBlur(t, (5, 5), 1.2)


def write_pair(d: Path, *, right_dy: int = 0, right_size=None, disparity_size=None) -> dict:
    """Write ``left.png``, ``right.png``, ``disparity.png`` and ``calib.json`` into ``d``.

    ``right_dy`` moves the right image down by that many rows (a pair that is not rectified);
    ``right_size`` / ``disparity_size`` ``(W, H)`` resize those files (bad inputs).
    Returns the paths by name.
    """
    import cv2

    d = Path(d)
    d.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    bg = _texture(rng, H, W + BACKGROUND_D)
    left, right = bg[:, :W].copy(), bg[:, BACKGROUND_D:].copy()
    disp = np.zeros((H, W), np.uint16)
    for (x0, y0, x1, y1), dd in OBJECTS.values():
        tex = _texture(rng, y1 - y0 + 1, x1 - x0 + 1)
        left[y0:y1 + 1, x0:x1 + 1] = tex
        right[y0:y1 + 1, x0 - dd:x1 - dd + 1] = tex
        disp[y0:y1 + 1:5, x0:x1 + 1] = dd * 256
    if right_dy:
        right = np.roll(right, right_dy, axis=0)
    if right_size is not None:
        right = cv2.resize(right, right_size)
    if disparity_size is not None:
        disp = cv2.resize(disp, disparity_size, interpolation=cv2.INTER_NEAREST)
    paths = {k: d / f for k, f in (("left", "left.png"), ("right", "right.png"), ("disparity", "disparity.png"),
                                    ("calibration", "calib.json"))}
    cv2.imwrite(str(paths["left"]), left)
    cv2.imwrite(str(paths["right"]), right)
    cv2.imwrite(str(paths["disparity"]), disp)
    paths["calibration"].write_text(json.dumps({"focal_length": [FX, FX], "principal_point": [CX, CY]}))
    return paths


def import_argv(paths: dict, out, *, baseline=BASELINE) -> list[str]:
    """``nvrq import stereo`` arguments for ``paths`` (without the program name)."""
    return ["import", "stereo", str(paths["left"]), str(paths["right"]), "--calibration",
            str(paths["calibration"]), "--baseline", str(baseline), "--disparity", str(paths["disparity"]), str(out)]
