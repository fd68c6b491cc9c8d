"""Pinhole cameras: ideal (``pinhole``) and OpenCV's 12-coefficient model (``opencv_pinhole``).

Layer: nvrq core, geometry.

OpenCV model (``cv2.projectPoints`` with distCoeffs ``k1,k2,p1,p2,k3,k4,k5,k6,s1,s2,s3,s4``),
for ``a = x/z, b = y/z, s = a**2 + b**2``:

    icD = (1 + k1 s + k2 s**2 + k3 s**3) / (1 + k4 s + k5 s**2 + k6 s**3)
    a'  = a icD + 2 p1 a b + p2 (s + 2 a**2) + s1 s + s2 s**2
    b'  = b icD + p1 (s + 2 b**2) + 2 p2 a b + s3 s + s4 s**2
    u, v = fx a' + cx, fy b' + cy

Projectable range, found once per camera by dense sampling: the radial part
``r -> r icD(r**2)`` (``r = sqrt(s)``) must increase with a positive denominator (20,001
angles in ``[0, pi/2)``, then bisection), and the Jacobian of the full map
``(a, b) -> (a', b')`` must keep a positive determinant (1,024 radii x 256 azimuths below
the radial limit, then bisection); ``r_lim`` is the smaller radius and
``max_valid_angle = atan(r_lim)``. Beyond it a point (even one far outside the field of
view) can fold back into the image.
"""

from __future__ import annotations

import math

import numpy as np

from ._base import CameraModel, register_camera_model
from ._radial import MonotonicMap

__all__ = ["OpenCVPinholeCamera", "PinholeCamera"]


@register_camera_model
class PinholeCamera(CameraModel):
    """Ideal pinhole: ``u = fx x/z + cx``, ``v = fy y/z + cy``.

    Parameters
    ----------
    resolution : (int, int)
        Image width and height ``(W, H)``, pixels.
    focal_length : (float, float)
        ``(fx, fy)``: pixels per unit of ``x/z`` and of ``y/z``.
    principal_point : (float, float)
        ``(cx, cy)``: where the optical axis meets the image, pixels (pixel-centre convention).

    >>> cam = PinholeCamera(resolution=(640, 480), focal_length=(500, 500),
    ...                     principal_point=(319.5, 239.5))
    >>> uv, ok = cam.project(np.array([[1.0, -0.5, 10.0], [0.0, 0.0, -1.0]]))
    >>> uv.tolist(), ok.tolist()
    ([[369.5, 214.5], [nan, nan]], [True, False])
    """

    type_name = "pinhole"

    def __init__(self, *, resolution, focal_length, principal_point):
        super().__init__(resolution=resolution)
        self.focal_length = np.asarray(focal_length, dtype=np.float64).reshape(2)
        self.principal_point = np.asarray(principal_point, dtype=np.float64).reshape(2)
        self.max_valid_angle = math.pi / 2

    def _distort(self, a, b):
        return a, b

    def _project(self, x, y, z, rho, theta):
        a, b = self._distort(x / z, y / z)
        (fx, fy), (cx, cy) = self.focal_length, self.principal_point
        return fx * a + cx, fy * b + cy

    def _normalised(self, u, v):
        (fx, fy), (cx, cy) = self.focal_length, self.principal_point
        return (u - cx) / fx, (v - cy) / fy

    def _unproject(self, u, v):
        a, b = self._normalised(u, v)
        rays = np.stack([a, b, np.ones_like(a)], axis=-1)
        return rays / np.linalg.norm(rays, axis=-1, keepdims=True)


