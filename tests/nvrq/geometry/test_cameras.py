"""Camera models against outside references: OpenCV's projectPoints (12-coefficient pinhole,
fisheye), NVIDIA NCore's own f-theta numbers, hand-derived fold limits, and round trips."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from data_schema.errors import InputError
from nvrq.geometry.cameras import CAMERA_MODEL_TYPES, CameraModel, camera_from_model

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
FTHETA_VECTORS = SHARED / "ref" / "ftheta_vectors.json"

PINHOLE = {"type": "pinhole", "resolution": [1920, 1080], "focal_length": [1200.0, 1190.0],
           "principal_point": [955.2, 541.7]}
# a moderately distorted automotive camera with every coefficient group in use
OPENCV_MILD = {
    "type": "opencv_pinhole",
    "resolution": [1920, 1208],
    "focal_length": [1010.5, 1008.2],
    "principal_point": [962.3, 598.1],
    "radial_coeffs": [-0.12, 0.03, -0.004, 0.02, 0.001, 0.0005],
    "tangential_coeffs": [0.0008, -0.0004],
    "thin_prism_coeffs": [0.0007, -0.0002, 0.0005, 0.0001],
}
# wide-angle barrel distortion that folds back (r*icD(r^2) peaks) inside a 120 deg cone
OPENCV_WIDE = {"type": "opencv_pinhole", "resolution": [1280, 720], "focal_length": [520.0, 520.0],
               "principal_point": [639.5, 359.5], "radial_coeffs": [-0.32, 0.11, -0.015, 0.0, 0.0, 0.0],
               "tangential_coeffs": [0.0005, 0.0002]}
FISHEYE = {"type": "opencv_fisheye", "resolution": [1920, 1080], "focal_length": [560.0, 561.5],
           "principal_point": [958.4, 542.9], "radial_coeffs": [0.05, -0.012, 0.003, -0.0004]}
# k1 < 0 only: theta_d = theta - 0.3 theta^3 peaks at theta = 1/sqrt(0.9) < pi/2
FISHEYE_FOLD = {**FISHEYE, "focal_length": [900.0, 901.0], "radial_coeffs": [-0.3, 0.0, 0.0, 0.0]}
FTHETA_WIDE = {  # 200 deg f-theta: max_angle beyond pi/2
    "type": "ftheta",
    "resolution": [1280, 1280],
    "principal_point": [640.2, 639.1],
    "reference_poly": "ANGLE_TO_PIXELDIST",
    "pixeldist_to_angle_poly": [0.0, 0.0027, 0.0, 0.0, 0.0, 0.0],
    "angle_to_pixeldist_poly": [0.0, 370.0, 0.0, -8.0, 0.0, 0.0],
    "max_angle": 1.75,
    "linear_cde": [1.0005, 0.0002, -0.0001],
}
FTHETA_BW = {  # pixeldist_to_angle reference, inverted by Newton for projection
    "type": "ftheta",
    "resolution": [1920, 1080],
    "principal_point": [961.0, 538.4],
    "reference_poly": "PIXELDIST_TO_ANGLE",
    "pixeldist_to_angle_poly": [0.0, 1.05e-3, -2.1e-9, 5.5e-12, -8.0e-16, 0.0],
    "angle_to_pixeldist_poly": [0.0, 952.0, 0.0, 0.0, 0.0, 0.0],
    "max_angle": 1.1,
    "linear_cde": [0.9998, 0.0003, 0.0002],
}
MODELS = {
    "pinhole": PINHOLE,
    "opencv_mild": OPENCV_MILD,
    "opencv_wide": OPENCV_WIDE,
    "fisheye": FISHEYE,
    "fisheye_fold": FISHEYE_FOLD,
    "ftheta_wide": FTHETA_WIDE,
    "ftheta_bw": FTHETA_BW,
}
CAMERAS = {name: camera_from_model(m) for name, m in MODELS.items()}


def _K(model):
    (fx, fy), (cx, cy) = model["focal_length"], model["principal_point"]
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def _opencv_dist12(model):
    """OpenCV's distCoeffs order: k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4."""
    k = model.get("radial_coeffs", [0.0] * 6)
    p = model.get("tangential_coeffs", [0.0] * 2)
    s = model.get("thin_prism_coeffs", [0.0] * 4)
    return np.array([k[0], k[1], p[0], p[1], k[2], k[3], k[4], k[5], *s], dtype=np.float64)


