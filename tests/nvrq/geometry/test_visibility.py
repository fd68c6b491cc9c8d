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
    rays = rays[np.isfinite(rays).all(axis=1)]  # a fisheye's pixels beyond its valid angle: no ray
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


SMALL = {
    "pinhole": {"type": "pinhole", "resolution": [160, 120], "focal_length": [120, 120],
                "principal_point": [79.5, 59.5]},
    "opencv": {"type": "opencv_pinhole", "resolution": [160, 120], "focal_length": [120, 120],
               "principal_point": [79.5, 59.5], "radial_coeffs": [-0.04, 0.01, 0, 0, 0, 0]},
    "opencv_strong": {"type": "opencv_pinhole", "resolution": [160, 120], "focal_length": [100, 100],
                      "principal_point": [79.5, 59.5], "radial_coeffs": [-0.25, 0.05, 0, 0, 0, 0]},
    "ftheta": {"type": "ftheta", "resolution": [160, 120], "principal_point": [79.5, 59.5],
               "reference_poly": "ANGLE_TO_PIXELDIST", "pixeldist_to_angle_poly": [0, 0.008, 0, 0, 0, 0],
               "angle_to_pixeldist_poly": [0, 125, 0, 0, 0, 0], "max_angle": 1.2},
    "fisheye": {"type": "opencv_fisheye", "resolution": [160, 120], "focal_length": [70, 70],
                "principal_point": [79.5, 59.5], "radial_coeffs": [0.05, 0.01, 0, 0]},
    # the image's corners beyond 90 degrees: pixels without a ray
    "fisheye_wide": {"type": "opencv_fisheye", "resolution": [160, 120], "focal_length": [40, 40],
                     "principal_point": [79.5, 59.5], "radial_coeffs": [0.05, 0.01, 0, 0]},
}


def _yawed(x, y, z, yaw):
    T = _pose(x, y, z)
    T[:3, :3] = [[np.cos(yaw), 0, np.sin(yaw)], [0, 1, 0], [-np.sin(yaw), 0, np.cos(yaw)]]
    return T


def test_box_beside_and_behind_the_camera_covers_like_the_dense_reference():
    # a long box from behind the camera to 4 m ahead, left of the optical axis, covers the
    # left quarter or so of a box 10 m ahead (rays with x / z below about -0.05)
    for name in ("pinhole", "opencv", "ftheta"):
        cam = camera_from_model(SMALL[name])
        T = np.stack([_pose(0, 0, 10), _pose(-1.6, 0, 0.5)])
        dims = np.array([[2.0, 2, 2], [2.8, 2, 7]])
        got = visible_fractions(cam, T, dims)
        ref = _dense_reference(cam, T, dims)
        assert 0.5 < ref[0] < 0.9, (name, ref)
        assert abs(got[0] - ref[0]) < 0.02, (name, got, ref)


@pytest.mark.parametrize("name", sorted(SMALL))
def test_occluders_near_the_camera_equal_dense_reference(name):
    """Boxes beside and behind the camera (not wholly projectable) in front of targets: the
    part inside the field of view is drawn (or, where the model has no such field of view,
    ray-cast) and matches a dense per-pixel ray cast."""
    from nvrq.geometry.visibility import _field_of_view

    cam = camera_from_model(SMALL[name])
    assert (_field_of_view(cam) is None) == (name == "fisheye_wide")
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(40):
        n_t, n_o = rng.integers(1, 3), rng.integers(1, 4)
        T = [_yawed(rng.uniform(-3, 3), rng.uniform(-1, 1), rng.uniform(6, 16), rng.uniform(0, np.pi))
             for _ in range(n_t)]
        T += [_yawed(rng.choice([-1, 1]) * rng.uniform(1.5, 4), rng.uniform(-0.5, 0.5), rng.uniform(-3, 3),
                     rng.uniform(-0.3, 0.3)) for _ in range(n_o)]
        T = np.stack(T)
        dims = np.r_[rng.uniform(1, 4, size=(n_t, 3)), np.c_[rng.uniform(1.5, 2.5, n_o), rng.uniform(1.2, 2, n_o),
                                                             rng.uniform(3, 8, n_o)]]
        only = np.arange(len(T)) < n_t
        got = visible_fractions(cam, T, dims, only=only)[:n_t]
        ref = _dense_reference(cam, T, dims)[:n_t]
        big = (_sizes(cam, T, dims) >= 20)[:n_t]
        assert (np.isfinite(got) == np.isfinite(ref))[big].all()
        both = big & np.isfinite(ref)
        if both.any():
            worst = max(worst, np.abs(got[both] - ref[both]).max())
    assert worst < 0.02, worst


def _crowded_frame(rng):
    """Targets ahead, some of them behind others, and boxes beside or behind the camera."""
    n_t, n_o = rng.integers(3, 8), rng.integers(0, 3)
    T = [_yawed(rng.uniform(-3, 3), rng.uniform(-1, 1), rng.uniform(5, 18), rng.uniform(0, np.pi))
         for _ in range(n_t)]
    T += [_yawed(rng.choice([-1, 1]) * rng.uniform(1.5, 4), rng.uniform(-0.5, 0.5), rng.uniform(-3, 3),
                 rng.uniform(-0.3, 0.3)) for _ in range(n_o)]
    dims = np.r_[rng.uniform(1, 4, size=(n_t, 3)),
                 np.c_[rng.uniform(1.5, 2.5, n_o), rng.uniform(1.2, 2, n_o), rng.uniform(3, 8, n_o)]]
    return np.stack(T), dims