@register_camera_model
class OpenCVPinholeCamera(PinholeCamera):
    """OpenCV rational + tangential + thin-prism pinhole; equations in the module docstring.

    ``unproject`` inverts the distortion: radial-only inverse as a start, then 2D Newton
    steps with the analytic Jacobian, damped to stay inside the valid disk ``r < r_lim`` (at
    most 50, stopping once a step is below 1e-12 normalised units);
    pixels that do not converge or lie past the fold get NaN.

    Parameters
    ----------
    resolution, focal_length, principal_point
        As for :class:`PinholeCamera`; ``fx, fy`` scale the distorted ``a', b'``.
    radial_coeffs : (6,) float, optional
        ``k1 .. k6``: ``k1..k3`` in the numerator of ``icD``, ``k4..k6`` in its denominator.
    tangential_coeffs : (2,) float, optional
        ``p1, p2`` (decentering terms).
    thin_prism_coeffs : (4,) float, optional
        ``s1 .. s4`` (thin-prism terms, ``s1, s2`` on ``a'``, ``s3, s4`` on ``b'``).
    """

    type_name = "opencv_pinhole"

    def __init__(
        self,
        *,
        resolution,
        focal_length,
        principal_point,
        radial_coeffs=(0.0,) * 6,
        tangential_coeffs=(0.0, 0.0),
        thin_prism_coeffs=(0.0,) * 4,
    ):
        super().__init__(
            resolution=resolution, focal_length=focal_length, principal_point=principal_point
        )
        self.radial_coeffs = np.asarray(radial_coeffs, dtype=np.float64).reshape(6)
        self.tangential_coeffs = np.asarray(tangential_coeffs, dtype=np.float64).reshape(2)
        self.thin_prism_coeffs = np.asarray(thin_prism_coeffs, dtype=np.float64).reshape(4)
        k1, k2, k3, k4, k5, k6 = self.radial_coeffs
        self._num = np.array([1.0, k1, k2, k3])
        self._den = np.array([1.0, k4, k5, k6])
        grid = np.tan(np.linspace(0.0, math.pi / 2 - 1e-6, 20001))
        self._radial = MonotonicMap(
            lambda r: r * self._icd(r * r)[0],
            lambda r: self._icd(r * r, derivative=True)[2],
            grid,
            ok=lambda r: self._icd(r * r)[1] > 0,
            lookup_max=2.0 * self._corner_radius(),
        )
        self.r_lim = self._jacobian_limit(self._radial.x_lim)
        self.max_valid_angle = math.atan(self.r_lim)
        # largest distorted radius reachable from the valid disk (sampled): pixels beyond
        # it have no valid ray and skip the Newton iterations
        phi = np.linspace(0.0, 2 * math.pi, 256, endpoint=False)
        rr = np.tan(np.linspace(0.0, self.max_valid_angle, 1025))[:, None]
        self._rd_max = float(np.max(np.hypot(*self._distort(rr * np.cos(phi), rr * np.sin(phi)))))

    def _jacobian_limit(self, r_max: float) -> float:
        """Smallest radius ``<= r_max`` where ``det d(a', b')/d(a, b) <= 0`` in some direction."""
        phi = np.linspace(0.0, 2 * math.pi, 256, endpoint=False)
        cos, sin = np.cos(phi), np.sin(phi)

        def good(r: np.ndarray) -> np.ndarray:
            r = np.asarray(r, dtype=np.float64)[:, None]
            *_, ja_a, ja_b, jb_a, jb_b = self._distort_jac(r * cos, r * sin)
            return np.all(ja_a * jb_b - ja_b * jb_a > 0, axis=1)

        radii = np.tan(np.linspace(0.0, math.atan(r_max), 1025))
        bad = np.flatnonzero(~good(radii))
        if bad.size == 0:
            return r_max
        if bad[0] == 0:
            return 0.0
        lo, hi = float(radii[bad[0] - 1]), float(radii[bad[0]])
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if good(np.array([mid]))[0] else (lo, mid)
        return lo

    def _corner_radius(self) -> float:
        """Largest normalised distance from the principal point to an image corner."""
        w, h = self.resolution
        corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [-0.5, h - 0.5], [w - 0.5, h - 0.5]])
        return float(np.max(np.hypot(*self._normalised(corners[:, 0], corners[:, 1]))))

    def _icd(self, s, *, derivative=False):
        """``icD(s)``, its denominator, and (if asked) ``d(r icD(r^2))/dr`` and ``d icD/ds``."""
        n0, n1, n2, n3 = self._num
        d0, d1, d2, d3 = self._den
        num = n0 + s * (n1 + s * (n2 + s * n3))
        den = d0 + s * (d1 + s * (d2 + s * d3))
        icd = num / den
        if not derivative:
            return icd, den
        dnum = n1 + s * (2 * n2 + s * 3 * n3)
        dden = d1 + s * (2 * d2 + s * 3 * d3)
        dicd_ds = (dnum * den - num * dden) / (den * den)
        return icd, den, icd + 2 * s * dicd_ds, dicd_ds

    def _distort(self, a, b):
        p1, p2 = self.tangential_coeffs
        s1, s2, s3, s4 = self.thin_prism_coeffs
        s = a * a + b * b
        icd = self._icd(s)[0]
        ab2 = 2 * a * b
        a_d = a * icd + p1 * ab2 + p2 * (s + 2 * a * a) + s * (s1 + s * s2)
        b_d = b * icd + p1 * (s + 2 * b * b) + p2 * ab2 + s * (s3 + s * s4)
        return a_d, b_d

    def _distort_jac(self, a, b):
        """``(a', b')`` and the Jacobian ``d(a', b')/d(a, b)`` as ``(a', b', aa, ab, ba, bb)``."""
        p1, p2 = self.tangential_coeffs
        s1, s2, s3, s4 = self.thin_prism_coeffs
        s = a * a + b * b
        icd, _, _, dicd = self._icd(s, derivative=True)
        ab2 = 2 * a * b
        a_d = a * icd + p1 * ab2 + p2 * (s + 2 * a * a) + s * (s1 + s * s2)
        b_d = b * icd + p1 * (s + 2 * b * b) + p2 * ab2 + s * (s3 + s * s4)
        # ds/da = 2a, ds/db = 2b
        ta, tb = s1 + 2 * s * s2, s3 + 2 * s * s4
        ja_a = icd + 2 * a * a * dicd + 2 * p1 * b + 6 * p2 * a + 2 * a * ta
        ja_b = ab2 * dicd + 2 * p1 * a + 2 * p2 * b + 2 * b * ta
        jb_a = ab2 * dicd + 2 * p1 * a + 2 * p2 * b + 2 * a * tb
        jb_b = icd + 2 * b * b * dicd + 6 * p1 * b + 2 * p2 * a + 2 * b * tb
        return a_d, b_d, ja_a, ja_b, jb_a, jb_b

    def _newton_step(self, a, b, ta, tb):
        """One Newton step of ``distort(a, b) == (ta, tb)``: returns ``(da, db)`` to subtract."""
        a_d, b_d, ja_a, ja_b, jb_a, jb_b = self._distort_jac(a, b)
        fa, fb = a_d - ta, b_d - tb
        det = ja_a * jb_b - ja_b * jb_a
        return (jb_b * fa - ja_b * fb) / det, (ja_a * fb - jb_a * fa) / det

    def _unproject(self, u, v):
        ta, tb = self._normalised(u, v)
        # start: invert the radial part only, inside the valid disk (tangential terms can
        # push a valid pixel slightly past the radial maximum)
        rd = np.hypot(ta, tb)
        rd = np.where(rd <= self._rd_max * (1 + 1e-3), rd, np.nan)
        r0 = self._radial.inverse(np.minimum(rd, self._radial.y_lim), iterations=1)
        r0 = np.minimum(r0, self.r_lim * (1 - 1e-9))
        scale = np.where(rd > 0, r0 / np.where(rd > 0, rd, 1.0), np.where(rd == 0, 1.0, np.nan))
        a, b = (ta * scale).ravel(), (tb * scale).ravel()
        fta, ftb = ta.ravel(), tb.ravel()
        r2_lim = self.r_lim**2
        active = np.flatnonzero(np.isfinite(a) & np.isfinite(b))  # not yet converged
        for _ in range(50):
            if active.size == 0:
                break
            a0, b0 = a[active], b[active]
            da, db = self._newton_step(a0, b0, fta[active], ftb[active])
            # damped: halve steps that would leave the valid disk (and cross the fold)
            out = np.flatnonzero((a0 - da) ** 2 + (b0 - db) ** 2 >= r2_lim)
            for _ in range(40):
                if out.size == 0:
                    break
                da[out] *= 0.5
                db[out] *= 0.5
                out = out[(a0[out] - da[out]) ** 2 + (b0[out] - db[out]) ** 2 >= r2_lim]
            a[active], b[active] = a0 - da, b0 - db
            active = active[
                np.abs(da) + np.abs(db) > 1e-12 * (1 + np.abs(a[active]) + np.abs(b[active]))
            ]
        a, b = a.reshape(ta.shape), b.reshape(tb.shape)
        fa, fb = self._distort(a, b)
        converged = np.hypot(fa - ta, fb - tb) <= 1e-9 * (1 + rd)
        inside = np.hypot(a, b) < self.r_lim
        ok = converged & inside
        rays = np.stack([a, b, np.ones_like(a)], axis=-1)
        rays = rays / np.linalg.norm(rays, axis=-1, keepdims=True)
        rays[~ok] = np.nan
        return rays
