"""The report folder of a pairwise study (``analyze VOTES.csv`` on pairwise votes).

Layer: analysis (pairwise study report).

Files: ``bradley_terry.csv`` (:data:`analysis.pairwise.BT_COLUMNS`), ``jod.csv``
(:data:`analysis.stats.jod.JOD_COLUMNS`, the same votes on a Thurstone Case V scale), ``agreement_2afc.csv``
(:data:`analysis.pairwise.AGREEMENT_COLUMNS`, the raters' ceiling as its last row),
``raters.csv`` (screening), the figures as PNG and SVG, ``report.html`` (self-contained)
and ``report.md``. Written atomically like :func:`analysis.report.report.write_report`.
"""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.common import plots
from analysis.common.plots import VIEW_AXIS_LABELS
from analysis.common.text import interval_text, offset_text, screening_text
from analysis.pairwise import CEILING_ROW, PairwiseAnalysis
from analysis.report.report import (
    path_from_report,
    rater_display,
    render_pages,
    write_report_folder,
)
from analysis.stats.bootstrap import MIN_RATERS
from analysis.stats.jod import MAX_JOD_BOOT
from annotate.screening import ScreenRule
from data_schema.csv_safe import write_people_table as write_table
from data_schema.text import plural

__all__ = ["write_pairwise_report", "bt_display", "jod_display", "win_prob_plot", "agreement_plot"]


def bt_display(bt: pd.DataFrame, axis: str = "all") -> pd.DataFrame:
    """The Bradley-Terry rows of one view axis as strings, best first within each view.

    With two methods the strengths (summing to 1) are the win probabilities themselves, so
    the ``BT score`` column, a repeat of ``win probability``, is left out.

    Parameters
    ----------
    bt : pandas.DataFrame
        ``bradley_terry.csv`` (:data:`analysis.pairwise.BT_COLUMNS`).
    axis : str
        ``all`` (the pooled rows) or a view axis.

    Returns
    -------
    pandas.DataFrame
        One row per (view, method), text cells.
    """
    t = bt[bt["axis"] == axis].copy()
    t["_view"] = t["offset"].fillna(0.0)
    t = t.sort_values(["_view", "score"], ascending=[True, False], kind="stable")
    rows = []
    for r in t.itertuples():
        rows.append({**({} if axis == "all" else {"view": offset_text(r.offset)}), "method": r.method,
                     "votes": str(r.n_votes), "won / tied / lost": f"{r.wins} / {r.ties} / {r.losses}",
                     "win probability": interval_text(r.win_prob, r.win_prob_ci_lo, r.win_prob_ci_hi),
                     "BT score": interval_text(r.score, r.score_ci_lo, r.score_ci_hi),
                     "reason": r.reason if isinstance(r.reason, str) else ""})
    out = pd.DataFrame(rows)
    return out.drop(columns="BT score") if bt["method"].nunique() == 2 and len(out) else out


def jod_display(jod: pd.DataFrame, axis: str = "all") -> pd.DataFrame:
    """The JOD rows of one view axis as strings, best first within each view.

    Parameters
    ----------
    jod : pandas.DataFrame
        ``jod.csv`` (:data:`analysis.stats.jod.JOD_COLUMNS`).
    axis : str
        ``all`` (the pooled rows) or a view axis.

    Returns
    -------
    pandas.DataFrame
        One row per (view, method), text cells: ``method``, ``votes``, ``JOD`` with its
        interval, ``P(above next)``, ``P(prefer to next)`` and ``reason``.
    """
    t = jod[jod["axis"] == axis].copy()
    t["_view"] = t["offset"].fillna(0.0)
    t = t.sort_values(["_view", "jod"], ascending=[True, False], kind="stable", na_position="last")
    rows = []
    for r in t.itertuples():
        nxt = r.next_method if isinstance(r.next_method, str) else ""
        rows.append({**({} if axis == "all" else {"view": offset_text(r.offset)}), "method": r.method,
                     "votes": f"{r.n_votes:g}", "JOD": interval_text(r.jod, r.jod_ci_lo, r.jod_ci_hi, 2),
                     "next method": nxt,
                     "P(above next)": "" if not nxt or not np.isfinite(r.p_better_than_next)
                     else f"{r.p_better_than_next:.2f}",
                     "P(prefer to next)": "" if not nxt else f"{r.p_prefer_next:.2f}",
                     "reason": r.reason if isinstance(r.reason, str) else ""})
    return pd.DataFrame(rows)