def _points_within(cam: CameraModel, n: int, seed: int, frac: float = 0.97) -> np.ndarray:
    """(n, 3) random points in front of the camera with angle < frac * max_valid_angle."""
    rng = np.random.default_rng(seed)
    theta = np.arccos(rng.uniform(math.cos(frac * cam.max_valid_angle), 1.0, n))
    phi = rng.uniform(0, 2 * math.pi, n)
    depth = rng.uniform(0.5, 200.0, n)
    dirs = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], 1)
    return dirs * depth[:, None]


# ---------------------------------------------------------------- f-theta vs NVIDIA NCore


def _ncore_cameras():
    if not FTHETA_VECTORS.is_file():
        return []
    return json.loads(FTHETA_VECTORS.read_text())["cameras"]


@pytest.mark.skipif(not FTHETA_VECTORS.is_file(), reason="../shared/ref/ftheta_vectors.json absent")
@pytest.mark.parametrize("ref", _ncore_cameras(), ids=lambda c: c["name"])
def test_ftheta_matches_ncore_numbers(ref):
    # expected: NCore FThetaCameraModel.camera_rays_to_image_points (float64), converted to
    # pixel centres by the file's producer (uv_center = NCore uv - 0.5); see its 'about'
    cam = camera_from_model({"type": "ftheta", **ref["params"]})
    pts = np.array(ref["points"])
    uv, projectable = cam.project(pts)
    angle_ok = np.array(ref["angle_ok"])
    ncore_valid = np.array(ref["ncore_valid"])
    expected = np.array(ref["uv_center"])

    assert angle_ok.sum() > 100 and (~angle_ok).sum() > 20  # both kinds are exercised
    np.testing.assert_array_equal(projectable, angle_ok)
    np.testing.assert_allclose(uv[angle_ok], expected[angle_ok], rtol=0, atol=1e-3)
    # NCore's flag uses corner-origin pixels: 0 <= u + 0.5 < W, 0 <= v + 0.5 < H
    w, h = cam.resolution
    corner = uv + 0.5
    in_corner_image = (
        (corner[:, 0] >= 0) & (corner[:, 0] < w) & (corner[:, 1] >= 0) & (corner[:, 1] < h)
    )
    np.testing.assert_array_equal(projectable & in_corner_image, ncore_valid)
    # and unproject inverts NCore's projections back onto the original rays
    rays = cam.unproject(expected[angle_ok])
    dirs = pts[angle_ok] / np.linalg.norm(pts[angle_ok], axis=1, keepdims=True)
    np.testing.assert_allclose(rays, dirs, atol=1e-9)


# ---------------------------------------------------------------- OpenCV references


@pytest.mark.parametrize("name", ["pinhole", "opencv_mild", "opencv_wide"])
def test_pinhole_models_match_cv2_project_points(name):
    model, cam = MODELS[name], CAMERAS[name]
    pts = _points_within(cam, 5000, seed=1)
    uv, projectable = cam.project(pts)
    assert projectable.all()
    # expected: cv2.projectPoints with the 12-coefficient rational + thin-prism model
    ref, _ = cv2.projectPoints(
        pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), _K(model), _opencv_dist12(model)
    )
    np.testing.assert_allclose(uv, ref.reshape(-1, 2), rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", ["fisheye", "fisheye_fold"])
def test_fisheye_matches_cv2_fisheye_project_points(name):
    model, cam = MODELS[name], CAMERAS[name]
    pts = _points_within(cam, 5000, seed=2)
    uv, projectable = cam.project(pts)
    assert projectable.all()
    ref, _ = cv2.fisheye.projectPoints(
        pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), _K(model), np.array(model["radial_coeffs"])
    )
    np.testing.assert_allclose(uv, ref.reshape(-1, 2), rtol=0, atol=1e-6)


def test_opencv_unproject_matches_cv2_undistort_points():
    # expected: OpenCV's iterative undistortion (normalised x/z, y/z), run to convergence
    model, cam = OPENCV_MILD, CAMERAS["opencv_mild"]
    rng = np.random.default_rng(5)
    w, h = cam.resolution
    uv = rng.uniform([0, 0], [w - 1, h - 1], size=(2000, 2))
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 1000, 1e-15)
    ref = cv2.undistortPoints(
        uv.reshape(-1, 1, 2), _K(model), _opencv_dist12(model), None, None, None, criteria
    ).reshape(-1, 2)
    rays = cam.unproject(uv)
    np.testing.assert_allclose(rays[:, :2] / rays[:, 2:], ref, rtol=0, atol=1e-9)


