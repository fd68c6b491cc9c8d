"""Visible fractions from boxes: a hand-built half occlusion and a dense per-pixel reference."""

import numpy as np
import pytest

from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.visibility import visible_fractions

PINHOLE = {"type": "pinhole", "resolution": [640, 480], "focal_length": [500, 500],
           "principal_point": [319.5, 239.5]}
FTHETA = {"type": "ftheta", "resolution": [640, 480], "principal_point": [319.5, 239.5],
          "reference_poly": "ANGLE_TO_PIXELDIST", "pixeldist_to_angle_poly": [0, 0.002, 0, 0, 0, 0],
          "angle_to_pixeldist_poly": [0, 500, 0, 0, 0, 0], "max_angle": 1.2}


def _pose(x, y, z):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


@pytest.mark.parametrize("model", [PINHOLE, FTHETA], ids=["pinhole", "ftheta"])
def test_half_covered(model):
    cam = camera_from_model(model)
    T = np.stack([_pose(0, 0, 10), _pose(-1, 0, 5)])
    dims = np.array([[2.0, 2.0, 2.0], [2.0, 2.0, 0.2]])  # occluder covers x < 0
    vis = visible_fractions(cam, T, dims)
    assert abs(vis[0] - 0.5) < 0.02
    assert vis[1] == 1.0


def _dense_reference(cam, T, dims):
    """Every pixel of the image: ray -> slab entry per box, written per box in a loop."""
    w, h = cam.resolution
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays = cam.unproject(np.stack([uu, vv], -1).reshape(-1, 2))
    entries = []
    for Tb, d in zip(T, dims, strict=True):
        R, c = Tb[:3, :3], Tb[:3, 3]
        o = R.T @ (-c)
        dl = rays @ R  # rows: R^T ray
        with np.errstate(divide="ignore", invalid="ignore"):
            a = (-d / 2 - o) / dl
            b = (d / 2 - o) / dl
        tn = np.nanmax(np.minimum(a, b), axis=1)
        tf = np.nanmin(np.maximum(a, b), axis=1)
        entries.append(np.where((tn <= tf) & (tf > 0), np.maximum(tn, 0), np.inf))
    E = np.array(entries)
    out = []
    for i in range(len(T)):
        sil = np.isfinite(E[i])
        if not sil.any():
            out.append(np.nan)
            continue
        occ = np.zeros(sil.sum(), bool)
        for j in range(len(T)):
            if j != i:
                occ |= E[j, sil] < E[i, sil]
        out.append(1 - occ.mean())
    return np.array(out)


def _sizes(cam, T, dims):
    w, h = cam.resolution
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays = cam.unproject(np.stack([uu, vv], -1).reshape(-1, 2))
    from nvrq.geometry.visibility import ray_box_entry
    return np.isfinite(ray_box_entry(rays, T, dims)).sum(axis=1)


def test_random_frames_equal_dense_reference():
    rng = np.random.default_rng(0)
    cam = camera_from_model({"type": "pinhole", "resolution": [160, 120],
                             "focal_length": [120, 120], "principal_point": [79.5, 59.5]})
    worst = 0.0
    for _ in range(200):
        n = rng.integers(2, 6)
        T = np.stack([_pose(rng.uniform(-4, 4), rng.uniform(-2, 2), rng.uniform(4, 20))
                      for _ in range(n)])
        for Tb in T:
            a = rng.uniform(0, 2 * np.pi)
            Tb[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
        dims = rng.uniform(0.5, 4, size=(n, 3))
        got = visible_fractions(cam, T, dims)
        ref = _dense_reference(cam, T, dims)
        both = np.isfinite(ref) & np.isfinite(got)
        # boxes the reference sees in at least 20 pixels (fewer cannot be told within 0.02)
        big = both & (_sizes(cam, T, dims) >= 20)
        assert (np.isfinite(got) == np.isfinite(ref))[_sizes(cam, T, dims) >= 20].all()
        if big.any():
            worst = max(worst, np.abs(got[big] - ref[big]).max())
    assert worst < 0.02, worst
