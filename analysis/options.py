"""The options of ``analyze``'s analyses, as frozen objects (layer: analysis, its entry points).

:class:`AnalysisOptions` drives :func:`analysis.pipeline.run_analysis` (ratings) and
:func:`analysis.all_pairs.run_pairs_analysis` (every pair); its ``compare`` field, a
:class:`MethodOptions`, asks for the method leaderboard (:func:`analysis.methods.compare_methods`).
:class:`SummaryOptions` drives :func:`analysis.tables.summary.summary_table`. The CLI makes them once,
in :func:`analysis.cli.options_from_args`; an API caller makes them directly.

>>> AnalysisOptions(n_boot=0).compare is None
True
>>> analysis_options({"compare_methods": True, "rank_metric": "psnr"}).compare.rank_metric
'psnr'
"""

from __future__ import annotations

from dataclasses import dataclass

from analysis.common.choices import DEFAULT_MARGIN, MIN_CLUSTERS
from data_schema.options import options_or_keywords

__all__ = ["MethodOptions", "AnalysisOptions", "SummaryOptions", "analysis_options"]

#: the former keyword arguments of the analyses that now live in :class:`MethodOptions`
_METHOD_KEYWORDS = ("methods", "rank_metric", "min_clusters", "by", "rank_view")


@dataclass(frozen=True)
class MethodOptions:
    """How the reconstruction methods are compared (:func:`analysis.methods.compare_methods`).

    Parameters
    ----------
    methods : sequence of str, optional
        Restricts (and orders) the methods compared (default: all).
    rank_metric : str, optional
        The metric that ranks the leaderboard (default
        :func:`analysis.methods.default_rank_metric`).
    min_clusters : int
        The fewest tracks of a group with an interval and a p-value (>= 2;
        :data:`analysis.common.choices.MIN_CLUSTERS`).
    by : sequence of str
        A crossed breakdown of methods_paired.csv: ``class``, a scene attribute, ``offset``.
    rank_view : {'off-path', 'on-path'}
        The views the leaderboard ranks on.
    attributes : sequence of str
        Scene attributes that break methods.csv down (and that ``by`` may name); an analysis
        sets its own.
    n_boot, seed : int
        Bootstrap replicates over tracks (0: no intervals) and their seed; an analysis sets its own.
    progress : bool
        Show a progress bar; an analysis sets its own.

    """

    methods: tuple | list | None = None
    rank_metric: str | None = None
    min_clusters: int = MIN_CLUSTERS
    by: tuple | list | str = ()
    rank_view: str = "off-path"
    attributes: tuple | list = ()
    n_boot: int = 1000
    seed: int = 0
    progress: bool = False


@dataclass(frozen=True)
class SummaryOptions:
    """How :func:`analysis.tables.summary.summary_table` compares the metrics with the target.

    Parameters
    ----------
    target : str
        The column the metrics are compared with (GVF by default).
    n_boot : int
        Bootstrap replicates (0: no intervals).
    seed : int
        Seeds the bootstrap.
    rank_by : {'srcc', 'plcc', 'roc_auc'}
        The statistic the metrics are ranked by (:data:`analysis.common.choices.RANK_BY`).
    progress : bool
        Show a progress bar.

    """

    target: str = "gvf"
    n_boot: int = 1000
    seed: int = 0
    rank_by: str = "srcc"
    progress: bool = True


@dataclass(frozen=True)
class AnalysisOptions:
    """The options of an analysis (``analyze``): inputs beside the main table, the statistics,
    and the optional method comparison.

    Parameters
    ----------
    metrics_paths : sequence of path
        Metrics tables (``pair_id`` + metric columns).
    lower, higher : sequence of str
        Metric columns where lower / higher is better (columns the metric registry does not know).
    target : str, optional
        The numeric per-item column to correlate with (ratings: default GVF, or ``p_good`` with
        a model; all pairs: required unless ``compare`` is set).
    exclude_raters : sequence of str
        Ratings only: rater ids to leave out.
    screen : bool
        Ratings only: also exclude the raters the screening rule flags.
    aggregate_method : str
        Ratings only: ``'majority'`` (GVF) or a crowd-kit model (:data:`analysis.common.choices.METHODS`).
    n_boot, seed : int
        Cluster-bootstrap replicates over tracks (0: no CIs) and their seed.
    rank_by : str
        The statistic that picks the best metric (:data:`analysis.common.choices.RANK_BY`).
    timing_paths : sequence of path
        Timing tables (``METRICS.timing.csv`` beside a metrics table is found automatically).
    stability_dir : str or Path, optional
        Ratings only: a folder with ``stability.csv`` and/or ``snr.csv``.
    margin : float
        Non-inferiority margin on SRCC for the recommended cheapest metric (>= 0).
    compare : MethodOptions, optional
        Also rank the reconstruction methods, with these options (None: no leaderboard).
    progress : bool
        Show progress bars.

    """

    metrics_paths: tuple | list = ()
    lower: tuple | list = ()
    higher: tuple | list = ()
    target: str | None = None
    exclude_raters: tuple | list = ()
    screen: bool = True
    aggregate_method: str = "majority"
    n_boot: int = 1000
    seed: int = 0
    rank_by: str = "srcc"
    timing_paths: tuple | list = ()
    stability_dir: object = None
    margin: float = DEFAULT_MARGIN
    compare: MethodOptions | None = None
    progress: bool = True


def analysis_options(keywords: dict, *, options: AnalysisOptions | None = None,
                     who: str = "run_analysis") -> AnalysisOptions:
    """``options``, or the options from the analyses' former keyword arguments
    (``compare_methods=True`` and ``methods``, ``rank_metric``, ``min_clusters``, ``by``,
    ``rank_view`` become ``compare``).

    Parameters
    ----------
    keywords : dict
        Field names of :class:`AnalysisOptions`, ``compare_methods`` and the method keywords.
    options : AnalysisOptions, optional
        The options the caller gave (then ``keywords`` must be empty).
    who : str
        The function named in the error of an unknown keyword.

    Returns
    -------
    AnalysisOptions
        The options.

    Raises
    ------
    TypeError
        An unknown keyword, or both ``options`` and keywords.
    """
    if not keywords or options is not None:
        return options_or_keywords(AnalysisOptions, options, keywords, who=who)
    keywords = dict(keywords)
    wanted = bool(keywords.pop("compare_methods", False))
    method = {k: keywords.pop(k) for k in _METHOD_KEYWORDS if k in keywords}
    options = options_or_keywords(AnalysisOptions, None, keywords, who=who)
    if not wanted:
        return options
    return AnalysisOptions(**{**options.__dict__, "compare": MethodOptions(**method)})