def test_fold_limits_equal_hand_derived_values():
    # r + k1 r^3 has d/dr = 1 + 3 k1 r^2 = 0 at r = 1/sqrt(-3 k1)
    cam = camera_from_model(
        {**PINHOLE, "type": "opencv_pinhole", "radial_coeffs": [-0.5] + [0] * 5}
    )
    assert cam.max_valid_angle == pytest.approx(math.atan(1 / math.sqrt(1.5)), abs=1e-9)
    # theta - 0.3 theta^3: fold at theta = 1/sqrt(0.9)
    assert CAMERAS["fisheye_fold"].max_valid_angle == pytest.approx(1 / math.sqrt(0.9), abs=1e-9)
    # f-theta 370 t - 8 t^3 increases up to sqrt(370/24) > max_angle: capped by pi/2 (z > 0)
    assert CAMERAS["ftheta_wide"].max_valid_angle == pytest.approx(math.pi / 2)
    # a rational model with a pole: 1 / (1 - 0.5 r^2) blows up at r^2 = 2; the radial
    # function r / (1 - 0.5 r^2) increases until then, so the limit is the pole
    pole = camera_from_model(
        {**PINHOLE, "type": "opencv_pinhole", "radial_coeffs": [0, 0, 0, -0.5, 0, 0]}
    )
    assert pole.max_valid_angle == pytest.approx(math.atan(math.sqrt(2)), abs=1e-9)
    # ideal models: the whole front half-space
    assert CAMERAS["pinhole"].max_valid_angle == math.pi / 2
    assert CAMERAS["fisheye"].max_valid_angle == math.pi / 2


def test_points_past_the_fold_are_not_projectable_although_opencv_maps_them_inside():
    # Issue 2: "for wide-angle models a point behind the camera can map inside the image;
    # such a box must never be kept". Past the fold OpenCV's formula lands back in the image.
    model, cam = OPENCV_WIDE, CAMERAS["opencv_wide"]
    r = np.tan(cam.max_valid_angle) * np.array([1.1, 1.2, 1.3])  # 2-6 deg past the fold
    pts = np.stack([r, 0.3 * r, np.ones_like(r)], axis=1)
    ref, _ = cv2.projectPoints(
        pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), _K(model), _opencv_dist12(model)
    )
    assert cam.in_image(ref.reshape(-1, 2)).all()  # the hazard is real
    uv, projectable = cam.project(pts)
    assert not projectable.any() and np.isnan(uv).all()


def test_ftheta_wider_than_180_degrees_still_needs_positive_depth():
    # max_angle = 1.75 rad (200 deg FOV), but docs/FORMATS.md §3 requires positive depth
    cam = CAMERAS["ftheta_wide"]
    theta = np.array([1.5, 1.55, 1.6, 1.7])  # the last two are behind the image plane
    pts = np.stack([np.sin(theta), np.zeros(4), np.cos(theta)], axis=1)
    _, projectable = cam.project(pts)
    assert projectable.tolist() == [True, True, False, False]


# ---------------------------------------------------------------- round trips and shapes


