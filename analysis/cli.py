"""The ``analyze`` command (docs/FORMATS.md §6): a thin shell over :func:`analysis.pipeline.run_analysis`.

``analyze RATINGS.csv [--metrics-table METRICS ...] [--lower-better A,B] [--higher-better A,B]
[--target COLUMN] [--exclude-raters A,B] [--no-screen] [--aggregate METHOD] [--timing FILE ...]
[--stability DIR]
[--bootstrap N] [--seed S] [--rank-by {srcc,plcc,roc_auc}]
[--compare-methods [--methods A,B] [--leaderboard-metric METRIC] [--leaderboard-view VIEW]
[--by A,B] [--min-clusters K]]
[--horizon [--metric METRIC] [--threshold VALUE | --threshold-table CSV] [--pooled-threshold]
[--view-fit {monotone,logistic}] [--no-floor]
[--share S] [--good-prob P] [--window-s W]]
--out REPORT_DIR``

Pairwise votes (a ``--design pairwise`` study's export) are recognised by their columns and
analysed by :mod:`analysis.pairwise`; ``--compare-methods`` adds the leaderboard of
:mod:`analysis.methods` to either path, and ``--horizon`` the trust horizon of
:mod:`analysis.horizon` (docs/FORMATS.md §15).

Raters flagged by screening (:mod:`annotate.screening`) are excluded unless ``--no-screen``;
who and why is printed and written in the report. An option that does not apply to the input
(:data:`NOT_FOR`) is refused, never ignored. Bad input ends with one line on stderr and exit
status 2 (docs/FORMATS.md §7). The analyses (SciPy, scikit-learn, matplotlib) are imported
when a run needs them, so ``analyze --help`` loads none of them.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from analysis.common.choices import (
    DEFAULT_MARGIN,
    DEFAULT_SHARE,
    METHODS,
    MIN_CLASS_VOTES,
    MIN_CLUSTERS,
    PATHS,
    RANK_BY,
    VIEW_FITS,
)
from analysis.options import AnalysisOptions, MethodOptions
from data_schema.errors import InputError
from data_schema.outputs import REPORT_MARKER, check_output_folder, mark_report, replacing_note
from nvrq.choices import WINDOW_S_RANGE
from nvrq.cli_types import (
    ArgumentParser,
    CommaList,
    DeprecatedFileOption,
    add_quiet_option,
    add_version,
    flags_in_errors,
    int_arg,
    number_arg,
    option_for,
    run_cli,
    show_progress,
)

__all__ = ["build_parser", "main", "options_from_args"]


def build_parser() -> ArgumentParser:
    """The ``analyze`` parser (one command, no subcommands): the option groups of
    :data:`OPTION_GROUPS`, in order.

    Returns
    -------
    argparse.ArgumentParser
        The parser of the ``analyze`` command.
    """
    p = ArgumentParser(
        prog="analyze",
        description="Which metric agrees with human judgements? Correlations, ROC AUC, bootstrap "
        "CIs, breakdowns, rater screening and an offline HTML report.",
    )
    add_version(p)
    for add_options in OPTION_GROUPS:
        add_options(p)
    return p


def _input_options(p: ArgumentParser) -> None:
    """What is analysed: the votes (or every pair), the metrics and their directions, the target."""
    p.add_argument("ratings", metavar="RATINGS", nargs="?",
                   help="ratings.csv (or .parquet) from `annotate export` (or use --pairs)")
    p.add_argument("--pairs", metavar="PAIRS", default=None,
                   help="instead of RATINGS: every pair of a pairs dataset (or a table with clip_id), "
                   "joined with --metrics-table, against --target (analysis.all_pairs)")
    p.add_argument("--metrics-table", dest="metrics_tables", action="append", default=[], metavar="FILE",
                   help="metrics table (pair_id + metric columns) joined on item_id; repeatable")
    p.add_argument("--metrics", dest="metrics_tables", action=DeprecatedFileOption,
                   new="--metrics-table", help=argparse.SUPPRESS)
    p.add_argument("--lower-better", action=CommaList, nargs="+", default=[], metavar="A,B",
                   help="metric columns where lower is better (comma list; the old space-separated "
                   "form is deprecated)")
    p.add_argument("--higher-better", action=CommaList, nargs="+", default=[], metavar="A,B",
                   help="metric columns where higher is better (comma list; the old space-separated "
                   "form is deprecated)")
    p.add_argument("--target", metavar="COLUMN", default=None,
                   help="a numeric per-item column to correlate with instead of GVF (e.g. s_det)")


def _rater_options(p: ArgumentParser) -> None:
    """Which raters count and how their votes become item labels (ratings only)."""
    p.add_argument("--exclude-raters", action=CommaList, default=[], metavar="A,B",
                   help="rater ids to leave out (comma list; repeatable)")
    p.add_argument("--no-screen", action="store_true",
                   help="keep the raters the screening rule flags (by default they are excluded; "
                   "raters.csv and the report say who and why)")
    p.add_argument("--screen", action=_ScreenIsDefault, nargs=0, default=False, help=argparse.SUPPRESS)
    p.add_argument("--aggregate", choices=METHODS, default="majority",
                   help="item labels: majority vote (GVF, default) or a crowd-kit model whose posterior "
                   "P(good) becomes the target (0.5 threshold for ROC AUC)")


class _ScreenIsDefault(argparse.Action):
    """The old ``--screen``: screening is now the default, so it changes nothing; one note."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"note: {option_string} is deprecated: screening is on by default (--no-screen keeps "
              "the flagged raters)", file=sys.stderr)
        setattr(namespace, self.dest, True)


