"""The choices ``analyze`` offers, in a module light enough for ``analyze --help``.

Each is defined here once and re-exported where it is used (:mod:`analysis.tables.aggregate`,
:mod:`analysis.tables.summary`, :mod:`analysis.stats.noninferiority`, :mod:`analysis.methods`,
:mod:`analysis.common.method_cells`), so the command's parser reads them
without importing the analyses (SciPy, scikit-learn, matplotlib).

>>> RANK_BY[0], METHODS[0], DEFAULT_MARGIN
('srcc', 'majority', 0.02)
"""

from __future__ import annotations

__all__ = ["METHODS", "RANK_BY", "DEFAULT_MARGIN", "MIN_CLUSTERS", "PATHS", "DEFAULT_SHARE", "MIN_CLASS_VOTES", "VIEW_FITS"]

#: How votes become item labels: majority vote (GVF) or a crowd-kit model (analysis.tables.aggregate).
METHODS = ("majority", "dawid-skene", "glad", "mace")
#: The statistics that can pick the best metric (analysis.tables.summary).
RANK_BY = ("srcc", "plcc", "roc_auc")
#: The non-inferiority margin on SRCC of the recommended cheapest metric (analysis.stats.noninferiority).
DEFAULT_MARGIN = 0.02
#: The fewest tracks (clusters) of a group that gets an interval and a p-value (analysis.methods).
#: Below 5, a share ``K^(1-K)`` of the bootstrap's resamples draws one track K times (50% at
#: K = 2, 11% at 3, 1.6% at 4; 0.16% at 5), so a "95% interval" spans little more than the
#: tracks' own means; and the sign-flip test over K tracks cannot go below ``2 / 2^K`` (0.0625
#: at K = 5).
MIN_CLUSTERS = 5
#: The two halves of the views: off the recorded path first, what a benchmark ranks on
#: (analysis.common.method_cells).
PATHS = ("off-path", "on-path")
#: The share of good objects each offset up to the trust horizon needs (``analyze --share``;
#: :data:`nvrq.horizon.DEFAULT_SHARE`, restated here for ``analyze --help``).
DEFAULT_SHARE = 0.9
#: The fewest votes a class needs at a view, good and bad among them, for a per-view threshold
#: of its own there (``analyze --horizon``; ``--no-class-thresholds`` turns it off).
MIN_CLASS_VOTES = 10
#: The per-view fits of people's votes for the trust horizon (``analyze --view-fit``;
#: :func:`analysis.stats.horizon_views.people_views`): isotonic inside each view, or a logistic with an
#: intercept per view and a shared slope.
VIEW_FITS = ("monotone", "logistic")
