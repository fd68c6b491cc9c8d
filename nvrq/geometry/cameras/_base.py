"""Camera-model base class, registry and parameter validation.

Layer: nvrq core, geometry.

Convention (docs/FORMATS.md §1): camera frame x right, y down, z forward; pixels u right,
v down, the centre of pixel (column i, row j) at (u=i, v=j). A pixel centre is inside
the image iff ``0 <= u <= W-1`` and ``0 <= v <= H-1``.

Every model projects through the angle from the optical axis,
``theta = atan2(hypot(x, y), z)``: a point is *projectable* iff ``z > 0`` and
``theta < max_valid_angle``, where ``max_valid_angle`` is the model's limit (f-theta's
``max_angle``, and for distorted models the end of the range where the distortion is
monotonic, so that nothing outside it can fold back into the image).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from data_schema.errors import InputError
from data_schema.scene import CAMERA_MODEL_SCHEMA, validate_camera_model

__all__ = ["CameraModel", "ModelParams", "camera_from_model", "register_camera_model"]

_REGISTRY: dict[str, type[CameraModel]] = {}


def register_camera_model(cls: type[CameraModel]) -> type[CameraModel]:
    """Class decorator: make ``cls`` available under ``model['type'] == cls.type_name``.

    Parameters
    ----------
    cls : type
        A :class:`CameraModel` subclass whose ``type_name`` is a scene-format model type.

    Returns
    -------
    type
        ``cls`` itself (so it decorates).

    Raises
    ------
    ValueError
        The type name is registered twice or not a scene-format type.
    """
    if cls.type_name in _REGISTRY:
        raise ValueError(f"camera model type {cls.type_name!r} registered twice")
    if cls.type_name not in CAMERA_MODEL_SCHEMA:
        raise ValueError(f"camera model type {cls.type_name!r} is not a scene-format model type")
    _REGISTRY[cls.type_name] = cls
    return cls


def camera_from_model(
    model: Mapping[str, Any], *, where: str = "camera model", field_prefix: str | None = None
) -> CameraModel:
    """Build the camera of a scene.json camera model dict (``{'type': ..., 'resolution': [W, H], ...}``).

    Parameter names, lengths and defaults are checked by the scene format's one validator,
    :func:`data_schema.scene.validate_camera_model`; the camera class adds only checks on
    values (e.g. a positive focal length). Errors are :class:`InputError` naming ``where``
    and the field, ``"{type}.{param}"`` by default, or ``field_prefix + param`` when given
    (e.g. ``"cameras.front.model."``). Keys a model does not use are ignored.

    Parameters
    ----------
    model : mapping
        The camera model dict of ``scene.json`` (``type``, ``resolution`` and the type's
        parameters).
    where : str, optional
        The file or object named in errors.
    field_prefix : str, optional
        Prefix of the field named in errors (default ``"{type}."``).

    Returns
    -------
    CameraModel

    Raises
    ------
    InputError
        An unknown type, or a missing or invalid parameter.
    """
    if field_prefix is None:
        kind = model.get("type") if isinstance(model, Mapping) else None
        fld = kind if isinstance(kind, str) and kind in _REGISTRY else ""
    else:
        fld = field_prefix.rstrip(".")
    checked = validate_camera_model(model, where, fld)
    params = ModelParams(checked, where=where, prefix=f"{fld}." if fld else "")
    return _REGISTRY[checked["type"]].from_params(params)


class ModelParams:
    """A model dict checked by :func:`~data_schema.scene.validate_camera_model` (every
    parameter present, of the right length, finite, defaults filled), with typed access and
    the value checks of the camera classes; every error names ``prefix + key``.

    Parameters
    ----------
    model : mapping
        The camera model dict.
    where : str
        The file or object named in errors.
    prefix : str
        Prefix of the field named in errors.
    """

    def __init__(self, model: Mapping[str, Any], *, where: str, prefix: str):
        self.model, self.where, self.prefix = model, where, prefix

    def error(self, key: str, expected: str, got: object) -> InputError:
        return InputError(self.where, f"{self.prefix}{key}", expected, got)

    def vector(self, key: str) -> np.ndarray:
        """The list parameter ``key`` as a float64 array."""
        return np.asarray(self.model[key], dtype=np.float64)

    def positive_vector(self, key: str) -> np.ndarray:
        arr = self.vector(key)
        if not np.all(arr > 0):
            raise self.error(key, f"a list of {arr.size} positive numbers", arr.tolist())
        return arr

    def resolution(self) -> tuple[int, int]:
        w, h = self.model["resolution"]
        return int(w), int(h)

    def kwargs(self) -> dict[str, Any]:
        """Every parameter of the model type as a constructor keyword: ``resolution`` a
        ``(W, H)`` tuple, lists float64 arrays, numbers floats, names strings."""
        out: dict[str, Any] = {}
        for key, (length, _default) in CAMERA_MODEL_SCHEMA[self.model["type"]].items():
            value = self.model[key]
            if key == "resolution":
                out[key] = self.resolution()
            elif isinstance(value, str):
                out[key] = value
            else:
                out[key] = float(value) if length == 0 else self.vector(key)
        return out


class CameraModel:
    """Base of every camera model: ``project``, ``unproject``, ``in_image`` on any leading dims.

    Subclasses set ``type_name``, take every parameter of their model type as a keyword
    argument, may add value checks in ``check_values``, implement ``_project(x, y, z, rho, theta)``
    (uv for all points; only projectable ones are kept; ``x, y, z`` arrive divided by the
    point's largest ``|component|``, so a model may only use their ratios) and
    ``_unproject(u, v)`` (rays,
    NaN outside the model's valid range) and set ``self.max_valid_angle``.

    Parameters
    ----------
    resolution : (int, int)
        ``(W, H)`` in pixels.
    """

    type_name: ClassVar[str]
    max_valid_angle: float

    def __init__(self, *, resolution: tuple[int, int]):
        self._resolution = (int(resolution[0]), int(resolution[1]))

    @classmethod
    def from_params(cls, params: ModelParams) -> CameraModel:
        """The camera of a validated model dict, after :meth:`check_values`."""
        cls.check_values(params)
        return cls(**params.kwargs())

    @classmethod
    def check_values(cls, params: ModelParams) -> None:
        """Checks on parameter values beyond the scene format's (default: focal lengths > 0)."""
        if "focal_length" in params.model:
            params.positive_vector("focal_length")

    @property
    def resolution(self) -> tuple[int, int]:
        """``(W, H)`` in pixels."""
        return self._resolution

    def project(self, points_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Camera-frame points ``(..., 3)`` -> ``(uv (..., 2) float64, projectable (...,) bool)``.

        ``projectable`` is ``z > 0`` and ``atan2(hypot(x, y), z) < max_valid_angle`` (NaN
        points are never projectable); ``uv`` is NaN wherever ``projectable`` is False.
        """
        pts = np.asarray(points_cam, dtype=np.float64)
        if pts.shape[-1:] != (3,):
            raise ValueError(f"points_cam: expected shape (..., 3), got {pts.shape}")
        x, y, z = _direction_scaled(pts)
        rho = np.hypot(x, y)
        theta = np.arctan2(rho, z)
        projectable = (z > 0) & (theta < self.max_valid_angle)
        with np.errstate(all="ignore"):
            u, v = self._project(x, y, z, rho, np.minimum(theta, self.max_valid_angle))
        uv = np.stack([u, v], axis=-1)
        uv[~projectable] = np.nan
        return uv, projectable

    def unproject(self, uv: np.ndarray) -> np.ndarray:
        """Pixel coordinates ``(..., 2)`` -> unit rays ``(..., 3)`` in the camera frame.

        A pixel whose ray would lie beyond ``max_valid_angle`` (e.g. outside a fisheye's
        image circle, or past the fold of a distortion polynomial) gets NaN; the limit
        itself is kept, to rounding (see ``_valid_angle``), so that every projectable
        point's pixel unprojects to its ray.
        """
        pix = np.asarray(uv, dtype=np.float64)
        if pix.shape[-1:] != (2,):
            raise ValueError(f"uv: expected shape (..., 2), got {pix.shape}")
        with np.errstate(all="ignore"):
            return self._unproject(pix[..., 0], pix[..., 1])

    def in_image(self, uv: np.ndarray) -> np.ndarray:
        """``(..., 2)`` -> ``(...,)`` bool: ``0 <= u <= W-1 and 0 <= v <= H-1`` (pixel centres).

        >>> cam = camera_from_model({"type": "pinhole", "resolution": [4, 3],
        ...                          "focal_length": [2, 2], "principal_point": [1.5, 1]})
        >>> cam.in_image(np.array([[0.0, 0.0], [3.0, 2.0], [3.01, 1.0], [-0.5, 1.0]])).tolist()
        [True, True, False, False]
        """
        pix = np.asarray(uv, dtype=np.float64)
        w, h = self._resolution
        u, v = pix[..., 0], pix[..., 1]
        return (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1)

    def _valid_angle(self, theta: np.ndarray) -> np.ndarray:
        """``theta`` from an inverted distortion, NaN where it lies beyond ``max_valid_angle``.

        The inversion is exact only to rounding: a projectable point just inside the limit
        can come back a few ulps past it, so angles within ``1e-12 * max_valid_angle`` of
        the limit are kept (clamped to it); anything farther out is NaN.
        """
        limit = self.max_valid_angle
        return np.where(theta <= limit * (1 + 1e-12), np.minimum(theta, limit), np.nan)

    def _project(self, x, y, z, rho, theta):  # pragma: no cover - abstract
        raise TypeError(f"{type(self).__name__} does not implement _project")

    def _unproject(self, u, v):  # pragma: no cover - abstract
        raise TypeError(f"{type(self).__name__} does not implement _unproject")

    def __repr__(self) -> str:
        return f"{type(self).__name__}(resolution={self._resolution})"


def _direction_scaled(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(..., 3)`` -> ``x, y, z`` divided by each point's largest ``|component|``.

    Projection depends only on a point's direction, but radii and ratios of tiny
    (subnormal) coordinates lose every significant bit (``hypot(5e-324, 5e-324)`` is
    ``5e-324``); scaling first keeps the direction exact. Points whose largest component
    is 0, infinite or NaN are left as they are.
    """
    with np.errstate(all="ignore"):
        scale = np.max(np.abs(pts), axis=-1)
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
    return pts[..., 0] / scale, pts[..., 1] / scale, pts[..., 2] / scale


def rays_from_angle(theta: np.ndarray, du: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """Unit rays at angle ``theta`` from the optical axis, azimuth of ``(du, dv)``: ``(..., 3)``.

    ``(du, dv) == (0, 0)`` gives the optical axis ``(0, 0, 1)`` (for ``theta == 0``).
    """
    norm = np.hypot(du, dv)
    safe = np.where(norm > 0, norm, 1.0)
    s = np.sin(theta)
    return np.stack([s * (du / safe), s * (dv / safe), np.cos(theta)], axis=-1)