def _cost_options(p: ArgumentParser) -> None:
    """The cheapest-metric recommendation and what the report adds beside the correlations:
    speed (timing tables) and the stability study."""
    p.add_argument("--margin", type=number_arg(low=0), default=DEFAULT_MARGIN,
                   help="non-inferiority margin on SRCC for the recommended cheapest metric "
                   f"(default {DEFAULT_MARGIN})")
    p.add_argument("--timing", action="append", default=[], metavar="FILE",
                   help="timing table (metric, seconds, pairs); repeatable; METRICS.timing.csv beside a "
                   "--metrics-table file is found automatically")
    p.add_argument("--stability", metavar="DIR", default=None,
                   help="directory with stability.csv and/or snr.csv to include")


def _statistics_options(p: ArgumentParser) -> None:
    """The bootstrap and the statistic that picks the best metric."""
    p.add_argument("--bootstrap", type=int_arg(low=0), default=1000, metavar="N",
                   help="cluster-bootstrap replicates over tracks (0: no CIs; default 1000)")
    p.add_argument("--seed", type=int_arg(low=0), default=0, help="bootstrap seed (default 0)")
    p.add_argument("--rank-by", choices=RANK_BY, default="srcc",
                   help="statistic that picks the best metric (default srcc)")


def _methods_options(p: ArgumentParser) -> None:
    """The leaderboard of reconstruction methods (analysis.methods)."""
    p.add_argument("--compare-methods", action="store_true",
                   help="rank the reconstruction methods of the pairs (column 'method'): methods.csv, "
                   "methods_paired.csv and a leaderboard in the report (--target optional with --pairs)")
    p.add_argument("--methods", action=CommaList, default=[], metavar="A,B",
                   help="with --compare-methods: the methods to compare (default: all)")
    p.add_argument("--leaderboard-metric", default=None, metavar="METRIC",
                   help="with --compare-methods: the metric that ranks the methods (default: "
                   "NVRQ-CA of the first encoder, else the first metric)")
    p.add_argument("--leaderboard-view", choices=PATHS, default="off-path", help=_HELP["view"])
    p.add_argument("--by", action=CommaList, default=[], metavar="A,B", help=_HELP["by"])
    p.add_argument("--min-clusters", type=int_arg(low=2), default=MIN_CLUSTERS, metavar="K",
                   help=_HELP["min_clusters"])
    p.add_argument("--nta", default=None, metavar="NTA.csv",
                   help="the per-box table of `nvrq proxy nta-iou`: its iou joins on pair_id as one more "
                   "metric, nta_iou (higher is better)")
    p.add_argument("--sets", default=None, metavar="SETS.csv",
                   help="with --compare-methods: the table of `nvrq score-sets` (FD, KID per method and view) "
                   "for the report's off-path metrics")


