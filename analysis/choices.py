"""The choices ``analyze`` offers, in a module light enough for ``analyze --help``.

Each is defined here once and re-exported where it is used (:mod:`analysis.aggregate`,
:mod:`analysis.summary`, :mod:`analysis.noninferiority`), so the command's parser reads them
without importing the analyses (SciPy, scikit-learn, matplotlib).

>>> RANK_BY[0], METHODS[0], DEFAULT_MARGIN
('srcc', 'majority', 0.02)
"""

from __future__ import annotations

__all__ = ["METHODS", "RANK_BY", "DEFAULT_MARGIN"]

#: How votes become item labels: majority vote (GVF) or a crowd-kit model (analysis.aggregate).
METHODS = ("majority", "dawid-skene", "glad", "mace")
#: The statistics that can pick the best metric (analysis.summary).
RANK_BY = ("srcc", "plcc", "roc_auc")
#: The non-inferiority margin on SRCC of the recommended cheapest metric (analysis.noninferiority).
DEFAULT_MARGIN = 0.02
