"""Writing the report directory (``analyze --out REPORT_DIR``).

Files: ``report.html`` (self-contained: figures embedded as base64 PNG, inline CSS, no
external URL), ``report.md`` (figures as relative PNG links), ``summary.csv``, ``items.csv``,
``by_offset.csv``, ``categories.csv``, ``raters.csv``, ``encoders.csv`` (when encoder
families are present), ``stability.csv`` / ``snr.csv`` (when given) and every figure as PNG
and SVG. The directory is built beside the target under a temporary name and renamed into
place at the end, so a failed run leaves no half-written report.
"""

from __future__ import annotations

import base64
import html
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from jinja2 import Environment, FileSystemLoader, select_autoescape
from markupsafe import Markup

from analysis import plots
from analysis.axes import axis_tent_plots
from analysis.pipeline import Analysis
from analysis.screening import ScreenRule
from analysis.summary import binary_label
from data_schema.outputs import check_output_folder, mark_report
from data_schema.tables import write_table

__all__ = ["write_report", "summary_display", "format_table_text"]

_DISPLAY = [
    "metric",
    "dir",
    "n",
    "plcc",
    "srcc",
    "krcc",
    "roc_auc",
    "plcc_logistic",
    "vs best",
    "reason",
]


def _fmt(v, digits: int = 3) -> str:
    if v is None or (isinstance(v, float) and not np.isfinite(v)) or v is pd.NA:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return f"{v:.{digits}f}"
    return str(v)


def _ci(row, name) -> str:
    v = _fmt(row[name])
    lo, hi = row.get(f"{name}_ci_lo"), row.get(f"{name}_ci_hi")
    if v and lo is not None and np.isfinite(lo):
        v += f" [{lo:.3f}, {hi:.3f}]"
    return v


def summary_display(a: Analysis, *, with_ci: bool = True) -> pd.DataFrame:
    """The summary as strings for the terminal and the report (CIs in brackets if ``with_ci``)."""
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
                "plcc_logistic": _fmt(r["plcc_logistic"]),
                "vs best": vs,
                "reason": r["reason"] or "",
            }
        )
    return pd.DataFrame(rows, columns=_DISPLAY)