#: The help of the leaderboard's options on honest statistics.
_HELP = {
    "view": "with --compare-methods: rank on the novel views (off-path, default) or on the recorded "
            "view (on-path, offset 0)",
    "by": "with --compare-methods: also compare the methods per cell of these columns crossed: class, "
          "offset and clip attributes (e.g. class,offset or lighting,offset)",
    "min_clusters": "with --compare-methods: the fewest tracks a group needs for an interval and a "
                    f"p-value (default {MIN_CLUSTERS}; docs/FORMATS.md §11)",
}


def _horizon_options(p: ArgumentParser) -> None:
    """The trust horizon (analysis.horizon): how far off the recorded path objects stay good."""
    p.add_argument("--horizon", action="store_true",
                   help="the trust horizon per method, class, axis and direction: horizon.csv, "
                   "horizon.json, horizon_timeline.csv and a section of the report (docs/FORMATS.md §15)")
    p.add_argument("--metric", default=None, metavar="METRIC",
                   help="with --horizon: the metric (default: NVRQ-CA of the first encoder; nvrq_ca "
                   "matches nvrq_ca:ENCODER)")
    p.add_argument("--threshold", type=number_arg(), default=None, metavar="VALUE",
                   help="with --horizon: good means METRIC at or above VALUE (at or below where lower "
                   "is better); with --pairs that hold a viewpoint floor (methods perfect or floor), "
                   "METRIC minus the floor of its view; without it and --threshold-table, fitted to the votes")
    p.add_argument("--threshold-table", default=None, metavar="CSV",
                   help="with --horizon: a threshold per view (columns offset, threshold and optionally "
                   "axis and metric; a study's horizon_view_thresholds.csv is one); it must cover every "
                   "view of the grid")
    p.add_argument("--pooled-threshold", action="store_true",
                   help="with --horizon and votes: one threshold for every view, from one logistic "
                   "P(good | METRIC) (default: a threshold per view, from one intercept per view and a "
                   "shared slope)")
    p.add_argument("--view-fit", choices=VIEW_FITS, default="monotone",
                   help="with --horizon and votes: the per-view threshold is where P(good | METRIC) = P "
                   "on a monotone (isotonic) fit of the votes inside each view (default), or on one "
                   "logistic with an intercept per view and a shared slope")
    p.add_argument("--no-class-thresholds", dest="by_class", action="store_false",
                   help="with --horizon and votes: one threshold per view for every class (default: a "
                   f"class with at least {MIN_CLASS_VOTES} votes at a view, good and bad, gets its own "
                   "threshold there)")
    p.add_argument("--no-floor", dest="floor", action="store_false",
                   help="with --horizon --threshold: apply VALUE to METRIC itself even where the pairs "
                   "hold a viewpoint floor")
    p.add_argument("--share", type=number_arg(low=0, high=1, low_open=True), default=DEFAULT_SHARE,
                   metavar="S", help="with --horizon: the share of objects that must be good at every "
                   f"offset up to the horizon, in (0, 1] (default {DEFAULT_SHARE})")
    p.add_argument("--good-prob", type=number_arg(low=0, high=1, low_open=True, high_open=True),
                   default=0.5, metavar="P", help="with --horizon and votes: the threshold is the "
                   "metric value where the fitted P(good | metric) = P (default 0.5)")
    p.add_argument("--window-s", type=number_arg(low=WINDOW_S_RANGE[0], high=WINDOW_S_RANGE[1]), default=2.0,
                   metavar="W", help=f"with --horizon: the timeline's window in seconds, {WINDOW_S_RANGE[0]:g} to "
                   f"{WINDOW_S_RANGE[1]:g} (default 2)")


def _floor_options(p: ArgumentParser) -> None:
    """The viewpoint floor on real photographs (analysis.tables.real_floor)."""
    p.add_argument("--real-floor", action="store_true",
                   help="with --pairs: each metric on the real pairs (nvrq import stereo) beside the GT crop "
                   "moved 5, 10, 20 px and the other methods' renders at the matched viewing angle: "
                   "floor.csv and a section of the report (docs/FORMATS.md §16)")
    p.add_argument("--floor-pairs", default=None, metavar="PAIRS",
                   help="with --floor-metrics: a pairs table holding a perfect render (method perfect, e.g. "
                   "the same clip from nvrq synth --methods perfect:0) or a log's floor (nvrq pairs --floor); "
                   "the tent plot draws its mean per offset dashed, as the viewpoint floor")
    p.add_argument("--floor-metrics", default=None, metavar="METRICS",
                   help="with --floor-pairs: the metrics table nvrq score wrote for it")


