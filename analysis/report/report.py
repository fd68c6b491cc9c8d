"""Writing the report directory (``analyze --out REPORT_DIR``).

Files: ``report.html`` (self-contained: figures embedded as base64 PNG, inline CSS, no
external URL) and ``report.md`` (figures as relative PNG links), both rendered from the
Jinja templates in ``templates/`` with the same context, ``summary.csv``, ``items.csv``,
``by_offset.csv``, ``categories.csv``, ``raters.csv``, ``encoders.csv`` (when encoder
families are present), ``stability.csv`` / ``snr.csv`` (when given), ``methods.csv`` /
``methods_paired.csv`` (``--compare-methods``, :mod:`analysis.methods`) and every figure as PNG
and SVG. The directory is built beside the target under a temporary name and renamed into
place at the end, so a failed run leaves no half-written report.
"""

from __future__ import annotations

import base64
import html
import os
from pathlib import Path

import numpy as np
import pandas as pd
from jinja2 import Environment, FileSystemLoader
from markupsafe import Markup

from analysis.common import plots
from analysis.common.text import MdText, cell_text, interval_text, md_escape, screening_text
from analysis.common.text import fmt as _fmt
from analysis.pipeline import Analysis
from analysis.report import horizon_report, methods_report
from analysis.stats.noninferiority import recommend_from_tables
from analysis.tables import real_floor
from analysis.tables.axes import axis_tent_plots
from analysis.tables.summary import binary_label
from annotate.screening import EXACT_J_MAX_N, ScreenRule
from data_schema.csv_safe import write_people_table as write_table
from data_schema.outputs import check_output_folder, mark_report
from data_schema.tables import atomic_folder
from data_schema.text import plural

__all__ = ["write_report", "write_report_folder", "render_pages", "summary_display", "rater_display",
           "path_from_report"]

_DISPLAY = [
    "metric",
    "dir",
    "n",
    "plcc",
    "srcc",
    "krcc",
    "roc_auc",
    "within plcc",
    "within srcc",
    "within roc_auc",
    "plcc_logistic",
    "srcc / ceiling",
    "vs best",
    "reason",
]


def _ci(row, name) -> str:
    return interval_text(row[name], row.get(f"{name}_ci_lo"), row.get(f"{name}_ci_hi"))


def _of_ceiling(row) -> str:
    """"SRCC 0.62 of a ceiling of 0.71" in short: ``0.62 / 0.71`` (empty when undefined)."""
    s, c = row.get("srcc"), row.get("srcc_ceiling")
    if s is None or c is None or not (np.isfinite(s) and np.isfinite(c)):
        return ""
    return f"{s:.2f} / {c:.2f}"


def summary_display(a: Analysis, *, with_ci: bool = True) -> pd.DataFrame:
    """The summary as strings for the terminal and the report (CIs in brackets if ``with_ci``).

    Parameters
    ----------
    a : Analysis
        The analysis.
    with_ci : bool
        Show confidence intervals in brackets.

    Returns
    -------
    pandas.DataFrame
        One row per metric, every cell a string.
    """
    ci = _ci if with_ci else (lambda row, name: _fmt(row[name]))
    rows = []
    for _, r in a.summary.iterrows():  # one row per metric
        if r["best"]:
            vs = "best"
        elif pd.isna(r["significant_vs_best"]):
            vs = ""
        else:
            pv = r["p_vs_best"]
            p_txt = f"p<{1 / a.n_boot:.3g}" if pv == 0 and a.n_boot else f"p={pv:.3f}"
            word = (
                "n.s."
                if not r["significant_vs_best"]
                else "worse"
                if r["diff_ci_lo"] > 0
                else "differs"
            )
            vs = f"{word} ({p_txt})"
        rows.append(
            {
                "metric": r["metric"],
                "dir": "\u2191" if r["higher_better"] else "\u2193",
                "n": str(r["n"]),
                "plcc": ci(r, "plcc"),
                "srcc": ci(r, "srcc"),
                "krcc": _fmt(r["krcc"]),
                "roc_auc": ci(r, "roc_auc"),
                **{f"within {k}": ci(r, f"within_{k}") if f"within_{k}" in r else ""
                   for k in ("plcc", "srcc", "roc_auc")},
                "plcc_logistic": _fmt(r["plcc_logistic"]),
                "srcc / ceiling": _of_ceiling(r),
                "vs best": vs,
                "reason": r["reason"] if isinstance(r["reason"], str) else "",
            }
        )
    terse = ("srcc / ceiling", "within plcc", "within roc_auc", "plcc_logistic", "krcc")
    cols = _DISPLAY if with_ci else [c for c in _DISPLAY if c not in terse]
    return pd.DataFrame(rows, columns=_DISPLAY)[cols]


