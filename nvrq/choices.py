"""Choices and defaults of nvrq commands, in a module light enough for ``nvrq --help``.

Each is defined here once and re-exported where it is used (:mod:`nvrq.render_plans`,
:mod:`nvrq.sources.renders`, :mod:`nvrq.metrics.registry`, which import pandas or OpenCV), so
the command parsers read them without importing those (tests/test_import_layers.py,
benchmarks/bench_cli_help.py).

>>> PLAN_FORMATS, WORLDS, LAYOUTS
(('csv', 'json', 'npz'), ('scene', 'source'), ('plan', 'order'))
"""

from __future__ import annotations

__all__ = ["PLAN_FORMATS", "WORLDS", "LAYOUTS", "DEFAULT_METRICS", "NTA_PROTOCOLS", "SET_KINDS", "KID_SUBSETS",
           "KID_SUBSET_SIZE", "MAX_KID_SUBSETS", "MAX_KID_SUBSET_SIZE", "WINDOW_S_RANGE"]

#: The file formats of a render plan (nvrq.render_plans; docs/FORMATS.md §14).
PLAN_FORMATS = ("csv", "json", "npz")
#: The worlds a plan's poses can be given in: the scene's, or the source dataset's (scene.json
#: ``source_world``).
WORLDS = ("scene", "source")
#: The layouts of a folder of renders (nvrq.sources.renders).
LAYOUTS = ("plan", "order")
#: The metrics ``nvrq score`` computes when ``--metrics`` is not given (``nvrq``/``nvrq_ca`` on
#: the chosen encoder; nvrq.metrics.registry).
DEFAULT_METRICS = ("psnr", "ssim", "nvrq", "nvrq_ca")
#: The NTA-IoU protocols (nvrq.proxies.nta_iou.PROTOCOLS; docs/FORMATS.md §3b), the default first.
NTA_PROTOCOLS = ("nvrq", "recondreamer", "drivedreamer4d")
#: The sets ``nvrq score-sets`` compares per view (nvrq.sets; docs/FORMATS.md §3c).
SET_KINDS = ("frames", "objects")
#: KID's subsets and subset size (torch-fidelity's defaults; nvrq.sets.kid).
KID_SUBSETS = 100
KID_SUBSET_SIZE = 1000
#: The most KID subsets (one kernel sum each; 100 already give the mean to a few per cent).
MAX_KID_SUBSETS = 10_000
#: The largest KID subset: three ``m x m`` kernel matrices of float64 (600 MB at 5000).
MAX_KID_SUBSET_SIZE = 5_000
#: The range of a horizon timeline's window in seconds (nvrq.horizon.horizon_timeline, ``analyze
#: --window-s``): a whole number of microseconds from a millisecond, and far from int64's overflow.
WINDOW_S_RANGE = (0.001, 1e6)