@pytest.mark.parametrize("name", sorted(SMALL))
def test_under_a_threshold_values_at_or_above_it_are_exact_and_the_others_stay_below(name):
    """``min_visible``'s early stops: a box at or above the threshold gets the exact value, to
    the bit; one below it an upper bound of its value, still below the threshold (from its row
    spans, or from the rectangles of :func:`_rect_bound` before any span is drawn)."""
    from nvrq.geometry.visibility import GRID, _Rays, _visible_fractions

    cam = camera_from_model(SMALL[name])
    rng = np.random.default_rng(2)
    n_below = n_bounded = 0
    for _ in range(40):
        T, dims = _crowded_frame(rng)
        exact = visible_fractions(cam, T, dims)
        ruled = _visible_fractions(cam, T, dims, group=None, only=None, grid=GRID, rays=_Rays(cam), below=0.8)
        seen = np.isfinite(exact)
        assert np.array_equal(np.isfinite(ruled), seen)
        high = seen & (exact >= 0.8)
        assert np.array_equal(ruled[high], exact[high])
        low = seen & (exact < 0.8)
        assert (ruled[low] < 0.8).all() and (ruled[low] >= exact[low] - 1e-12).all()
        n_below += low.sum()
        n_bounded += (ruled[low] > exact[low]).sum()
    assert n_below > 40 and n_bounded > 0, (n_below, n_bounded)


def test_rectangle_bound_is_above_the_counted_fraction():
    """:func:`_rect_bound` against pixel centres counted one by one: random convex targets
    and occluders (hulls of random points), the bound at or above the true uncovered share."""
    from nvrq.geometry.visibility import _hull_table, _Points, _rect_bound

    rng = np.random.default_rng(3)
    w, h = 64, 48
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    centres = np.c_[uu.ravel(), vv.ravel()]

    def inside(poly):
        e = np.roll(poly, -1, axis=0) - poly
        side = e[:, 0] * (centres[:, None, 1] - poly[:, 1]) - e[:, 1] * (centres[:, None, 0] - poly[:, 0])
        return (side >= -1e-9).all(axis=1) | (side <= 1e-9).all(axis=1)

    tight = 0
    for _ in range(300):
        k = rng.integers(2, 5)
        at = rng.uniform([0, 0], [w, h]) + rng.uniform(-12, 12, (k, 2))  # the occluders about the target
        polys = [(c + rng.uniform(3, 25) * rng.uniform(-1, 1, (rng.integers(3, 9), 2))).astype(np.float32)
                 for c in at]
        _, p, q, ne, first = _hull_table(_Points(polys), np.arange(k))
        hull = [p[f:f + n] for f, n in zip(first, ne, strict=True)]
        t_in = inside(hull[0])
        if t_in.sum() < 5:
            continue
        covered = np.zeros(len(centres), bool)
        for poly in hull[1:]:
            covered |= inside(poly)
        truth = 1 - (t_in & covered).sum() / t_in.sum()
        got = _rect_bound((p, q, ne), np.array([0]), (np.zeros(k - 1, np.int64), np.arange(1, k)), (w, h))[0]
        assert got >= truth - 1e-12, (got, truth)
        tight += got < 1.0
    assert tight > 50


@pytest.mark.parametrize("name", ["opencv_strong", "ftheta", "fisheye"])
def test_edges_sampled_only_where_they_curve_give_the_fully_sampled_fractions(name, monkeypatch):
    """A silhouette edge drawn through its ends and middle alone (its middle near its chord)
    against every edge sampled (:data:`OUTLINE_SAMPLES` points each), small boxes on strongly
    curving models: the fractions move by 0.0003 on average (a few boxes by a pixel or two of
    an edge that runs along a pixel row), never by 0.02."""
    import nvrq.geometry.visibility as vis

    cam = camera_from_model(SMALL[name])
    rng = np.random.default_rng(4)
    moved = []
    for _ in range(30):
        T, dims = _crowded_frame(rng)
        adaptive = visible_fractions(cam, T, dims)
        monkeypatch.setattr(vis, "STRAIGHT_PX", 0.0)
        full = visible_fractions(cam, T, dims)
        monkeypatch.undo()
        assert np.array_equal(np.isfinite(adaptive), np.isfinite(full))
        both = np.isfinite(full) & (_sizes(cam, T, dims) >= 20)
        moved += list(np.abs(adaptive[both] - full[both]))
    assert len(moved) > 150
    assert np.mean(moved) < 0.0003 and np.max(moved) < 0.02, (np.mean(moved), np.max(moved))


def test_a_box_from_behind_the_camera_as_the_target_equals_the_dense_reference():
    """A target that does not project whole (a long box beside the camera, from behind it to
    6 m ahead) is sampled over its whole silhouette, not the box of its corners in front of the
    camera (its edges that cross behind the camera run off to the image's border); a box
    ahead that it runs into covers part of it."""
    T = np.stack([_yawed(1.93, -0.3, 2.22, -0.225), _yawed(-0.01, -0.59, 5.17, 1.25)])
    dims = np.array([[2.25, 1.86, 7.71], [3.95, 2.05, 3.94]])
    for name in ("pinhole", "opencv", "ftheta"):
        cam = camera_from_model(SMALL[name])
        got = visible_fractions(cam, T, dims)
        ref = _dense_reference(cam, T, dims)
        assert 0.6 < ref[0] < 0.95, (name, ref)
        assert np.abs(got - ref).max() < 0.02, (name, got, ref)