#: A cell with more characters than this wraps, at a width that keeps it within three lines.
LONG_CELL = 40


def _td(text: str) -> str:
    """One cell: short text on one line; long text (reasons, flags) wrapped in a box about a
    third of its length wide (``ch`` is the width of a digit, about a character's)."""
    if len(text) <= LONG_CELL:
        return f"<td>{html.escape(text)}</td>"
    return f'<td class="long" style="min-width: {int(np.ceil(len(text) / 2.6))}ch">{html.escape(text)}</td>'


def _html_table(df: pd.DataFrame, *, best_col: str | None = None) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns if c != best_col)
    body = []
    for _, r in df.iterrows():  # report tables are small (one row per metric/group/rater)
        cls = ' class="best"' if best_col and r[best_col] else ""
        tds = "".join(_td(cell_text(r[c], c)) for c in df.columns if c != best_col)
        body.append(f"<tr{cls}>{tds}</tr>")
    # a wide table scrolls inside its own box: the page keeps the window's width
    return (f'<div class="scroll"><table><thead><tr>{head}</tr></thead>'
            f"<tbody>{''.join(body)}</tbody></table></div>")


def _md_table(df: pd.DataFrame) -> MdText:
    esc = lambda s: md_escape(s, cell=True)  # noqa: E731
    lines = [
        "| " + " | ".join(esc(str(c)) for c in df.columns) + " |",
        "|" + "|".join("---" for _ in df.columns) + "|",
    ]
    lines += [
        "| " + " | ".join(esc(cell_text(v, c)) for v, c in zip(row, df.columns, strict=True)) + " |"
        for row in df.itertuples(index=False)
    ]
    return MdText("\n".join(lines))


def _category_wide(cat: pd.DataFrame, breakdown: str) -> pd.DataFrame:
    """Paper Table 2 layout: one row per group, n and k, then PLCC/SRCC per metric."""
    t = cat[cat["breakdown"] == breakdown]
    base = t.groupby("group", sort=True)[["n", "k"]].max()
    cols = {}
    for m in t["metric"].unique():
        s = t[t["metric"] == m].set_index("group")
        cols[f"{m} PLCC"] = s["plcc"].reindex(base.index)
        cols[f"{m} SRCC"] = s["srcc"].reindex(base.index)
    # all at once: a column at a time fragments the frame (a warning per column past 100)
    return pd.concat([base, pd.DataFrame(cols, index=base.index)], axis=1).reset_index()


def _best_text(a: Analysis) -> str:
    s = a.summary
    best = s[s["best"]]
    if best.empty:
        return "No metric has a defined " + a.rank_by.upper() + "."
    b = best.iloc[0]
    sig = s["significant_vs_best"]
    worse = s.loc[sig.fillna(False).astype(bool), "metric"].tolist()
    ns = s.loc[(~s["best"]) & sig.notna() & ~sig.fillna(False).astype(bool), "metric"].tolist()
    text = f"Best metric by |{a.rank_by.upper()}|: {b['metric']} ({b[a.rank_by]:.3f})."
    if a.n_boot:
        text += (
            f" Significantly different from it (95% paired cluster bootstrap): "
            f"{', '.join(worse) or 'none'}; not significantly different: {', '.join(ns) or 'none'}."
        )
        rec = recommend_from_tables(s, a.timing, margin=a.margin)
        if rec is not None:  # needs the bootstrap replicates, like the comparison above
            text += " " + rec.sentence()
    return text


