"""Defaults several commands share, in a module light enough for their ``--help`` (no pandas).

Layer: data_schema (file formats).

Each is defined here once; :mod:`data_schema.tables` re-exports it with the table facts.

>>> MIN_SIDE_PX
30
"""

from __future__ import annotations

__all__ = ["MIN_SIDE_PX", "MIN_VISIBLE"]

#: docs/FORMATS.md §3: the default smallest shorter box side (pixels) of a usable object crop,
#: shared by ``nvrq pairs --min-side`` and ``nvrq stability --min-side``.
MIN_SIDE_PX = 30

#: docs/FORMATS.md §3: the default smallest visible fraction of an object, in the GT view and in
#: the novel view, of a kept pair (``nvrq pairs --min-visible``; 0 is the paper's protocol).
MIN_VISIBLE = 0.8

#: docs/FORMATS.md §5: a study's crop display size in pixels and the votes between offered breaks
#: (``annotate build --size`` / ``--break-every``; also what a manifest without the key means).
DISPLAY_SIZE = 320
BREAK_EVERY = 50
