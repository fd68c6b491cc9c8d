"""What the no-reference metrics share: grey conversions and locating a package's data files.

Each metric follows the grey conversion of the implementation whose model it uses (docs/FORMATS.md
§4): MATLAB's ``rgb2gray`` (:func:`rgb2gray_matlab`) for ``piqe`` and ``entropy``, scikit-image's
``rgb2gray`` for ``brisque`` (the ``brisque`` package), scikit-video's ``rgb2gray`` for ``niqe``.

>>> import numpy as np
>>> px = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255], [10, 20, 30]]], np.uint8)
>>> rgb2gray_matlab(px).tolist()  # round(0.298936 * 255) = 76, ...; 10*.2989+20*.5870+30*.1140 = 18.15
[[76, 150, 29, 18]]
"""

from __future__ import annotations

import importlib.util
import os

import numpy as np

from data_schema.errors import InputError

__all__ = ["rgb2gray_matlab", "package_data", "check_rgb", "MATLAB_GREY", "SKIMAGE_GREY",
           "SKVIDEO_GREY"]

#: MATLAB ``rgb2gray`` (the NTSC luma of ``rgb2ntsc``, as MATLAB documents it to 15 digits)
MATLAB_GREY = (0.298936021293775, 0.587043074451121, 0.114020904255103)
#: scikit-image ``rgb2gray`` (ITU-R BT.709 luma) on values scaled to [0, 1]
SKIMAGE_GREY = (0.2125, 0.7154, 0.0721)
#: scikit-video ``utils.rgb2gray``
SKVIDEO_GREY = (0.2989, 0.5870, 0.1140)


def check_rgb(crop: np.ndarray) -> np.ndarray:
    """The render crop checked, as the no-reference metrics take it.

    Parameters
    ----------
    crop : array
        Should be a uint8 (H, W, 3) RGB array.

    Returns
    -------
    numpy.ndarray
        ``crop`` as given.

    Raises
    ------
    InputError
        (a ValueError) naming the metric functions' parameter ``render`` otherwise.

    >>> check_rgb(np.zeros((2, 2), np.float32))
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: render: expected a uint8 (H, W, 3) RGB crop, got float32 (2, 2)
    """
    crop = np.asarray(crop)
    if crop.ndim != 3 or crop.shape[2] != 3 or crop.dtype != np.uint8:
        raise InputError("render", None, "a uint8 (H, W, 3) RGB crop", f"{crop.dtype} {crop.shape}")
    return crop


def rgb2gray_matlab(crop: np.ndarray) -> np.ndarray:
    """MATLAB ``rgb2gray``: the weighted sum :data:`MATLAB_GREY`, rounded half away from zero
    (values are non-negative).

    Parameters
    ----------
    crop : (H, W, 3) uint8
        An RGB crop (:func:`check_rgb`).

    Returns
    -------
    (H, W) uint8
    """
    grey = check_rgb(crop).astype(np.float64) @ np.asarray(MATLAB_GREY)
    return np.floor(grey + 0.5).clip(0, 255).astype(np.uint8)


def package_data(package: str, *parts: str, what: str) -> str:
    """Path of a data file inside an installed package, found without importing it (its own
    modules may not import on this NumPy).

    Parameters
    ----------
    package : str
        The package's import name, e.g. ``skvideo``.
    *parts : str
        The file's path inside the package.
    what : str
        What the file is, for the error.

    Returns
    -------
    str

    Raises
    ------
    InputError
        Naming the package when it is not installed or lacks the file.
    """
    spec = importlib.util.find_spec(package)
    roots = list(spec.submodule_search_locations or []) if spec is not None else []
    for root in roots:
        path = os.path.join(root, *parts)
        if os.path.isfile(path):
            return path
    raise InputError(package, "/".join(parts), f"the installed Python package {package!r} with {what} "
                     f"(pip install -e . installs it)", "not installed" if not roots else "file missing")
