"""Downstream proxies of render quality (paper Eq. 6-10), one per-pair column each.

Layer: nvrq core, proxies (downstream quality proxies).

- :mod:`nvrq.proxies.detection` -- detection confidence ``s_det`` on the render box (Eq. 6-8).
- :mod:`nvrq.proxies.classifier_drop` -- ImageNet top-class confidence drop ``imagenet_drop`` (Eq. 9).
- :mod:`nvrq.proxies.clip_drop` -- CLIP zero-shot true-category confidence drop ``clip_drop`` (Eq. 10).

The class maps (dataset ``label_class`` -> COCO classes, -> CLIP category, and the CLIP
prompts) are editable data in ``class_maps.json`` (:func:`load_class_maps`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from data_schema.errors import InputError

__all__ = ["CLASS_MAPS_PATH", "load_class_maps", "mapped_labels"]

CLASS_MAPS_PATH = Path(__file__).with_name("class_maps.json")
_KEYS = ("coco", "clip_category", "clip_prompts")


def load_class_maps(path: str | os.PathLike | None = None) -> dict:
    """The class maps: ``{'coco': {label_class: [coco classes]}, 'clip_category': {label_class:
    category or None}, 'clip_prompts': {category: prompt}}`` (keys lower-cased).

    ``path``: a JSON file of the same layout (default: the shipped ``class_maps.json``).

    Parameters
    ----------
    path : str or PathLike, optional
        A JSON file of the same layout (default: the shipped ``class_maps.json``).

    Returns
    -------
    dict
        ``{'coco': ..., 'clip_category': ..., 'clip_prompts': ...}``.

    >>> maps = load_class_maps()
    >>> maps["coco"]["automobile"], maps["clip_category"]["heavy_truck"]
    (['car', 'truck', 'bus'], 'large vehicle')
    """
    from nvrq.proxies.coco import check_coco_classes

    path = Path(path) if path is not None else CLASS_MAPS_PATH
    if not path.is_file():
        raise InputError(path, None, "a class-map JSON file", "no such file")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise InputError(path, None, "valid JSON", str(exc)) from None
    if not isinstance(doc, dict):
        raise InputError(path, None, "a JSON object with the keys " + ", ".join(_KEYS), type(doc).__name__)
    for key in _KEYS:
        if not isinstance(doc.get(key), dict):
            raise InputError(path, key, "an object", type(doc.get(key)).__name__)
    out = {"coco": {}, "clip_category": {}, "clip_prompts": {}}
    for label, classes in doc["coco"].items():
        if not isinstance(classes, list) or not all(isinstance(c, str) for c in classes):
            raise InputError(path, f"coco.{label}", "a list of COCO class names", classes)
        out["coco"][label.lower()] = [c.lower() for c in classes]
        check_coco_classes(out["coco"][label.lower()], where=path, field_of=lambda i, k=label: f"coco.{k}[{i}]")
    prompts = {k.lower(): v for k, v in doc["clip_prompts"].items()}
    for k, v in prompts.items():
        if not isinstance(v, str) or not v.strip():
            raise InputError(path, f"clip_prompts.{k}", "a prompt string", v)
    out["clip_prompts"] = prompts
    for label, cat in doc["clip_category"].items():
        if cat is not None and (not isinstance(cat, str) or cat.lower() not in prompts):
            raise InputError(
                path,
                f"clip_category.{label}",
                f"null or one of the clip_prompts categories ({', '.join(prompts)})",
                cat,
            )
        out["clip_category"][label.lower()] = None if cat is None else cat.lower()
    return out


def mapped_labels(labels, mapping: dict, section: str, *, where: str = "pairs") -> np.ndarray:
    """Lower-cased ``labels`` ``(N,)`` object array; :class:`InputError` naming ``where`` if a
    label is missing from ``mapping`` (the class map's ``section``, e.g. ``'coco'``).

    Parameters
    ----------
    labels : (N,) array-like of str
        ``label_class`` per pair.
    mapping : dict
        One section of the class maps, keyed by lower-cased label class.
    section : str
        The section's name, for errors (e.g. ``'coco'``).
    where : str, optional
        The table named in errors.

    Returns
    -------
    (N,) object array of str
        The lower-cased labels.

    Raises
    ------
    InputError
        A label is absent from ``mapping``.
    """
    low = np.array([str(x).lower() for x in labels], dtype=object)
    unknown = sorted(set(low) - set(mapping))
    if unknown:
        raise InputError(
            where,
            "label_class",
            f"classes listed in the class map's {section!r} section "
            "(edit nvrq/proxies/class_maps.json or use a `class_map` file of that layout)",
            ", ".join(unknown),
        )
    return low

# a submodule (e.g. nvrq.proxies.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.proxies", {}, globals())
