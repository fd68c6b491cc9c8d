"""Camera models: one class per ``model['type']`` of docs/FORMATS.md §2, one registry.

Layer: nvrq core, geometry.

``camera_from_model(model)`` builds the camera of a scene's model dict; every camera has
``resolution -> (W, H)``, ``project(points_cam (..., 3)) -> (uv (..., 2), projectable (...,))``,
``unproject(uv (..., 2)) -> unit rays (..., 3)`` and ``in_image(uv) -> (...,) bool``.

Convention: camera frame x right, y down, z forward; the centre of pixel (column i, row j)
is at (u=i, v=j). A point is projectable iff ``z > 0`` and its angle from the optical axis
is below the model's ``max_valid_angle`` (f-theta's ``max_angle``; for distorted models
also the end of the range where the distortion is monotonic); ``uv`` is NaN elsewhere.

>>> import numpy as np
>>> cam = camera_from_model({"type": "pinhole", "resolution": [1920, 1080],
...                          "focal_length": [1000, 1000], "principal_point": [959.5, 539.5]})
>>> uv, ok = cam.project(np.array([[2.0, 1.0, 10.0]]))   # u = 1000 * 2/10 + 959.5
>>> uv.tolist(), ok.tolist(), cam.in_image(uv).tolist()
([[1159.5, 639.5]], [True], [True])
>>> CAMERA_MODEL_TYPES
('ftheta', 'opencv_fisheye', 'opencv_pinhole', 'pinhole')
"""

from ._base import _REGISTRY, CameraModel, camera_from_model, register_camera_model
from .fisheye import OpenCVFisheyeCamera
from .ftheta import FThetaCamera
from .pinhole import OpenCVPinholeCamera, PinholeCamera

#: The ``model['type']`` names known to :func:`camera_from_model`, sorted.
CAMERA_MODEL_TYPES: tuple[str, ...] = tuple(sorted(_REGISTRY))

__all__ = [
    "CAMERA_MODEL_TYPES",
    "CameraModel",
    "FThetaCamera",
    "OpenCVFisheyeCamera",
    "OpenCVPinholeCamera",
    "PinholeCamera",
    "camera_from_model",
    "register_camera_model",
]

# a submodule (e.g. nvrq.geometry.cameras.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.geometry.cameras", {}, globals())