#: The options that need --horizon (argparse dests).
HORIZON_DESTS = ("metric", "threshold", "threshold_table", "pooled_threshold", "view_fit", "by_class", "floor",
                 "share", "good_prob", "window_s")


def _output_options(p: ArgumentParser) -> None:
    """Where the report goes, and the progress bars."""
    p.add_argument("--out", required=True, metavar="REPORT_DIR", help="report directory")
    add_quiet_option(p)


#: The option groups of ``analyze``, in the order ``analyze --help`` lists them.
OPTION_GROUPS = (_input_options, _rater_options, _cost_options, _statistics_options, _methods_options,
                 _horizon_options, _floor_options, _output_options)

#: Library parameter names that differ from this CLI's argparse dests.
_ALIASES = {"n_boot": "bootstrap", "metrics_paths": "metrics_tables", "timing_paths": "timing",
            "stability_dir": "stability", "lower": "lower_better", "higher": "higher_better",
            "exclude": "exclude_raters", "rank_metric": "leaderboard_metric",
            "rank_view": "leaderboard_view", "screen": "no_screen", "screen_raters": "no_screen"}

#: Per input other than a ratings table: the options that do not apply to it (argparse dests),
#: and why. One given with a value other than its default is refused (one line, exit 2).
NOT_FOR = {
    "pairwise votes": (("target", "stability", "aggregate", "timing", "compare_methods", "methods",
                        "leaderboard_metric", "leaderboard_view", "by", "min_clusters",
                        "rank_by", "margin", "horizon", *HORIZON_DESTS, "real_floor", "floor_pairs",
                        "floor_metrics"),
                       "they rank methods by Bradley-Terry and metrics by 2AFC agreement"),
    "--pairs": (("exclude_raters", "no_screen", "screen", "stability", "aggregate", "good_prob",
                 "pooled_threshold", "view_fit", "by_class"),
                "there are no votes: no raters to screen, labels to aggregate or P(good) to fit"),
}


def _print_summary(analysis) -> None:
    from analysis.report.report import summary_display

    _print(summary_display(analysis, with_ci=False), f"metrics against {analysis.target}",
           left=("metric", "reason", "vs best"))


def _print(df, title: str, *, left=("method", "reason", "vs next")) -> None:
    """``df`` as a table on stdout: the ``left`` columns left-aligned, the others right."""
    from rich.console import Console
    from rich.table import Table

    t = Table(title=title)
    for c in df.columns:
        t.add_column(c, justify="left" if c in left else "right")
    for row in df.itertuples(index=False):
        t.add_row(*[str(v) for v in row])
    Console(width=max(120, Console().width)).print(t)


def _main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    with flags_in_errors(parser, args, _ALIASES):
        _check_compare_options(parser, args)  # before --nta's table is read
        with _nta_metrics(args):
            return _run(args)


def _check_compare_options(parser, args) -> None:
    """The options of the method comparison need ``--compare-methods``: the first one given is
    named (``--min-clusters`` also serves ``--horizon``)."""
    if args.compare_methods:
        return
    given = [d for d in ("methods", "leaderboard_metric", "leaderboard_view", "by", "nta", "sets")
             if getattr(args, d) != parser.get_default(d)]
    if args.min_clusters != MIN_CLUSTERS and not args.horizon:
        given.append("min_clusters")
    if given:
        flag = option_for(parser, args, given[0]) or "--" + given[0].replace("_", "-")
        raise InputError(param=flag, expected=f"--compare-methods as well ({flag} is an option of "
                         f"the method comparison): add --compare-methods or leave out {flag}",
                         got="no --compare-methods")