def _method_text(a: Analysis, tl: str) -> str:
    label = ("model_good (the model's P(good) >= 0.5)" if a.target == "p_good"
             else "majority_good (GVF >= 0.5)")
    method = (
        f"plcc, srcc, krcc: absolute Pearson, Spearman and Kendall (tau-b) correlations with {tl} "
        f"over items with a finite value; signed values in summary.csv. roc_auc: area under the ROC "
        f"curve of {label} scored by the metric, negated when lower is better. "
        f"plcc_logistic: PLCC after the VQEG 4-parameter logistic fit. "
        f"srcc / ceiling: |SRCC| beside the noise ceiling (below). "
    )
    if a.n_boot:
        method += (
            f"Brackets: 95% percentile intervals of a cluster bootstrap over {a.counts['tracks']} "
            f"tracks (clip_id, track_id), {a.n_boot} replicates, seed {a.seed}. "
        )
    else:
        method += "No bootstrap (--bootstrap 0). "
    return method + ("Empty cells are undefined (n < 3, constant metric or target, one class "
                     "only); the reason is given.")


def _rater_texts(a: Analysis) -> dict:
    alpha_text = "Krippendorff's alpha (nominal) over test votes: " + "; ".join(
        f"{k}: {_fmt(v['alpha'])}" + (f" ({v['reason']})" if v["reason"] else "")
        + f" from {plural(v['votes'], 'vote')}" for k, v in a.alpha.items()) + "."
    screen_text = screening_text(a.raters, applied=a.screen)
    sim = ""
    if a.counts["raters_simulated"]:
        sim = (
            f"{a.counts['raters_simulated']} of {plural(a.counts['raters'], 'rater')} "
            f"{'is' if a.counts['raters_simulated'] == 1 else 'are'} simulated "
            "(rater_id starting with 'sim-'): these are not human judgements."
        )
    rule = ScreenRule()
    screen_rule = (
        f"Screening rule ({'applied' if a.screen else 'off: --no-screen'}; one-sided tests at "
        f"level {rule.alpha} each): exclude a rater whose "
        f"chance-corrected agreement with the leave-one-out consensus (Youden J = sensitivity + "
        f"specificity - 1, consensus by backward elimination) is significantly below "
        f"{rule.min_j} (j_p: exact test up to {EXACT_J_MAX_N} compared items, z-test above) or who shows no skill (one-sided Fisher exact test of "
        f"votes against consensus labels, skill_p >= {rule.skill_alpha}, with >= "
        f"{rule.min_class_votes} items per consensus class), whose gold failure rate is "
        f"significantly above {rule.max_gold_failure_rate} or repeat consistency significantly "
        f"below {rule.min_repeat_consistency} (exact binomial, gold_p / repeat_p), or whose "
        f"median response is significantly below {rule.min_response_ms:g} ms (sign test, speed_p)."
    )
    return {"alpha_text": alpha_text, "screen_text": screen_text, "simulated": sim,
            "screen_rule": screen_rule}


def _label_texts(a: Analysis) -> dict:
    c = a.ceiling or {}
    ceiling_text = (
        f"Noise ceiling: split-half reliability of GVF (rater halves, Spearman-Brown) "
        f"{_fmt(c.get('reliability'))} [{_fmt(c.get('reliability_ci_lo'))}, "
        f"{_fmt(c.get('reliability_ci_hi'))}] (95% bootstrap over items); no metric can exceed "
        f"|PLCC| {_fmt(c.get('plcc_ceiling'))} or |SRCC| {_fmt(c.get('srcc_ceiling'))} "
        f"against these votes." + (f" ({c['reason']})" if c.get("reason") else "")
    )
    cmp_ = a.comparison
    comparison_text = "" if cmp_ is None else (
        f"Labels: majority vote against {cmp_['method']}: {cmp_['labels_differ']} of "
        f"{cmp_['items']} item labels differ ({cmp_['good_majority']} good by majority, "
        f"{cmp_['good_model']} by the model; target = the model's posterior P(good))."
    )
    return {"ceiling_text": ceiling_text, "comparison_text": comparison_text}