def win_prob_plot(bt: pd.DataFrame, methods: list[str]) -> Figure | None:
    """Win probability (mean P(beats another method)) per method along each view axis,
    with its 95% interval; with two methods one line, P(first beats second) (the other is its
    mirror image); each method in its colour (:func:`analysis.common.plots.method_colours`). ``None``
    when the votes have a single view.

    Parameters
    ----------
    bt : pandas.DataFrame
        :func:`analysis.pairwise.bt_table`.
    methods : list of str
        The methods compared.

    Returns
    -------
    matplotlib.figure.Figure or None
    """
    axes_ = [a for a in dict.fromkeys(bt["axis"]) if a != "all"]
    if not axes_:
        return None
    colours = plots.method_colours(methods)
    if len(methods) == 2:  # the line of the method preferred overall: P above 0.5 is its lead
        overall = bt[bt["axis"] == "all"].set_index("method")["win_prob"].reindex(methods)
        methods = list(overall.sort_values(ascending=False, kind="stable", na_position="last").index)
    shown = methods[:1] if len(methods) == 2 else methods
    ylabel = (f"P({methods[0]} beats {methods[1]})" if len(methods) == 2
              else "Bradley-Terry win probability (higher is better)")
    fig = Figure(figsize=(4.2 * len(axes_), 3.2), layout="constrained")
    panels = fig.subplots(1, len(axes_), squeeze=False).ravel()
    for ax, axis in zip(panels, axes_, strict=True):
        t = bt[bt["axis"] == axis]
        for m in shown:
            s = t[t["method"] == m].sort_values("offset")
            x = s["offset"].to_numpy(float)
            label = ylabel if len(methods) == 2 else m
            ax.plot(x, s["win_prob"].to_numpy(float), "o-", color=colours[m], markersize=3, label=label)
            lo, hi = s["win_prob_ci_lo"].to_numpy(float), s["win_prob_ci_hi"].to_numpy(float)
            if np.isfinite(lo).any():
                ax.fill_between(x, lo, hi, color=colours[m], alpha=0.2, linewidth=0)
        ax.axhline(0.5, color="0.5", linestyle=":", linewidth=0.8)
        ax.set_ylim(0, 1)
        ax.set_xlabel(VIEW_AXIS_LABELS.get(axis, axis), fontsize=8)
        ax.set_ylabel(ylabel, fontsize=8)
        plots.offset_ticks(ax)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    panels[0].legend(fontsize=7, title=None if len(methods) == 2 else "method", title_fontsize=7)
    return fig


def agreement_plot(agreement: pd.DataFrame) -> Figure | None:
    """2AFC agreement per metric (bars with 95% intervals) beside the raters' ceiling (band).

    Parameters
    ----------
    agreement : pandas.DataFrame
        :func:`analysis.pairwise.agreement_table`.

    Returns
    -------
    matplotlib.figure.Figure or None
    """
    t = agreement[(agreement["metric"] != CEILING_ROW) & np.isfinite(agreement["agreement"].astype(float))]
    if t.empty:
        return None
    t = t.sort_values("agreement")
    fig = Figure(figsize=(5.5, 0.8 + 0.35 * len(t)), layout="constrained")
    ax = fig.subplots()
    y = np.arange(len(t))
    v = t["agreement"].to_numpy(float)
    lo, hi = t["ci_lo"].to_numpy(float), t["ci_hi"].to_numpy(float)
    err = np.where(np.isfinite(lo), [v - lo, hi - v], 0.0)
    ax.barh(y, v, xerr=err, color="C0", capsize=2)
    ax.set_yticks(y, t["metric"].tolist(), fontsize=7)
    c = agreement[agreement["metric"] == CEILING_ROW].iloc[0]
    if np.isfinite(c["agreement"]):
        ax.axvline(c["agreement"], color="C3", label="raters (ceiling)")
        if np.isfinite(c["ci_lo"]):
            ax.axvspan(c["ci_lo"], c["ci_hi"], color="C3", alpha=0.15, linewidth=0)
        plots.legend_below(fig, ax)
    ax.axvline(0.5, color="0.5", linestyle=":", linewidth=0.8)
    ax.set_xlim(0, 1)
    ax.set_xlabel("2AFC agreement with the raters' choices", fontsize=8)
    return fig