def format_table_text(df: pd.DataFrame) -> str:
    """Plain-text aligned table (the terminal fallback without ``rich``)."""
    cols = list(df.columns)
    cells = [[str(c) for c in cols]] + [
        [_fmt(v) for v in row] for row in df.itertuples(index=False)
    ]
    widths = [max(len(r[i]) for r in cells) for i in range(len(cols))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _html_table(df: pd.DataFrame, *, best_col: str | None = None) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns if c != best_col)
    body = []
    for _, r in df.iterrows():  # report tables are small (one row per metric/group/rater)
        cls = ' class="best"' if best_col and r[best_col] else ""
        tds = "".join(f"<td>{html.escape(_fmt(r[c]))}</td>" for c in df.columns if c != best_col)
        body.append(f"<tr{cls}>{tds}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _md_table(df: pd.DataFrame) -> str:
    esc = lambda s: s.replace("|", "\\|")  # noqa: E731
    lines = [
        "| " + " | ".join(esc(str(c)) for c in df.columns) + " |",
        "|" + "|".join("---" for _ in df.columns) + "|",
    ]
    lines += [
        "| " + " | ".join(esc(_fmt(v)) for v in row) + " |" for row in df.itertuples(index=False)
    ]
    return "\n".join(lines)


def _category_wide(cat: pd.DataFrame, breakdown: str) -> pd.DataFrame:
    """Paper Table 2 layout: one row per group, n and k, then PLCC/SRCC per metric."""
    t = cat[cat["breakdown"] == breakdown]
    base = t.groupby("group", sort=True)[["n", "k"]].max()
    for m in t["metric"].unique():
        s = t[t["metric"] == m].set_index("group")
        base[f"{m} PLCC"] = s["plcc"]
        base[f"{m} SRCC"] = s["srcc"]
    return base.reset_index()


def _texts(a: Analysis) -> dict:
    s = a.summary
    tl = "GVF" if a.target == "gvf" else a.target
    best = s[s["best"]]
    if best.empty:
        best_text = "No metric has a defined " + a.rank_by.upper() + "."
    else:
        b = best.iloc[0]
        worse = s.loc[s["significant_vs_best"].fillna(False).astype(bool), "metric"].tolist()
        ns = s.loc[
            (~s["best"])
            & s["significant_vs_best"].notna()
            & ~s["significant_vs_best"].fillna(False).astype(bool),
            "metric",
        ].tolist()
        best_text = f"Best metric by |{a.rank_by.upper()}|: {b['metric']} ({b[a.rank_by]:.3f})."
        if a.n_boot:
            best_text += (
                f" Significantly different from it (95% paired cluster bootstrap): "
                f"{', '.join(worse) or 'none'}; not significantly different: {', '.join(ns) or 'none'}."
            )
    method = (
        f"plcc, srcc, krcc: absolute Pearson, Spearman and Kendall (tau-b) correlations with {tl} "
        f"over items with a finite value; signed values in summary.csv. roc_auc: area under the ROC "
        f"curve of majority_good (GVF >= 0.5) scored by the metric, negated when lower is better. "
        f"plcc_logistic: PLCC after the VQEG 4-parameter logistic fit. "
    )
    if a.n_boot:
        method += (
            f"Brackets: 95% percentile intervals of a cluster bootstrap over {a.counts['tracks']} "
            f"tracks (clip_id, track_id), {a.n_boot} replicates, seed {a.seed}. "
        )
    else:
        method += "No bootstrap (--bootstrap 0). "
    method += "Empty cells are undefined (n < 3, constant metric or target, one class only); the reason is given."
    al = a.alpha
    alpha_text = (
        "Krippendorff's alpha (nominal) over test votes: "
        + "; ".join(
            f"{k}: {_fmt(v['alpha'])}"
            + (f" ({v['reason']})" if v["reason"] else "")
            + f" from {v['votes']} votes"
            for k, v in al.items()
        )
        + "."
    )
    ex = a.raters[a.raters["excluded"]]
    screen_text = (
        "Excluded raters: "
        + "; ".join(f"{r.rater_id} ({r.excluded_reason})" for r in ex.itertuples())
        if len(ex)
        else "No rater excluded."
    )
    if not a.screen:
        screen_text += (
            " Screening flags are reported but not applied (run with --screen to apply them)."
        )
    sim = ""
    if a.counts["raters_simulated"]:
        sim = (
            f"{a.counts['raters_simulated']} of {a.counts['raters']} raters are simulated "
            "(rater_id starting with 'sim-'): these are not human judgements."
        )
    rule = ScreenRule()
    screen_rule = (
        f"--screen rule: exclude a rater when agreement with the others' majority < {rule.min_agreement} "
        f"(>= {rule.min_compared} votes), gold failure rate > {rule.max_gold_failure_rate} "
        f"(>= {rule.min_gold} gold votes), repeat consistency < {rule.min_repeat_consistency} "
        f"(>= {rule.min_repeats} repeats), straight-lining (modal share >= {rule.straight_modal_share} "
        f"while the others' is <= {rule.straight_others_max}, >= {rule.straight_min_votes} votes) or "
        f"median response < {rule.min_median_response_ms:g} ms (>= {rule.min_votes_for_speed} votes)."
    )
    notes = list(a.notes)
    if a.proxies:
        notes.append("proxy columns (use --target): " + ", ".join(a.proxies))
    return {
        "best_text": best_text,
        "method_text": method,
        "alpha_text": alpha_text,
        "screen_text": screen_text,
        "simulated": sim,
        "screen_rule": screen_rule,
        "target_label": tl,
        "notes": notes,
    }


_RATER_COLS = [
    "rater_id",
    "simulated",
    "n_test",
    "n_gold",
    "n_repeat",
    "agreement",
    "loo_corr",
    "gold_failures",
    "repeat_consistency",
    "modal_share",
    "median_response_ms",
    "flags",
    "excluded",
    "excluded_reason",
]


def _figures(a: Analysis, d: Path, tl: str) -> list[dict]:
    figs = []
    cols = [a.target] + a.metrics
    items = [
        (
            "tent",
            f"Per-offset tent plot ({tl} first, mean +/- 1 std)",
            plots.tent_plot(a.by_offset, cols, a.directions, target_label=tl),
        ),
        ("target_hist", f"{tl} distribution", plots.target_histogram(a.items, a.target, label=tl)),
    ]
    if a.by_axis is not None:  # 6-DoF views: one tent plot per axis instead of the lateral one
        items[:1] = axis_tent_plots(a.by_axis, cols, a.directions, target_label=tl)
    label, _ = binary_label(a.items, a.target)
    if label is not None:
        items.append(
            ("roc", "ROC curves of the best metrics", plots.roc_plot(a.items, a.summary, label))
        )
    if a.timing is not None:
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


def _build(a: Analysis, d: Path) -> None:
    t = _texts(a)
    write_table(a.summary, d / "summary.csv")
    write_table(a.items, d / "items.csv")
    write_table(a.by_offset, d / "by_offset.csv")
    if a.by_axis is not None:
        write_table(a.by_axis, d / "by_axis.csv")
    write_table(a.categories, d / "categories.csv")
    write_table(a.raters, d / "raters.csv")
    if len(a.encoders):
        write_table(a.encoders, d / "encoders.csv")
    if a.stability is not None:
        write_table(a.stability, d / "stability.csv")
    if a.snr is not None:
        write_table(a.snr, d / "snr.csv")
    figs = _figures(a, d, t["target_label"])
    disp = summary_display(a)
    disp_best = disp.assign(_best=a.summary["best"].to_numpy(bool))
    breakdowns = [
        {"name": b, "df": _category_wide(a.categories, b)}
        for b in a.categories["breakdown"].unique()
    ]
    raters = a.raters[[c for c in _RATER_COLS if c in a.raters.columns]]
    env = Environment(
        loader=FileSystemLoader(Path(__file__).parent / "templates"),
        autoescape=select_autoescape(["html", "j2"]),
    )
    page = env.get_template("report.html.j2").render(
        title=Path(a.ratings_path).name,
        ratings=a.ratings_path,
        counts=a.counts,
        figures=figs,
        summary_html=Markup(_html_table(disp_best, best_col="_best")),
        breakdowns=[{"name": b["name"], "html": Markup(_html_table(b["df"]))} for b in breakdowns],
        encoders_html=Markup(_html_table(a.encoders)) if len(a.encoders) else "",
        stability_html=Markup(_html_table(a.stability)) if a.stability is not None else "",
        snr_html=Markup(_html_table(a.snr)) if a.snr is not None else "",
        raters_html=Markup(_html_table(raters)),
        **t,
    )
    (d / "report.html").write_text(page, encoding="utf-8")
    md = [
        f"# NVRQ analysis: {Path(a.ratings_path).name}",
        "",
        f"Target: **{t['target_label']}**. {a.counts['items']} items, {a.counts['tracks']} tracks, "
        f"{a.counts['clips']} clips; {a.counts['test_votes_kept']} of {a.counts['test_votes']} test votes used.",
        "",
    ]
    md += [x for x in [t["simulated"]] + t["notes"] if x]
    md += [
        "",
        f"## Metrics against {t['target_label']}",
        "",
        t["best_text"],
        "",
        _md_table(disp),
        "",
        t["method_text"],
        "",
        "## Figures",
        "",
    ]
    md += [f"![{f['title']}]({f['file']})\n" for f in figs]
    for b in breakdowns:
        md += [f"## By {b['name']}", "", _md_table(b["df"]), ""]
    if len(a.encoders):
        md += ["## By encoder: NVRQ against NVRQ-CA", "", _md_table(a.encoders), ""]
    if a.stability is not None:
        md += ["## Stability", "", _md_table(a.stability), ""]
    if a.snr is not None:
        md += ["## SNR", "", _md_table(a.snr), ""]
    md += [
        "## Raters",
        "",
        t["alpha_text"],
        "",
        t["screen_text"],
        "",
        _md_table(raters),
        "",
        t["screen_rule"],
        "",
    ]
    (d / "report.md").write_text("\n".join(md), encoding="utf-8")


def write_report(a: Analysis, out_dir) -> Path:
    """Write the report directory atomically (build beside it, then swap it into place)."""
    out = check_output_folder(out_dir, kind="report", option="out_dir")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".part", dir=out.parent))
    os.chmod(tmp, 0o755)
    try:
        _build(a, tmp)
        mark_report(tmp)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = None
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".old", dir=out.parent))
        os.replace(out, old / out.name)
    os.replace(tmp, out)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    return out