#: The report header's line on row order (docs/FORMATS.md §6), for readers of older reports.
ORDER_TEXT = {
    "ratings": "Row order: results use the canonical order (items sorted by item_id; votes by "
               "item_id, rater_id, kind), so a reordered ratings file gives this same report. "
               "Reports made before this rule followed the file's row order and may differ in "
               "bootstrap intervals, logistic fits and last digits.",
    "pairs": "Row order: results use the canonical order (pairs sorted by clip_id, then pair_id), "
             "so reordered inputs give this same report. Reports made before this rule followed "
             "the input's row order and may differ in bootstrap intervals, logistic fits and "
             "last digits.",
}


def _texts(a: Analysis) -> dict:
    tl = "GVF" if a.target == "gvf" else a.target
    notes = list(a.notes)
    if a.proxies:
        notes.append("proxy columns (use --target): " + ", ".join(a.proxies))
    if a.visibility_note:
        notes.append(a.visibility_note)
    best = _best_text(a) if a.view_text is None else a.view_text + " " + _best_text(a)
    return {"best_text": best, "method_text": _method_text(a, tl), "target_label": tl,
            "notes": notes, "order_text": ORDER_TEXT[a.source], **_rater_texts(a),
            **_label_texts(a)}


_RATER_COLS = [
    "rater_id",
    "simulated",
    "n_test",
    "n_gold",
    "n_repeat",
    "agreement",
    "kappa",
    "youden_j",
    "j_p",
    "skill_p",
    "loo_corr",
    "gold_failures",
    "gold_p",
    "repeat_consistency",
    "repeat_p",
    "modal_share",
    "median_response_ms",
    "model_sensitivity",
    "model_specificity",
    "model_skill",
    "model_competence",
    "flags",
    "excluded",
    "excluded_reason",
]


def _figures(a: Analysis, d: Path, tl: str) -> list[dict]:
    figs = []
    cols = [a.target] + a.metrics
    items = [] if a.target is None else [
        (
            "tent",
            f"Per-offset tent plot ({tl} first, mean +/- 1 std)" + (
                "; dashed: the viewpoint floor, what a perfect render of the same views scores"
                if getattr(a, "viewpoint_floor", None) is not None else ""),
            plots.tent_plot(a.by_offset, cols, a.directions, target_label=tl,
                            floor=getattr(a, "viewpoint_floor", None)),
        ),
        ("target_hist", f"{tl} distribution", plots.target_histogram(a.items, a.target, label=tl)),
        ("agreement", f"Table 1 as a figure: pooled and within-view |SRCC| with {tl}",
         plots.agreement_plot(a.summary, target_label=tl)),
    ]
    if a.by_axis is not None and items:  # 6-DoF views: one tent plot per axis instead of the lateral one
        items[:1] = axis_tent_plots(a.by_axis, cols, a.directions, target_label=tl)
    label, _ = binary_label(a.items, a.target) if items else (None, None)
    if label is not None:
        items.append(
            ("roc", "ROC curves of the best metrics", plots.roc_plot(a.items, a.summary, label))
        )
    if a.methods is not None:  # --compare-methods: the leaderboard's figures first
        items[:0] = methods_report.method_figures(a.methods)
    if a.timing is not None and a.target is not None:
        items.append(
            (
                "speed_accuracy",
                "Speed against accuracy",
                plots.speed_accuracy_plot(a.summary, a.timing, target_label=tl),
            )
        )
    for name, title, fig in items:
        if fig is None:
            continue
        png = plots.save_figure(fig, d, name)
        figs.append(
            {"title": title, "b64": base64.b64encode(png).decode("ascii"), "file": f"{name}.png"}
        )
    return figs