@pytest.mark.parametrize("name", sorted(MODELS))
def test_project_unproject_round_trip_on_pixel_grid(name):
    cam = CAMERAS[name]
    w, h = cam.resolution
    uv = np.stack(np.meshgrid(np.linspace(0, w - 1, 97), np.linspace(0, h - 1, 61)), axis=-1)
    rays = cam.unproject(uv)
    assert rays.shape == (61, 97, 3)
    ok = np.isfinite(rays).all(axis=-1)
    # every pixel has a ray, except where the image extends past the camera's valid cone
    if name in ("pinhole", "opencv_mild"):
        assert ok.all()
    else:
        assert ok.mean() > 0.5
    np.testing.assert_allclose(np.linalg.norm(rays[ok], axis=-1), 1.0, atol=1e-12)
    back, projectable = cam.project(rays * 7.5)
    np.testing.assert_array_equal(projectable, ok)
    np.testing.assert_allclose(back[ok], uv[ok], rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_leading_dims_are_kept(name):
    cam = CAMERAS[name]
    pts = _points_within(cam, 4 * 8, seed=3).reshape(4, 8, 3)
    uv, projectable = cam.project(pts)
    assert uv.shape == (4, 8, 2) and uv.dtype == np.float64 and projectable.shape == (4, 8)
    flat_uv, _ = cam.project(pts.reshape(-1, 3))
    np.testing.assert_array_equal(uv.reshape(-1, 2), flat_uv)
    assert cam.in_image(uv).shape == (4, 8)
    assert cam.unproject(uv).shape == (4, 8, 3)


def test_optical_axis_maps_to_principal_point():
    for name, cam in CAMERAS.items():
        uv, ok = cam.project(np.array([0.0, 0.0, 3.0]))
        assert ok and uv.shape == (2,)
        pp = np.array(MODELS[name]["principal_point"])
        np.testing.assert_allclose(uv, pp, atol=1e-6 if name.startswith("opencv") else 1e-12)
        if not name.startswith("opencv"):  # thin prism/tangential shift the centre slightly
            np.testing.assert_allclose(cam.unproject(pp), [0.0, 0.0, 1.0], atol=1e-12)


def test_in_image_uses_pixel_centres():
    cam = CAMERAS["pinhole"]
    uv = np.array([[0, 0], [1919, 1079], [1919.0001, 5], [-1e-9, 5], [5, 1079.5], [np.nan, 3]])
    assert cam.in_image(uv).tolist() == [True, True, False, False, False, False]


# ---------------------------------------------------------------- properties (hypothesis)

coord = st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False)


@settings(max_examples=300, deadline=None)
@given(x=coord, y=coord, z=st.floats(-1e4, 0.0), name=st.sampled_from(sorted(MODELS)))
def test_point_with_nonpositive_depth_is_never_projectable(x, y, z, name):
    uv, projectable = CAMERAS[name].project(np.array([x, y, z]))
    assert not projectable and np.isnan(uv).all()


@settings(max_examples=300, deadline=None)
@given(
    fu=st.floats(0.25, 0.75),
    fv=st.floats(0.25, 0.75),
    depth=st.floats(0.05, 1e4),
    name=st.sampled_from(sorted(MODELS)),
)
def test_point_well_inside_the_view_is_projectable_and_in_image(fu, fv, depth, name):
    cam = CAMERAS[name]
    w, h = cam.resolution
    pixel = np.array([fu * (w - 1), fv * (h - 1)])
    point = cam.unproject(pixel) * depth
    uv, projectable = cam.project(point)
    assert projectable and cam.in_image(uv)
    np.testing.assert_allclose(uv, pixel, atol=1e-6)


@settings(max_examples=300, deadline=None)
@given(x=coord, y=coord, z=coord, name=st.sampled_from(sorted(MODELS)))
def test_projectable_point_maps_back_onto_its_own_ray(x, y, z, name):
    # no fold-back: a projectable point's pixel unprojects to that point's direction
    cam = CAMERAS[name]
    p = np.array([x, y, z])
    uv, projectable = cam.project(p)
    if projectable:
        assert np.isfinite(uv).all()
        d = p / np.abs(p).max()  # scale first: |p| can underflow for tiny coordinates
        np.testing.assert_allclose(cam.unproject(uv), d / np.linalg.norm(d), atol=1e-7)


# ---------------------------------------------------------------- bad input


def test_registry_names():
    assert set(CAMERA_MODEL_TYPES) == {"pinhole", "opencv_pinhole", "opencv_fisheye", "ftheta"}