def _texts(a: PairwiseAnalysis) -> dict:
    rule = ScreenRule()
    c = a.counts
    boot = (f"Intervals: 95% percentile bootstrap over raters and items ({a.n_boot} replicates, "
            f"seed {a.seed}); the ceiling's over items." if a.n_boot else "No bootstrap (--bootstrap 0).")
    bt_text = ("Bradley-Terry strengths (sum 1; P(i preferred to j) = p_i / (p_i + p_j)) fitted by "
               "maximum likelihood (MM algorithm, Hunter 2004) to the test votes; a \"can't tell\" "
               "counts half a win for each side. Win probability: the mean of P(i preferred to j) "
               "over the other methods" + (" (with two methods it is the Bradley-Terry strength "
               "itself, so the table shows it once)" if len(a.methods) == 2 else "") + ". " + boot)
    agree_text = ("2AFC agreement (as in the BAPPS evaluation of LPIPS): per test vote, 1 when the "
                  "rater chose the render the metric scores better, 0 for the other, 0.5 when the "
                  "rater or the metric ties; each side's value is the metric of that method's pair. "
                  "Ceiling: the expected agreement of two different raters of the same item.")
    screen_text = (screening_text(a.raters, applied=a.screen) + " Bradley-Terry, the agreement and "
                   "its ceiling use the raters kept. "
                   f"Screening rule ({'applied' if a.screen else 'off: --no-screen'}): gold items "
                   f"show the GT crop itself on one side (it must be chosen; exclusion when the "
                   f"failure rate is significantly above {rule.max_gold_failure_rate}), repeats show "
                   f"a test item again with the sides swapped (exclusion when the consistency is "
                   f"significantly below {rule.min_repeat_consistency}), a median response "
                   f"significantly below {rule.min_response_ms:g} ms (one-sided exact binomial "
                   f"tests at level {rule.alpha}), and agreement with the others on sides: the "
                   f"side pressed against the side of the other raters' modal choice (A's side is "
                   f"counterbalanced, so a rater who does not look scores J = 0), excluded when J is "
                   f"significantly below {rule.min_j} or shows no skill (Fisher p >= "
                   f"{rule.skill_alpha}), as for binary votes.")
    sim = (f"{c['raters_simulated']} of {plural(c['raters'], 'rater')} "
           f"{'is' if c['raters_simulated'] == 1 else 'are'} simulated (rater_id starting with "
           "'sim-'): these are not human judgements." if c["raters_simulated"] else "")
    jod_text = ("JOD: the same test votes on a Thurstone Case V scale, in just-objectionable "
                "differences (a method 1 JOD above another is preferred by 75% of observers), fitted "
                "by maximum likelihood with pwcmp's prior for unanimous pairs and centred to mean 0. "
                "P(above next): the share of bootstrap replicates in which the method is above the "
                "next one; P(prefer to next): the share of observers the scale predicts to prefer it. "
                + (f"Brackets: 95% percentile intervals of a bootstrap over raters "
                   f"({min(a.n_boot, MAX_JOD_BOOT)} replicates, seed {a.seed}). " if a.n_boot else "")
                + f"No interval is given from fewer than {MIN_RATERS} raters, without a bootstrap "
                "(--bootstrap 0), or when the interval would not contain its own estimate; the "
                "reason column says which.")
    return {"bt_text": bt_text, "agree_text": agree_text, "screen_text": screen_text, "simulated": sim,
            "jod_text": jod_text}


def _figures(a: PairwiseAnalysis, d: Path) -> list[dict]:
    figs = []
    for name, title, fig in (("bt_win_prob", "Bradley-Terry win probability per view", win_prob_plot(a.bradley_terry, a.methods)),
                             ("agreement_2afc", "2AFC agreement of each metric with the raters",
                              agreement_plot(a.agreement))):
        if fig is None:
            continue
        png = plots.save_figure(fig, d, name)
        figs.append({"title": title, "b64": base64.b64encode(png).decode("ascii"), "file": f"{name}.png"})
    return figs


def _context(a: PairwiseAnalysis, figs, d: Path, *, table) -> dict:
    views = [table(bt_display(a.bradley_terry, axis)) for axis in dict.fromkeys(a.bradley_terry["axis"])
             if axis != "all"]
    jod = a.jod
    jod_views = [] if jod is None else [table(jod_display(jod, axis)) for axis in dict.fromkeys(jod["axis"])
                                        if axis != "all"]
    return {"title": Path(a.votes_path).name, "votes": path_from_report(a.votes_path, d), "counts": a.counts,
            "jod_table": "" if jod is None else table(jod_display(jod)), "jod_views": jod_views,
            "methods": ", ".join(a.methods), "figures": figs, "notes": a.notes,
            "bt_table": table(bt_display(a.bradley_terry)), "bt_views": views,
            "agreement_table": table(a.agreement), "raters_table": table(rater_display(a.raters)), **_texts(a)}


def _build(a: PairwiseAnalysis, d: Path) -> None:
    write_table(a.bradley_terry, d / "bradley_terry.csv")
    if a.jod is not None:
        write_table(a.jod, d / "jod.csv")
    write_table(a.agreement, d / "agreement_2afc.csv")
    write_table(a.raters, d / "raters.csv")
    figs = _figures(a, d)
    render_pages(d, "pairwise", lambda table: _context(a, figs, d, table=table))


def write_pairwise_report(a: PairwiseAnalysis, out_dir) -> Path:
    """Write the report directory atomically (build beside it, then swap it into place).

    Parameters
    ----------
    a : PairwiseAnalysis
        The analysis.
    out_dir : str or Path
        The report folder, replaced as a whole.

    Returns
    -------
    Path
        ``out_dir``.
    """
    return write_report_folder(lambda d: _build(a, d), out_dir)