def _write_tables(a: Analysis, d: Path) -> None:
    write_table(a.summary, d / "summary.csv")
    if a.source == "ratings":  # --pairs: one row per pair (millions) stays in the input files
        write_table(a.items, d / "items.csv")
    write_table(a.by_offset, d / "by_offset.csv")
    if a.by_axis is not None:
        write_table(a.by_axis, d / "by_axis.csv")
    if a.visibility is not None:
        write_table(a.visibility, d / "by_visibility.csv")
    write_table(a.categories, d / "categories.csv")
    if a.source == "ratings":
        write_table(a.raters, d / "raters.csv")
    if a.methods is not None:
        write_table(a.methods.table, d / "methods.csv")
        write_table(a.methods.paired, d / "methods_paired.csv")
    for table, name in ((a.encoders if len(a.encoders) else None, "encoders"),
                        (a.stability, "stability"), (a.snr, "snr")):
        if table is not None:
            write_table(table, d / f"{name}.csv")


#: What the report's header calls its input: votes, or a pairs table without votes (--pairs).
INPUT_LABEL = {"ratings": "Ratings", "pairs": "Pairs (no votes; analyze --pairs)"}


def rater_display(raters: pd.DataFrame) -> pd.DataFrame:
    """The raters table for a page: a rater excluded by screening has its flags in
    ``excluded_reason`` (``screening: FLAGS``), so ``flags`` is left empty there instead of
    printing the same text twice.

    Parameters
    ----------
    raters : pandas.DataFrame
        Screened raters (:func:`annotate.screening.screen`), any subset of its columns.

    Returns
    -------
    pandas.DataFrame
        A copy, ``flags`` blank where ``excluded_reason`` already carries them.
    """
    if not {"flags", "excluded_reason"} <= set(raters.columns):
        return raters
    flags = raters["flags"].fillna("").astype(str)
    reason = raters["excluded_reason"].fillna("").astype(str)
    said = [bool(f) and f"screening: {f}" in r for f, r in zip(flags, reason, strict=True)]
    return raters.assign(flags=flags.where(~pd.Series(said, index=raters.index), ""))


def path_from_report(path, folder) -> str:
    """``path`` as the report in ``folder`` shows it: relative to the folder (a report moved
    with its inputs still names them rightly, and no machine's temporary folder is printed).

    Parameters
    ----------
    path : str or os.PathLike
        An input file.
    folder : str or os.PathLike
        The report folder (or the folder being built beside it: the same parent).

    Returns
    -------
    str
        The relative path with ``/`` separators (the absolute path where none exists, e.g.
        another drive).

    >>> path_from_report("/data/run/votes.csv", "/data/run/pairwise")
    '../votes.csv'
    """
    try:
        rel = os.path.relpath(Path(path).resolve(), Path(folder).resolve())
    except ValueError:
        return str(path)
    return Path(rel).as_posix()


def _context(a: Analysis, t: dict, figs: list[dict], *, table) -> dict:
    """What both templates show; ``table`` renders a DataFrame for the page (:func:`render_pages`)."""
    disp = summary_display(a).assign(_best=a.summary["best"].to_numpy(bool))
    raters = rater_display(a.raters[[c for c in _RATER_COLS if c in a.raters.columns]])
    opt = {"encoders": a.encoders if len(a.encoders) else None, "stability": a.stability,
           "snr": a.snr, "comparison": a.comparison["table"] if a.comparison else None}
    return {
        "title": Path(a.ratings_path).name,
        "ratings": path_from_report(a.ratings_path, t["folder"]),
        "input_label": INPUT_LABEL[a.source],
        "counts": a.counts,
        "figures": figs,
        "summary_table": table(disp, best_col="_best") if a.target is not None else "",
        **methods_report.context(a.methods, table),
        "breakdowns": [{"name": b, "table": table(_category_wide(a.categories, b))}
                       for b in a.categories["breakdown"].unique()],
        "raters_table": table(raters) if a.source == "ratings" else "",
        **{f"{k}_table": ("" if v is None else table(v)) for k, v in opt.items()},
        **t,
    }