@pytest.mark.parametrize(
    ("model", "message"),
    [
        (
            {"type": "kannala", "resolution": [10, 10]},
            "camera model: type: expected one of "
            "{'pinhole', 'opencv_pinhole', 'opencv_fisheye', 'ftheta'}, got 'kannala'",
        ),
        (
            {k: v for k, v in FTHETA_BW.items() if k != "max_angle"},
            "camera model: ftheta.max_angle: expected this ftheta parameter to be present, got missing",
        ),
        (
            {**OPENCV_MILD, "radial_coeffs": [0.1, 0.2, 0.3, 0.4]},
            "camera model: opencv_pinhole.radial_coeffs: expected a list of 6 numbers, got shape 4",
        ),
        (
            {**FTHETA_BW, "angle_to_pixeldist_poly": [0.0, 952.0]},
            "camera model: ftheta.angle_to_pixeldist_poly: expected a list of 6 numbers, got shape 2",
        ),
        (
            {k: v for k, v in FISHEYE.items() if k != "focal_length"},
            "camera model: opencv_fisheye.focal_length: expected this opencv_fisheye parameter to be "
            "present, got missing",
        ),
        (
            {**PINHOLE, "focal_length": [1000.0, -5.0]},
            "camera model: pinhole.focal_length: expected a list of 2 positive numbers, got [1000.0, -5.0]",
        ),
        (
            {**PINHOLE, "principal_point": ["a", 3]},
            "camera model: pinhole.principal_point: expected a list of 2 numbers, "
            "got non-numeric or ragged values",
        ),
        (
            {**PINHOLE, "resolution": [1920.5, 1080]},
            "camera model: pinhole.resolution: expected two positive integers [W, H], got [1920.5, 1080.0]",
        ),
        (
            {**FTHETA_BW, "reference_poly": "FORWARD"},
            "camera model: ftheta.reference_poly: expected one of "
            "PIXELDIST_TO_ANGLE or ANGLE_TO_PIXELDIST, got 'FORWARD'",
        ),
        (
            {**FTHETA_BW, "linear_cde": [0.0, 1.0, 0.0]},
            "camera model: ftheta.linear_cde: expected [c, d, e] with c - e*d != 0 (invertible), got [0.0, 1.0, 0.0]",
        ),
        (
            {**FTHETA_BW, "pixeldist_to_angle_poly": [0.0, -1e-3, 0, 0, 0, 0]},
            "camera model: ftheta.pixeldist_to_angle_poly: expected a polynomial with c0 == 0 and "
            "c1 > 0 (increasing from the principal point), got [0.0, -0.001, 0.0, 0.0, 0.0, 0.0]",
        ),
    ],
    ids=[
        "unknown-type",
        "missing-max-angle",
        "radial-wrong-length",
        "poly-wrong-length",
        "missing-focal",
        "negative-focal",
        "non-numeric",
        "fractional-resolution",
        "bad-reference",
        "singular-cde",
        "decreasing-poly",
    ],
)
def test_bad_model_raises_input_error_naming_the_field(model, message):
    # names, lengths and defaults: data_schema.scene.validate_camera_model's wording (the one
    # validator); positive focal lengths and f-theta polynomials: the camera classes' checks
    with pytest.raises(InputError) as err:
        camera_from_model(model)
    assert str(err.value) == message


def test_field_prefix_names_the_scene_path():
    model = {k: v for k, v in FTHETA_BW.items() if k != "max_angle"}
    with pytest.raises(InputError, match=r"^scene.json: cameras.front.model.max_angle: expected"):
        camera_from_model(model, where="scene.json", field_prefix="cameras.front.model.")


def test_missing_opencv_coefficient_lists_mean_zeros():
    # an opencv_pinhole with no coefficient lists is the ideal pinhole (cv2 with zero distCoeffs)
    bare = camera_from_model({**PINHOLE, "type": "opencv_pinhole"})
    pts = _points_within(CAMERAS["pinhole"], 200, seed=4)
    np.testing.assert_array_equal(bare.project(pts)[0], CAMERAS["pinhole"].project(pts)[0])


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.parametrize("tiny", [5e-324, 1e-310, 1e-200])
def test_subnormal_point_projects_onto_its_own_ray(name, tiny):
    # regression: for x = y = z = 5e-324 the fisheye returned (0.627, 0.627, 0.463) because
    # hypot() of subnormals rounds; the direction (1, 1, 1) / sqrt(3) is exact by symmetry
    cam = CAMERAS[name]
    uv, projectable = cam.project(np.array([tiny, tiny, tiny]))
    uv_ref, projectable_ref = cam.project(np.array([1.0, 1.0, 1.0]))
    assert projectable == projectable_ref
    np.testing.assert_array_equal(uv, uv_ref)
    if projectable:
        np.testing.assert_allclose(cam.unproject(uv), np.full(3, 1 / np.sqrt(3)), atol=1e-7)


@pytest.mark.parametrize("name", ["fisheye", "ftheta_wide"])
def test_point_one_ulp_inside_the_angle_limit_unprojects_onto_its_ray(name):
    # regression: (0, 254, 1e-13) is 2.2e-16 rad inside the fisheye's pi/2 limit; the
    # inverted distortion came back at the limit itself and unproject gave NaN
    cam = CAMERAS[name]
    p = np.array([0.0, 254.0, 1e-13])
    uv, projectable = cam.project(p)
    assert projectable
    np.testing.assert_allclose(cam.unproject(uv), p / np.linalg.norm(p), atol=1e-7)
