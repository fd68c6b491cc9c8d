"""The 80 COCO detection classes, by the names detectors write (Ultralytics' ``model.names``,
torchvision's ``COCO_V1`` categories without their ``N/A`` gaps): the vocabulary of a DETS table's
``coco_class`` and of the class map's ``coco`` lists (library layer, :mod:`nvrq.proxies`).

>>> len(COCO_CLASSES), COCO_CLASSES[:3], "traffic light" in COCO_CLASSES
(80, ('person', 'bicycle', 'car'), True)
"""

from __future__ import annotations

import numpy as np

from data_schema.errors import InputError

__all__ = ["COCO_CLASSES", "check_coco_classes"]

COCO_CLASSES = (
    "person", "bicycle", "car", "motorcycle", "airplane", "bus", "train", "truck", "boat", "traffic light",
    "fire hydrant", "stop sign", "parking meter", "bench", "bird", "cat", "dog", "horse", "sheep", "cow",
    "elephant", "bear", "zebra", "giraffe", "backpack", "umbrella", "handbag", "tie", "suitcase", "frisbee",
    "skis", "snowboard", "sports ball", "kite", "baseball bat", "baseball glove", "skateboard", "surfboard",
    "tennis racket", "bottle", "wine glass", "cup", "fork", "knife", "spoon", "bowl", "banana", "apple",
    "sandwich", "orange", "broccoli", "carrot", "hot dog", "pizza", "donut", "cake", "chair", "couch",
    "potted plant", "bed", "dining table", "toilet", "tv", "laptop", "mouse", "remote", "keyboard",
    "cell phone", "microwave", "oven", "toaster", "sink", "refrigerator", "book", "clock", "vase", "scissors",
    "teddy bear", "hair drier", "toothbrush",
)


def check_coco_classes(values, *, where, field_of) -> None:
    """Refuse the first value that is not a COCO class name (:data:`COCO_CLASSES`, lower case).

    Parameters
    ----------
    values : (N,) array-like of str
        Lower-cased class names.
    where : str
        The file named in the error.
    field_of : callable
        ``field_of(i)`` is the field (or row) the error names for value ``i``.

    Raises
    ------
    InputError
        A name that COCO does not have, with the nearest COCO names when there are some.

    >>> check_coco_classes(["car", "bus"], where="d.csv", field_of=lambda i: f"row {i + 2}")
    >>> check_coco_classes(["car", "vehicle"], where="d.csv", field_of=lambda i: f"row {i + 2}, column coco_class")
    Traceback (most recent call last):
    data_schema.errors.InputError: d.csv: row 3, column coco_class: expected one of the 80 COCO class names (person, bicycle, car, motorcycle, bus, truck, ...), got 'vehicle'
    """
    import difflib

    vals = np.asarray(values, dtype=object).astype(str)
    uniq, inv = np.unique(vals, return_inverse=True)
    known = np.isin(uniq, COCO_CLASSES)
    if known.all():
        return
    i = int(np.flatnonzero(~known[inv])[0])
    bad = str(vals[i])
    near = difflib.get_close_matches(bad, COCO_CLASSES, n=3)
    hint = ", ".join(near) if near else "person, bicycle, car, motorcycle, bus, truck"
    raise InputError(where, field_of(i), f"one of the 80 COCO class names ({hint}, ...)", repr(bad))