def _html_page_table(df: pd.DataFrame, *, best_col: str | None = None) -> Markup:
    return Markup(_html_table(df, best_col=best_col))


def _md_page_table(df: pd.DataFrame, *, best_col: str | None = None) -> MdText:
    return _md_table(df if best_col is None else df.drop(columns=[best_col]))


def _md_finalize(v):
    return md_escape(v) if isinstance(v, str) else v


def render_pages(d: Path, template: str, context) -> None:
    """Render ``templates/TEMPLATE.html.j2`` to ``d/report.html`` (HTML-escaped) and
    ``templates/TEMPLATE.md.j2`` to ``d/report.md``; ``context(table=...)`` gives each page's
    variables, its tables rendered by ``table(df, best_col=None)`` (an HTML table, the rows
    where ``best_col`` is true marked, or a Markdown table without that column). Every text
    the Markdown page prints is escaped (:func:`analysis.common.text.md_escape`) but its own tables.

    Parameters
    ----------
    d : pathlib.Path
        The report folder written to.
    template : str
        The template name, without the ``.html.j2`` / ``.md.j2`` suffix.
    context : callable
        ``context(table=...)`` returns a dict of the page's template variables.
    """
    templates = Path(__file__).parent / "templates"
    for suffix, out, escape, table in ((".html.j2", "report.html", True, _html_page_table),
                                       (".md.j2", "report.md", False, _md_page_table)):
        env = Environment(loader=FileSystemLoader(templates), autoescape=escape, keep_trailing_newline=not escape,
                          finalize=None if escape else _md_finalize)
        env.filters["plural"] = plural  # "1 rater", "2 raters"
        page = env.get_template(template + suffix).render(**context(table=table))
        (d / out).write_text(page, encoding="utf-8")


def write_report_folder(build, out_dir) -> Path:
    """Write a report directory atomically: ``build(folder)`` fills a folder beside ``out_dir``
    that is marked as a report and swapped into place; an existing folder that is not a report
    is refused (:func:`data_schema.outputs.check_output_folder`).

    Parameters
    ----------
    build : callable
        ``build(folder)`` writes the report's files into ``folder`` (a pathlib.Path).
    out_dir : str or pathlib.Path
        The report directory to write or replace.

    Returns
    -------
    pathlib.Path
        The report directory.
    """
    out = check_output_folder(out_dir, kind="report", option="out_dir", command="analyze")
    with atomic_folder(out) as tmp:
        build(tmp)
        mark_report(tmp, command="analyze")
    return out


def _build(a: Analysis, d: Path) -> None:
    t = {**_texts(a), "folder": d}
    _write_tables(a, d)
    figs = _figures(a, d, t["target_label"])
    horizon = getattr(a, "horizon", None)  # analyze --horizon (analysis.report.horizon_report)
    hfigs = horizon_report.write_horizon(horizon, d) if horizon is not None else []
    floor = getattr(a, "floor", None)  # analyze --real-floor (analysis.tables.real_floor)
    real_floor.write_floor(floor, d)
    render_pages(d, "report", lambda table: {**_context(a, t, figs, table=table),
                                             **horizon_report.context(horizon, hfigs, table),
                                             **real_floor.context(floor, table)})


def write_report(a: Analysis, out_dir) -> Path:
    """Write the report directory atomically (build beside it, then swap it into place).

    Parameters
    ----------
    a : Analysis
        The analysis to report (tables, figures and, with ``--horizon``, its horizon).
    out_dir : str or pathlib.Path
        Where report.html and report.md go; an earlier report there is replaced.

    Returns
    -------
    pathlib.Path
        ``out_dir``, checked and complete.
    """
    return write_report_folder(lambda d: _build(a, d), out_dir)
