"""Within-view statistics and the view-only baseline (analysis.tables.within_view).

References: scipy.stats.pearsonr / spearmanr and sklearn.metrics.roc_auc_score on the same
per-view subsets, pooled with the formula written out here (n-weighted Fisher z, tanh back).
"""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats as st
from sklearn.metrics import roc_auc_score

from analysis.cli import main
from analysis.stats.bootstrap import draw_cluster_counts
from analysis.tables import within_view as wv
from analysis.tables.summary import summary_table

sys.path.insert(0, str(Path(__file__).parents[1]))
from synth import make_ratings  # noqa: E402


def _items(seed=0, n_tracks=12, n_frames=3, offsets=(-2.0, -1.0, 0.0, 1.0, 2.0)):
    rng = np.random.default_rng(seed)
    rows = [{"clip_id": "c", "track_id": f"t{t}", "frame": f, "y_offset_m": o}
            for t in range(n_tracks) for f in range(n_frames) for o in offsets]
    d = pd.DataFrame(rows)
    q = rng.normal(0, 1, n_tracks)[d["track_id"].str[1:].astype(int)]  # per-object quality
    d["gvf"] = -np.abs(d["y_offset_m"]) + 0.5 * q + rng.normal(0, 0.3, len(d))
    d["m"] = d["gvf"] + rng.normal(0, 0.8, len(d))
    d["good"] = d["majority_good"] = d["gvf"] > np.median(d["gvf"])
    return d


def _clusters(d):
    return pd.factorize(d["track_id"])[0]


def _reference(d, x, y, label):
    """Per-cell scipy/sklearn values pooled by the stated formula."""
    z, za, n = [], [], []
    zp = []
    for _, g in d.groupby("y_offset_m"):
        xi, yi = x[g.index], y[g.index]
        n.append(len(g))
        zp.append(np.arctanh(st.pearsonr(xi, yi).statistic))
        z.append(np.arctanh(st.spearmanr(xi, yi).statistic))
        za.append(roc_auc_score(label[g.index], xi))
    n = np.array(n, float)
    return (np.tanh((n * zp).sum() / n.sum()), np.tanh((n * z).sum() / n.sum()),
            (n * za).sum() / n.sum())


def test_within_view_equals_scipy_sklearn_pooled():
    d = _items()
    x, y, lab = d["m"].to_numpy(), d["gvf"].to_numpy(), d["good"].to_numpy()
    cells, k = wv.view_cells(d)
    assert k == 5
    r = wv.within_view_stats(x, y, lab, cells, _clusters(d))
    plcc, srcc, auc = _reference(d, x, y, lab)
    assert np.isclose(r["plcc"], plcc, atol=1e-12)
    assert np.isclose(r["srcc"], srcc, atol=1e-12)
    assert np.isclose(r["roc_auc"], auc, atol=1e-12)
    assert (r["cells"], r["skipped"]) == (5, 0)


def test_small_cells_are_skipped_and_counted():
    d = _items()
    extra = d[d["y_offset_m"] == 2.0].head(wv.MIN_CELL_PAIRS - 1).assign(y_offset_m=3.0)
    d2 = pd.concat([d, extra], ignore_index=True)
    r = wv.within_view_stats(d2["m"].to_numpy(), d2["gvf"].to_numpy(), None,
                             wv.view_cells(d2)[0], _clusters(d2))
    assert (r["cells"], r["skipped"]) == (5, 1)
    _, srcc, _ = _reference(d, d["m"].to_numpy(), d["gvf"].to_numpy(), d["good"].to_numpy())
    assert np.isclose(r["srcc"], srcc, atol=1e-12)  # the small cell changes nothing


def test_bootstrap_replicate_equals_resampled_data():
    """One replicate of the within-view SRCC equals the statistic of the duplicated data."""
    d = _items()
    cl = _clusters(d)
    counts = draw_cluster_counts(int(cl.max()) + 1, 3, seed=4)
    x, y = d["m"].to_numpy(), d["gvf"].to_numpy()
    r = wv.within_view_stats(x, y, None, wv.view_cells(d)[0], cl, counts=counts)
    for b in range(3):
        rep = d.loc[np.repeat(d.index.to_numpy(), counts[b][cl])].reset_index(drop=True)
        zs, ns = [], []
        for _, g in rep.groupby("y_offset_m"):
            zs.append(np.arctanh(st.spearmanr(g["m"], g["gvf"]).statistic))
            ns.append(len(g))
        ns = np.array(ns, float)
        assert np.isclose(r["replicates"]["srcc"][b], np.tanh((ns * zs).sum() / ns.sum()))


