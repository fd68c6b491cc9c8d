"""OpenCV fisheye camera (``opencv_fisheye``, as ``cv2.fisheye.projectPoints`` with alpha 0).

Layer: nvrq core, geometry.

For a camera-frame point at angle ``theta = atan2(hypot(x, y), z)`` from the optical axis:

    theta_d = theta (1 + k1 theta**2 + k2 theta**4 + k3 theta**6 + k4 theta**8)
    [u, v]  = [fx, fy] * theta_d * [x, y] / hypot(x, y) + [cx, cy]

``max_valid_angle`` is ``pi/2`` or, if smaller, the end of the range where ``theta_d`` increases
(found once by dense sampling, 20,001 angles in ``[0, pi/2]``, then bisection): past it,
points far outside the field of view would fold back into the image.
"""

from __future__ import annotations

import math

import numpy as np

from ._base import CameraModel, rays_from_angle, register_camera_model
from ._radial import MonotonicMap, horner, poly_derivative

__all__ = ["OpenCVFisheyeCamera"]


@register_camera_model
class OpenCVFisheyeCamera(CameraModel):
    """OpenCV fisheye; ``unproject`` inverts ``theta_d`` by table lookup and Newton steps.

    Parameters
    ----------
    resolution : (int, int)
        ``(W, H)`` of the image, pixels.
    focal_length : (float, float)
        ``(fx, fy)``: pixels per radian of the distorted angle ``theta_d``.
    principal_point : (float, float)
        ``(cx, cy)``, the image of the optical axis; pixels, pixel-centre convention.
    radial_coeffs : (4,) float, optional
        ``k1 .. k4`` of the odd polynomial ``theta_d(theta)``; zeros give the equidistant model.

    >>> cam = OpenCVFisheyeCamera(resolution=(200, 200), focal_length=(100, 100),
    ...                           principal_point=(99.5, 99.5), radial_coeffs=(0, 0, 0, 0))
    >>> uv, ok = cam.project(np.array([[1.0, 0.0, 1.0]]))  # equidistant: 100 * pi/4 px right
    >>> np.round(uv, 4).tolist(), ok.tolist()
    ([[178.0398, 99.5]], [True])
    """

    type_name = "opencv_fisheye"

    def __init__(self, *, resolution, focal_length, principal_point, radial_coeffs=(0.0,) * 4):
        super().__init__(resolution=resolution)
        self.focal_length = np.asarray(focal_length, dtype=np.float64).reshape(2)
        self.principal_point = np.asarray(principal_point, dtype=np.float64).reshape(2)
        self.radial_coeffs = np.asarray(radial_coeffs, dtype=np.float64).reshape(4)
        k1, k2, k3, k4 = self.radial_coeffs
        poly = np.array([0.0, 1.0, 0.0, k1, 0.0, k2, 0.0, k3, 0.0, k4])
        dpoly = poly_derivative(poly)
        self._map = MonotonicMap(
            lambda t: horner(poly, t),
            lambda t: horner(dpoly, t),
            np.linspace(0.0, math.pi / 2, 20001),
        )
        self.max_valid_angle = min(math.pi / 2, self._map.x_lim)

    def _project(self, x, y, z, rho, theta):
        safe = np.where(rho > 0, rho, 1.0)
        dist = self._map(theta)  # theta_d, normalised image units
        (fx, fy), (cx, cy) = self.focal_length, self.principal_point
        return fx * dist * (x / safe) + cx, fy * dist * (y / safe) + cy

    def _unproject(self, u, v):
        (fx, fy), (cx, cy) = self.focal_length, self.principal_point
        a, b = (u - cx) / fx, (v - cy) / fy
        theta = self._map.inverse(np.hypot(a, b))
        return rays_from_angle(self._valid_angle(theta), a, b)