@contextlib.contextmanager
def _nta_metrics(args):
    """``--nta NTA.csv``: its ``pair_id, iou`` as a metrics table ``pair_id, nta_iou`` (written to
    a temporary folder for the run) appended to ``--metrics-table``, ``nta_iou`` higher-better."""
    if getattr(args, "nta", None) is None:
        yield
        return
    import tempfile

    from data_schema.tables import read_table, write_table

    nta = read_table(args.nta, required=("pair_id", "iou", "protocol"), what="NTA-IoU per-box table",
                     dtype={"pair_id": str, "clip_id": str})
    if (args.ratings is None) != (args.pairs is None):  # else _run says so
        from analysis.pairwise import is_pairwise
        from analysis.tables.side_tables import analysed_ids, check_nta

        if args.pairs is not None or not is_pairwise(args.ratings):  # pairwise votes: refused later
            clips, ids = analysed_ids(args.ratings, args.pairs)
            check_nta(nta, args.nta, clips=clips, pair_ids=ids)
    with tempfile.TemporaryDirectory(prefix="nvrq-nta-") as tmp:
        path = Path(tmp) / "nta_iou.csv"
        write_table(nta.loc[:, ["pair_id"]].assign(nta_iou=nta["iou"].to_numpy()), path)
        args.metrics_tables = [*args.metrics_tables, str(path)]
        args.nta_table = {str(path): args.nta}  # the temporary table stands for the --nta file
        if "nta_iou" not in args.lower_better + args.higher_better:
            args.higher_better = [*args.higher_better, "nta_iou"]
        yield


def _notes_for_report(notes: list[str], args) -> list[str]:
    """The notes as the report shows them: an input named by an absolute path is named by its
    path relative to the report folder, and the temporary table of ``--nta`` by the user's file."""
    from analysis.report.report import path_from_report

    shown = {tmp: f"--nta {path_from_report(given, args.out)}" for tmp, given in getattr(args, "nta_table", {}).items()}
    for p in args.metrics_tables:
        if Path(p).is_absolute() and str(p) not in shown:
            shown[str(p)] = path_from_report(p, args.out)
    for old, new in shown.items():
        notes = [n.replace(old, new) for n in notes]
    return notes


def _report_inputs(args) -> dict:
    """What a report is made from, for its marker (data_schema.outputs.mark_report)."""
    paths = {"RATINGS": args.ratings, "--pairs": args.pairs, "--metrics-table": args.metrics_tables,
             "--timing": args.timing, "--stability": args.stability, "--nta": args.nta,
             "--sets": args.sets}
    return {k: [Path(p) for p in v] if isinstance(v, list) else None if v is None else Path(v)
            for k, v in paths.items()}


def _run(args) -> int:
    if (args.ratings is None) == (args.pairs is None):
        raise InputError("RATINGS/--pairs", None, "either a ratings file or --pairs PAIRS",
                         "both" if args.pairs else "neither")
    check_output_folder(args.out, kind="report", option="--out", command="analyze",
                        inputs=[args.ratings or args.pairs, *args.metrics_tables, *args.timing,
                                args.stability, args.nta, args.sets, args.floor_pairs, args.floor_metrics])
    inputs = _report_inputs(args)
    note = replacing_note(args.out, command="analyze", inputs=inputs)  # read before it is replaced
    rc = _analyze(args)
    if (Path(args.out) / REPORT_MARKER).is_file():  # records the inputs for the next run's note
        mark_report(args.out, command="analyze", inputs=inputs)
    if note:
        print(note, file=sys.stderr)
    return rc


