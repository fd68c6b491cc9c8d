"""``entropy``: Shannon entropy of the grey-level histogram (MATLAB ``entropy``; higher is better).

MATLAB's ``entropy(I)`` of a uint8 grey image: the 256-bin histogram ``imhist``, its empty bins
dropped, ``p = counts / numel(I)``, ``E = -sum(p .* log2(p))`` bits. The crop is first made grey
with MATLAB's ``rgb2gray`` (:func:`~nvrq.metrics.no_reference._common.rgb2gray_matlab`). Range [0, 8]: 0 for
a flat crop, 8 when all 256 levels are equally frequent. Defined for every crop.

>>> import numpy as np
>>> half = np.zeros((2, 4, 3), np.uint8); half[:, 2:] = 255   # two levels, half each: 1 bit
>>> entropy(half)
1.0
>>> ramp = np.repeat(np.arange(256, dtype=np.uint8), 3).reshape(16, 16, 3)  # 256 levels once: 8 bits
>>> entropy(ramp)
8.0
"""

from __future__ import annotations

import numpy as np

from nvrq.metrics.no_reference._common import _rgb2gray, rgb2gray_matlab

__all__ = ["entropy", "grey_entropy"]


def grey_entropy(grey: np.ndarray) -> float:
    """Shannon entropy of the 256-bin histogram of grey levels.

    Parameters
    ----------
    grey : uint8 array
        Any shape, non-empty.

    Returns
    -------
    float
        Bits, in [0, 8].
    """
    counts = np.bincount(np.asarray(grey, np.uint8).ravel(), minlength=256)
    p = counts[counts > 0] / grey.size
    return float(-np.sum(p * np.log2(p))) + 0.0  # + 0.0: no -0.0 for a flat crop


def entropy(render: np.ndarray) -> float:
    """MATLAB ``entropy(rgb2gray(render))``.

    Parameters
    ----------
    render : (H, W, 3) uint8
        The render crop alone.

    Returns
    -------
    float
        In bits; higher is better.

    Raises
    ------
    InputError
        For a crop that is not uint8 (H, W, 3).
    """
    return grey_entropy(rgb2gray_matlab(render))


def _entropy(render: np.ndarray) -> float:
    """:func:`entropy` without the input check (the scoring core checks once per run)."""
    return grey_entropy(_rgb2gray(render))
