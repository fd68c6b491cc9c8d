"""NVIDIA f-theta camera (NCore's ``FThetaCameraModel`` parameters and behaviour).

Layer: nvrq core, geometry.

Model, for a camera-frame point at angle ``theta = atan2(hypot(x, y), z)``:

    rho = fw(theta)                                  # angle_to_pixeldist_poly, pixels
    [u, v] = A @ (rho * [x, y] / hypot(x, y)) + pp   # A = [[c, d], [e, 1]] (linear_cde)

and back: ``p = inv(A) @ ([u, v] - pp)``, ``theta = bw(|p|)`` (pixeldist_to_angle_poly).
The polynomial named by ``reference_poly`` is exact; the other direction is its numerical
inverse (Newton), as in NCore. Polynomials are ascending (``c0 + c1 t + ... + c5 t**5``).

Differences from NCore: ``principal_point`` stays in docs/FORMATS.md §1's pixel-centre convention
(NCore adds 0.5 internally and returns corner-origin coordinates); validity is split into
``projectable`` (``z > 0`` and ``theta < max_valid_angle``) and :meth:`in_image`.
``max_valid_angle = min(max_angle, pi/2, end of the reference polynomial's increasing
range)`` (the latter searched for ``theta <= pi/2``, or pixel distances up to four
image diagonals).
"""

from __future__ import annotations

import math

import numpy as np

from data_schema.scene import FTHETA_REFERENCE_POLYS

from ._base import CameraModel, ModelParams, rays_from_angle, register_camera_model
from ._radial import MonotonicMap, horner, poly_derivative

__all__ = ["FThetaCamera"]

_GRID = 20001


@register_camera_model
class FThetaCamera(CameraModel):
    """f-theta camera; see the module docstring for the equations.

    Parameters
    ----------
    resolution : (int, int)
        ``(W, H)`` in pixels.
    principal_point : (float, float)
        ``(cx, cy)`` in pixels, pixel-centre convention.
    reference_poly : str
        Which polynomial is exact, one of ``FTHETA_REFERENCE_POLYS``.
    pixeldist_to_angle_poly : (6,) float
        Backward polynomial, pixels to radians, ascending.
    angle_to_pixeldist_poly : (6,) float
        Forward polynomial, radians to pixels, ascending.
    max_angle : float, radians
        Largest angle from the optical axis.
    linear_cde : (3,) float, optional
        ``(c, d, e)`` of the linear term ``A = [[c, d], [e, 1]]``.

    >>> cam = FThetaCamera(resolution=(100, 80), principal_point=(49.5, 39.5),
    ...     reference_poly="ANGLE_TO_PIXELDIST", pixeldist_to_angle_poly=[0, 0.01, 0, 0, 0, 0],
    ...     angle_to_pixeldist_poly=[0, 100, 0, 0, 0, 0], max_angle=1.0)
    >>> uv, ok = cam.project(np.array([[1.0, 0.0, 1.0]]))   # 45 deg -> 100 * pi/4 px right
    >>> np.round(uv, 4).tolist(), ok.tolist()
    ([[128.0398, 39.5]], [True])
    """

    type_name = "ftheta"

    def __init__(
        self,
        *,
        resolution: tuple[int, int],
        principal_point,
        reference_poly: str,
        pixeldist_to_angle_poly,
        angle_to_pixeldist_poly,
        max_angle: float,
        linear_cde=(1.0, 0.0, 0.0),
    ):
        super().__init__(resolution=resolution)
        if reference_poly not in FTHETA_REFERENCE_POLYS:
            raise ValueError(
                f"reference_poly must be one of {FTHETA_REFERENCE_POLYS}, got {reference_poly!r}"
            )
        self.principal_point = np.asarray(principal_point, dtype=np.float64).reshape(2)
        self.reference_poly = reference_poly
        self.bw_poly = np.asarray(pixeldist_to_angle_poly, dtype=np.float64).reshape(6)
        self.fw_poly = np.asarray(angle_to_pixeldist_poly, dtype=np.float64).reshape(6)
        self.max_angle = float(max_angle)
        self.linear_cde = np.asarray(linear_cde, dtype=np.float64).reshape(3)
        c, d, e = self.linear_cde
        self._det = c - e * d
        if self._det == 0:
            raise ValueError("linear_cde: c - e*d must not be 0")

        if reference_poly == "PIXELDIST_TO_ANGLE":
            # x = pixel distance, y = angle; projection needs the inverse
            ref, dref = self.bw_poly, poly_derivative(self.bw_poly)
            grid = np.linspace(0.0, 4.0 * math.hypot(*self.resolution), _GRID)
        else:
            # x = angle, y = pixel distance
            ref, dref = self.fw_poly, poly_derivative(self.fw_poly)
            grid = np.linspace(0.0, min(self.max_angle, math.pi / 2), _GRID)
        self._map = MonotonicMap(lambda t: horner(ref, t), lambda t: horner(dref, t), grid)
        theta_mono = self._map.y_lim if reference_poly == "PIXELDIST_TO_ANGLE" else self._map.x_lim
        self.max_valid_angle = min(self.max_angle, math.pi / 2, theta_mono)

    @classmethod
    def check_values(cls, p: ModelParams) -> None:
        """``linear_cde`` invertible; the reference polynomial starts at 0 and increases."""
        cde = p.vector("linear_cde")
        if cde[0] - cde[2] * cde[1] == 0:
            raise p.error("linear_cde", "[c, d, e] with c - e*d != 0 (invertible)", cde.tolist())
        key = (
            "pixeldist_to_angle_poly"
            if p.model["reference_poly"] == "PIXELDIST_TO_ANGLE"
            else "angle_to_pixeldist_poly"
        )
        poly = p.vector(key)
        if poly[0] != 0 or poly[1] <= 0:
            raise p.error(
                key,
                "a polynomial with c0 == 0 and c1 > 0 (increasing from the principal point)",
                poly.tolist(),
            )

    def _project(self, x, y, z, rho, theta):
        if self.reference_poly == "ANGLE_TO_PIXELDIST":
            dist = self._map(theta)
        else:
            dist = self._map.inverse(theta)
        safe = np.where(rho > 0, rho, 1.0)
        du, dv = dist * (x / safe), dist * (y / safe)
        c, d, e = self.linear_cde
        cx, cy = self.principal_point
        return c * du + d * dv + cx, e * du + dv + cy

    def _unproject(self, u, v):
        c, d, e = self.linear_cde
        du, dv = u - self.principal_point[0], v - self.principal_point[1]
        pu, pv = (du - d * dv) / self._det, (c * dv - e * du) / self._det
        dist = np.hypot(pu, pv)
        if self.reference_poly == "PIXELDIST_TO_ANGLE":
            theta = np.where(dist <= self._map.x_lim, self._map(dist), np.nan)
        else:
            theta = self._map.inverse(dist)
        return rays_from_angle(self._valid_angle(theta), pu, pv)

    def __repr__(self) -> str:
        return (
            f"FThetaCamera(resolution={self.resolution}, reference_poly={self.reference_poly!r}, "
            f"max_angle={self.max_angle:.4f}, max_valid_angle={self.max_valid_angle:.4f})"
        )
