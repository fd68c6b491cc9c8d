"""Object crops: read an image once, cut inclusive pixel boxes, make encoder inputs.

Layer: nvrq core, geometry (image crops).

Convention:
    Images are handled as RGB ``uint8`` arrays of shape (H, W, 3), channel order R, G, B.
    Files on disk are ordinary RGB image files; OpenCV decodes them as B, G, R, so
    :func:`read_rgb` swaps the channels once right after decoding. A box is
    ``[x0, y0, x1, y1]`` in inclusive pixel indices (docs/FORMATS.md §3): the crop is
    ``image[y0:y1 + 1, x0:x1 + 1]``, so the box ``[2, 1, 4, 1]`` is 3 pixels wide and
    1 pixel tall.

Encoder input (docs/FORMATS.md §4, paper section 5.1): the crop is padded with black to a
square, content centred (the odd pixel of padding goes to the bottom/right), then
bicubic-resized (``cv2.INTER_CUBIC``) to the encoder's input size.

>>> import numpy as np
>>> img = np.arange(5 * 6 * 3, dtype=np.uint8).reshape(5, 6, 3)
>>> cut_box(img, (2, 1, 4, 1)).shape
(1, 3, 3)
>>> sq = pad_to_square(np.full((2, 5, 3), 255, np.uint8))
>>> sq.shape, sq[:, 0, 0].tolist()
((5, 5, 3), [0, 255, 255, 0, 0])
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import cv2
import numpy as np

from data_schema.errors import InputError
from data_schema.images import check_image

__all__ = ["read_rgb", "cut_box", "pad_to_square", "encoder_input", "resize_to", "normalised_tensor"]


#: OpenCV >= 4.10 decodes straight to R, G, B
_IMREAD_RGB = getattr(cv2, "IMREAD_COLOR_RGB", None)


def read_rgb(path: str | os.PathLike, *, size: tuple[int, int] | None = None,
             of: str = "its camera") -> np.ndarray:
    """Decode an image file into an RGB ``uint8`` array (H, W, 3), its header checked first.

    OpenCV returns B, G, R unless asked for R, G, B (``cv2.IMREAD_COLOR_RGB``, OpenCV >= 4.10;
    older builds swap with ``cv2.COLOR_BGR2RGB``): the result is in the file's own R, G, B
    order. Grey and RGBA files become 3-channel RGB.
    Raises :class:`InputError` if the file is missing or cannot be decoded, and before any
    decode (:func:`data_schema.images.check_image`: the header only) if it has more than
    :data:`data_schema.images.MAX_IMAGE_PIXELS` pixels, is a PNG or JPEG file cut short, or
    is not of ``size``.

    Parameters
    ----------
    path : str or PathLike
        An image file OpenCV can decode.
    size : (int, int), optional
        The ``(width, height)`` it must have (its camera's resolution).
    of : str, optional
        Whose size ``size`` is, for the error (``"camera front"``).

    Returns
    -------
    (H, W, 3) uint8
        RGB.
    """
    path = os.fspath(path)
    check_image(path, size=size, of=of)
    if _IMREAD_RGB is not None:  # the decoder writes R, G, B: no full-frame channel swap
        image = cv2.imread(path, _IMREAD_RGB)
    else:
        image = cv2.imread(path, cv2.IMREAD_COLOR)
        image = None if image is None else cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    if image is None:
        got = "no such file" if not os.path.exists(path) else "an undecodable file"
        raise InputError(path, None, "a readable image file", got)
    return image


def cut_box(image: np.ndarray, box: Sequence[int], *, where: str = "box",
            field: str | None = None) -> np.ndarray:
    """The inclusive crop ``image[y0:y1+1, x0:x1+1]`` (a view) of ``image`` (H, W, C).

    ``box`` is ``[x0, y0, x1, y1]`` (inclusive). A box that is empty or reaches outside the
    image raises :class:`InputError` naming ``where`` and ``field`` (default
    ``"box [x0, y0, x1, y1]"``).

    Parameters
    ----------
    image : (H, W, C) array
        The image.
    box : (4,) int
        ``[x0, y0, x1, y1]``, inclusive pixels.
    where : str, optional
        The file or table named in errors.
    field : str, optional
        The field named in errors.

    Returns
    -------
    (y1 - y0 + 1, x1 - x0 + 1, C) array
        A view of ``image``.
    """
    x0, y0, x1, y1 = (int(v) for v in box)
    h, w = image.shape[:2]
    if not (0 <= x0 <= x1 < w and 0 <= y0 <= y1 < h):
        raise InputError(where, field or "box [x0, y0, x1, y1]",
                         f"0 <= x0 <= x1 < {w} and 0 <= y0 <= y1 < {h} (image W x H = {w} x {h})",
                         [x0, y0, x1, y1])
    return image[y0:y1 + 1, x0:x1 + 1]


def pad_to_square(crop: np.ndarray, *, side: int | None = None) -> np.ndarray:
    """Centre ``crop`` (H, W, C) on a black (zero) square canvas (S, S, C).

    ``side``: S, at least ``max(H, W)``; default ``max(H, W)`` (then a square crop is returned
    as it is). The content starts at row ``(S - H) // 2`` and column ``(S - W) // 2`` (the odd
    pixel of padding goes to the bottom/right).

    Parameters
    ----------
    crop : (H, W, C) array
        The crop.
    side : int, optional
        ``S``, pixels, at least ``max(H, W)``.

    Returns
    -------
    (S, S, C) array
        Same dtype as ``crop``.

    >>> import numpy as np
    >>> pad_to_square(np.ones((2, 2, 1), np.uint8), side=4)[:, :, 0].tolist()
    [[0, 0, 0, 0], [0, 1, 1, 0], [0, 1, 1, 0], [0, 0, 0, 0]]
    """
    h, w = crop.shape[:2]
    s = max(h, w) if side is None else int(side)
    if s < max(h, w):
        raise InputError(param="side", expected=f"at least the crop's longer side {max(h, w)}", got=s)
    if h == w == s:
        return crop
    out = np.zeros((s, s) + crop.shape[2:], dtype=crop.dtype)
    top, left = (s - h) // 2, (s - w) // 2
    out[top:top + h, left:left + w] = crop
    return out


def encoder_input(crop: np.ndarray, size: int) -> np.ndarray:
    """Square-pad ``crop`` (H, W, 3) and bicubic-resize it to (size, size, 3), dtype kept.

    Parameters
    ----------
    crop : (H, W, 3) array
        The crop, RGB.
    size : int
        Output side, pixels.

    Returns
    -------
    (size, size, 3) array
        Same dtype as ``crop``.

    >>> import numpy as np
    >>> encoder_input(np.full((10, 20, 3), 7, np.uint8), 8).shape
    (8, 8, 3)
    """
    square = pad_to_square(crop)
    if square.shape[0] == size:
        return np.ascontiguousarray(square)
    return cv2.resize(square, (size, size), interpolation=cv2.INTER_CUBIC)


def resize_to(crop: np.ndarray, height: int, width: int) -> np.ndarray:
    """Bicubic-resize ``crop`` (h, w, C) to (height, width, C) (no-op if already that size).

    Used for pixel metrics: the render crop is brought to the GT crop's size (docs/FORMATS.md §4).

    Parameters
    ----------
    crop : (h, w, C) array
        The crop.
    height, width : int
        Target size, pixels.

    Returns
    -------
    (height, width, C) array
        Same dtype as ``crop``.
    """
    if crop.shape[:2] == (height, width):
        return crop
    return cv2.resize(crop, (int(width), int(height)), interpolation=cv2.INTER_CUBIC)


def normalised_tensor(images: np.ndarray, mean, std, *, device="cpu"):
    """uint8 RGB ``images: (B, S, S, 3)`` -> float32 torch tensor ``(B, 3, S, S)`` on ``device``.

    Values are ``(x / 255 - mean) / std`` per channel (``mean``/``std``: 3 numbers on [0, 1]
    RGB, or tensors broadcastable to ``(1, 3, 1, 1)``). Used by every encoder and classifier.

    Parameters
    ----------
    images : (B, S, S, 3) uint8
        RGB crops.
    mean, std : (3,) float or torch.Tensor
        Per-channel normalisation of RGB in [0, 1].
    device : str or torch.device, optional
        Where the tensor goes.

    Returns
    -------
    (B, 3, S, S) float32 torch.Tensor
    """
    import torch

    x = torch.from_numpy(np.ascontiguousarray(images)).to(device)
    x = x.permute(0, 3, 1, 2).float().div_(255.0)
    mean = torch.as_tensor(mean, dtype=torch.float32, device=device).view(1, 3, 1, 1)
    std = torch.as_tensor(std, dtype=torch.float32, device=device).view(1, 3, 1, 1)
    return (x - mean) / std