def _analyze(args) -> int:
    from analysis.pairwise import is_pairwise
    from analysis.report.methods_report import leaderboard_display
    from analysis.report.report import write_report

    _check_horizon(args)
    if (args.floor_pairs is None) != (args.floor_metrics is None):
        given, other = ("--floor-pairs", "--floor-metrics") if args.floor_metrics is None \
            else ("--floor-metrics", "--floor-pairs")
        raise InputError(given, None, f"{other} with it (the floor's pairs and their scores)", "none")
    if args.real_floor and args.pairs is None and not is_pairwise(args.ratings):
        raise InputError("--real-floor", None, "--pairs PAIRS with it (the floor needs the boxes and images "
                         "of the real pairs)", args.ratings)
    if args.ratings is not None and is_pairwise(args.ratings):
        _check_applies(args, "pairwise votes", args.ratings)
        return _run_pairwise(args)
    if args.pairs is not None:
        _check_applies(args, "--pairs", args.pairs)
        analysis = _run_pairs(args)
    else:
        analysis = _run_ratings(args)
    analysis.notes = _notes_for_report(analysis.notes, args)
    if args.sets is not None and analysis.methods is not None:
        from analysis.tables.side_tables import check_sets
        from data_schema.tables import read_table

        sets = read_table(args.sets, required=("set_id", "kind", "y_offset_m", "n_render"), what="score-sets table",
                          dtype={"clip_id": str, "method": str})
        items = analysis.items
        check_sets(sets, args.sets, clips=items["clip_id"].astype(str).unique(),
                   methods=items["method"].fillna("").astype(str).unique() if "method" in items.columns else [""])
        analysis.methods.sets = sets
    if args.horizon:
        analysis.horizon = _horizon(args, analysis)
    if args.real_floor:
        analysis.floor = _floor(args, analysis)
    if args.floor_pairs is not None:
        analysis.viewpoint_floor, sentence = _viewpoint_floor(args)
        if sentence:
            analysis.notes.append(sentence)
    out = write_report(analysis, args.out)  # then the terminal: an error stays one line
    if args.pairs is None:
        _print_screening(analysis.raters, applied=analysis.screen)
    if analysis.target is not None:
        _print_summary(analysis)
    if analysis.methods is not None:
        _print(leaderboard_display(analysis.methods), f"methods by {analysis.methods.rank_metric}")
    if getattr(analysis, "floor", None) is not None:
        from analysis.tables.real_floor import floor_display, floor_sentence

        _print(floor_display(analysis.floor), "viewpoint floor on real photographs", left=("row",))
        print(floor_sentence(analysis.floor))
    print(f"report: {out / 'report.html'}", file=sys.stderr)
    return 0


def options_from_args(args) -> AnalysisOptions:
    """The analysis options from ``analyze``'s parsed arguments (the one place they are gathered).

    Parameters
    ----------
    args : argparse.Namespace
        ``analyze``'s arguments (:func:`build_parser`).

    Returns
    -------
    analysis.options.AnalysisOptions
        The options of :func:`analysis.pipeline.run_analysis` and
        :func:`analysis.all_pairs.run_pairs_analysis`; ``compare`` is set with
        ``--compare-methods``.
    """
    compare = MethodOptions(methods=args.methods, rank_metric=args.leaderboard_metric,
                            min_clusters=args.min_clusters, by=args.by,
                            rank_view=args.leaderboard_view) if args.compare_methods else None
    return AnalysisOptions(
        metrics_paths=args.metrics_tables, lower=args.lower_better, higher=args.higher_better,
        target=args.target, exclude_raters=args.exclude_raters, screen=not args.no_screen,
        aggregate_method=args.aggregate, n_boot=args.bootstrap, seed=args.seed, rank_by=args.rank_by,
        timing_paths=args.timing, stability_dir=args.stability, margin=args.margin, compare=compare,
        progress=show_progress(args))


def _horizon_options_of(args):
    from analysis.horizon import HorizonOptions

    return HorizonOptions(metric=args.metric, threshold=args.threshold, threshold_table=args.threshold_table,
                          pooled=args.pooled_threshold, view_fit=args.view_fit, by_class=args.by_class,
                          floor=args.floor,
                          share=args.share,
                          good_prob=args.good_prob, window_s=args.window_s, min_clusters=args.min_clusters,
                          n_boot=args.bootstrap, seed=args.seed)


def _check_horizon(args) -> None:
    """The options of --horizon need it; with it, a threshold source (votes or --threshold)."""
    parser = build_parser()
    given = [d for d in HORIZON_DESTS if getattr(args, d) != parser.get_default(d)]
    if given and not args.horizon:
        flag = option_for(parser, args, given[0]) or "--" + given[0].replace("_", "-")
        raise InputError(flag, None, "--horizon with it", "none")
    if args.threshold is not None and args.threshold_table is not None:
        raise InputError("--threshold-table", None, "either --threshold or --threshold-table, not both",
                         "both")
    if args.horizon and args.pairs is not None and args.threshold is None and args.threshold_table is None:
        raise InputError("--horizon", None, "a threshold source: --threshold VALUE or --threshold-table CSV "
                         "(--pairs has no votes to fit one)", "none")


def _run_pairs(args):
    """``analyze --pairs``: the all-pairs analysis, or with --horizon or --real-floor alone theirs only."""
    if (args.horizon or args.real_floor) and args.target is None and not args.compare_methods:
        from analysis.horizon import horizon_only_analysis

        analysis = horizon_only_analysis(args.pairs, args.metrics_tables, lower=args.lower_better,
                                         higher=args.higher_better, progress=show_progress(args))
        if not args.horizon:
            analysis.notes[0] = analysis.notes[0].replace("the trust horizon only", "the viewpoint floor only")
        return analysis
    from analysis.all_pairs import run_pairs_analysis

    return run_pairs_analysis(args.pairs, options_from_args(args))