def test_offset_metric_high_pooled_zero_within():
    """-|offset| + small noise: high pooled SRCC with a GVF that falls with the offset, but
    about 0 within views, where GVF is driven by an independent per-object quality."""
    rng = np.random.default_rng(1)
    d = _items(seed=1, n_tracks=60, n_frames=4)
    d["m"] = -np.abs(d["y_offset_m"]) + rng.normal(0, 0.01, len(d))
    s = summary_table(d, ["m"], {"m": True}, target="gvf", n_boot=0)
    out = wv.within_view_columns(s, d, {"m": True}, target="gvf", label=None,
                                 clusters=_clusters(d), n_boot=50, seed=0)
    assert out.loc[0, "srcc"] > 0.6
    assert abs(out.loc[0, "within_srcc"]) < 0.1
    assert out.loc[0, "within_srcc_ci_lo"] <= out.loc[0, "within_srcc"] <= out.loc[0, "within_srcc_ci_hi"]


def test_view_only_rows_and_visibility_breakdown():
    d = _items()
    cl = _clusters(d)

    def summarize(frame, cols, dirs):
        return summary_table(frame, cols, dirs, target="gvf", n_boot=0, clusters=cl)

    s = summarize(d, ["m"], {"m": True})
    out, text, vis, note = wv.extend_summary(s, d, {"m": True}, wv.ViewInputs("gvf", None, cl),
                                             rank_by="srcc", summarize=summarize)
    row = out[out["metric"] == "view_only"].iloc[0]
    assert np.isclose(row["srcc"], abs(st.spearmanr(-np.abs(d["y_offset_m"]), d["gvf"]).statistic))
    assert np.isnan(row["within_srcc"]) and row["within_cells"] == 0  # constant in every cell
    assert "view_only" in text and "Within views, m leads" in text
    assert vis is None and "gt_visible" in note
    d["gt_visible"] = np.where(np.arange(len(d)) % 2, 1.0, 0.3)
    d["novel_visible"] = 0.9
    _, _, vis, note = wv.extend_summary(s, d, {"m": True}, wv.ViewInputs("gvf", None, cl),
                                        rank_by="srcc", summarize=summarize)
    assert note is None
    top = vis[(vis["gt_visible"] == "[0.8, 1]") & (vis["novel_visible"] == "[0.8, 1]")].iloc[0]
    sel = d["gt_visible"] == 1.0
    assert top["n"] == sel.sum()
    assert np.isclose(top["srcc"], abs(st.spearmanr(d.loc[sel, "m"], d.loc[sel, "gvf"]).statistic))


def test_view_only_row_in_table_1_of_every_output(tmp_path, capsys):
    ratings, metrics = make_ratings()
    ratings.to_csv(tmp_path / "ratings.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    out = tmp_path / "o"
    rc = main([str(tmp_path / "ratings.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
               "--lower-better", "blurriness", "--bootstrap", "50", "--out", str(out), "--quiet"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    summary = pd.read_csv(out / "summary.csv")
    assert "view_only" in summary["metric"].tolist()
    assert {"within_srcc", "within_srcc_ci_lo", "within_cells_skipped"} <= set(summary.columns)
    assert (out / "agreement.png").is_file()  # Table 1 as a figure, both numbers
    html = (out / "report.html").read_text()
    table1 = html.split("<h2>Metrics against GVF</h2>", 1)[1].split("</table>", 1)[0]
    assert "within srcc" in table1 and ">view_only<" in table1
    assert "View-only baseline view_only" in table1  # the sentence above the table
    md = (out / "report.md").read_text()
    table1 = md.split("## Metrics against GVF", 1)[1].split("\n## ", 1)[0]
    assert "within srcc" in table1 and "| view_only" in table1
    assert "View-only baseline view_only" in table1