def _viewpoint_floor(args):
    """The tents' viewpoint floor from --floor-pairs and --floor-metrics and the sentence about a
    log's floor (analysis.common.viewpoint_floor.tent_floor)."""
    from analysis.common.viewpoint_floor import tent_floor
    from data_schema.tables import PAIRS_COLUMNS, TableKind, read_metrics, read_table

    pairs = read_table(args.floor_pairs, required=PAIRS_COLUMNS, kind=TableKind.PAIRS)
    return tent_floor(pairs, read_metrics(args.floor_metrics), where=args.floor_pairs)


def _floor(args, analysis):
    """The viewpoint floor of the real pairs (analysis.tables.real_floor)."""
    from analysis.tables.real_floor import read_floor_pairs, real_floor

    pairs = read_floor_pairs(args.pairs, args.metrics_tables)
    return real_floor(pairs, analysis.metrics, analysis.directions)


def _horizon(args, analysis):
    """The trust horizon of ``analysis`` (analysis.horizon), printed as one sentence per method."""
    from analysis import horizon
    from analysis.report.horizon_report import method_sentence

    opts = _horizon_options_of(args)
    if args.pairs is not None:
        items = horizon.pairs_items(analysis, args.pairs, args.metrics_tables, progress=show_progress(args))
        result = horizon.for_pairs(analysis, items, opts, where=args.pairs)
    else:
        from analysis.tables.inputs import read_ratings

        result = horizon.for_ratings(analysis, read_ratings(args.ratings), opts, where=args.ratings)
    if result.kind == "floor":
        print("note: " + result.notes[0].replace("with `floor` off it applies", "--no-floor applies it"),
              file=sys.stderr)
    for m in sorted(result.table["method"].unique()):
        print(method_sentence(m, result.table), file=sys.stderr)
    return result


def _check_applies(args, kind: str, path) -> None:
    """Refuse the first option of :data:`NOT_FOR` ``[kind]`` given with a non-default value."""
    parser = build_parser()
    dests, why = NOT_FOR[kind]
    for dest in dests:
        if getattr(args, dest) != parser.get_default(dest):
            flag = option_for(parser, args, dest) or "--" + dest.replace("_", "-")  # hidden: --screen
            raise InputError(flag, None, f"no {flag} with {kind} ({why})", path)


def _print_screening(raters, *, applied: bool) -> None:
    """Who screening (or --exclude-raters) left out and why, as the report says it (stderr)."""
    from analysis.common.text import screening_text

    print(screening_text(raters, applied=applied), file=sys.stderr)


def _run_pairwise(args) -> int:
    """Pairwise votes: Bradley-Terry, 2AFC agreement and screening (analysis.pairwise)."""
    from analysis.pairwise import run_pairwise_analysis
    from analysis.report.pairwise_report import bt_display, write_pairwise_report

    result = run_pairwise_analysis(
        args.ratings, metrics_paths=args.metrics_tables, lower=args.lower_better,
        higher=args.higher_better, exclude_raters=args.exclude_raters,
        screen_raters=not args.no_screen, n_boot=args.bootstrap, seed=args.seed)
    out = write_pairwise_report(result, args.out)
    _print_screening(result.raters, applied=result.screen)
    _print(bt_display(result.bradley_terry), "methods by Bradley-Terry (pairwise votes)")
    print(f"report: {out / 'report.html'}", file=sys.stderr)
    return 0


def _run_ratings(args):
    from analysis.pipeline import run_analysis

    return run_analysis(args.ratings, options_from_args(args))


def main(argv=None) -> int:
    """Entry point of the ``analyze`` console script: analyse ``argv`` (default
    ``sys.argv[1:]``) and return the exit status (2 for bad input,
    :func:`nvrq.cli_types.run_cli`).

    Parameters
    ----------
    argv : list of str or None
        The command-line arguments; None for ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status: 0 on success, 2 for bad input.
    """
    return run_cli(_main, argv)


if __name__ == "__main__":
    sys.exit(main())
