"""``analyze`` end to end on a synthetic ratings.csv, and its bad-input behaviour (docs/FORMATS.md §6, §7)."""

import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats as st
from sklearn.metrics import roc_auc_score

from analysis.cli import main

sys.path.insert(0, str(Path(__file__).parent))
from synth import make_ratings  # noqa: E402


@pytest.fixture()
def data(tmp_path):
    ratings, metrics = make_ratings()
    ratings.to_csv(tmp_path / "ratings.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    pd.DataFrame(
        {
            "metric": ["nvrq:dinov2-small", "nvrq_ca:dinov2-small", "blurriness"],
            "seconds": [10.0, 12.0, 0.5],
            "pairs": [1000, 1000, 1000],
        }
    ).to_csv(tmp_path / "metrics.timing.csv", index=False)
    return tmp_path, ratings, metrics


def _run(args, capsys):
    rc = main([str(a) for a in args] + ["--quiet"])
    return rc, capsys.readouterr()


def _run_quick(d, metrics_table, capsys, *extra):
    """``analyze`` on the fixture's ratings without bootstrap, into ``d / "o"``."""
    args = [d / "ratings.csv", "--metrics-table", metrics_table, "--lower-better", "blurriness"]
    return _run([*args, *extra, "--bootstrap", "0", "--out", d / "o"], capsys)


def _stability_dir(d):
    """A one-row ``stability.csv`` (the folder ``nvrq stability`` writes) under ``d / "stab"``."""
    stab = d / "stab"
    stab.mkdir()
    pd.DataFrame(
        {
            "metric": ["nvrq:dinov2-small"],
            "nuisance_or_artefact": ["brightness"],
            "kind": ["nuisance"],
            "strength": [0.1],
            "mean_abs_change": [0.01],
        }
    ).to_csv(stab / "stability.csv", index=False)
    return stab


def test_end_to_end_report(data, capsys):
    d, ratings, metrics = data
    stab = _stability_dir(d)
    out = d / "report"
    rc, cap = _run(
        [
            d / "ratings.csv",
            "--metrics-table", d / "metrics.csv",
            "--lower-better", "blurriness",
            "--bootstrap", "200",
            "--stability", stab,
            "--exclude-raters", "sim-4",
            "--no-screen",  # the numbers below are recomputed from every other rater's votes
            "--out", out,
        ],
        capsys,
    )
    assert rc == 0, cap.err
    for f in (
        "report.html",
        "report.md",
        "summary.csv",
        "items.csv",
        "by_offset.csv",
        "categories.csv",
        "raters.csv",
        "encoders.csv",
        "stability.csv",
        "tent.png",
        "tent.svg",
        "speed_accuracy.png",
        "roc.png",
        "target_hist.png",
    ):
        assert (out / f).is_file(), f
    assert "nvrq_ca:dinov2-small" in cap.out  # terminal summary
    html = (out / "report.html").read_text()
    assert not re.search(r"https?://", html)  # self-contained, opens offline
    assert html.count("data:image/png;base64,") == 5  # tent, histogram, agreement, ROC, speed
    assert (
        "120 items from 12 tracks in 3 clips" in html
    )  # make_ratings: 3 clips x 4 tracks x 2 frames x 5 offsets
    assert "sim-4 (--exclude-raters)" in html and "simulated" in html and "brightness" in html

    # independent recomputation of the summary from the raw votes (pandas + scipy + sklearn)
    s = pd.read_csv(out / "summary.csv").set_index("metric")
    assert {"metric", "higher_better", "n", "plcc", "srcc", "roc_auc"} <= set(
        s.reset_index().columns
    )
    t = ratings[(ratings["kind"] == "test") & (ratings["rater_id"] != "sim-4")]
    gvf = t.groupby("item_id")["vote"].mean()
    ref = metrics.set_index("pair_id").join(gvf.rename("gvf"), how="inner")
    blur = t.groupby("item_id")["blurriness"].first()
    for m in ("nvrq:dinov2-small", "nvrq_ca:dinov2-small"):
        assert s.loc[m, "plcc"] == pytest.approx(
            abs(st.pearsonr(ref[m], ref["gvf"]).statistic), abs=1e-9
        )
        assert s.loc[m, "srcc"] == pytest.approx(
            abs(st.spearmanr(ref[m], ref["gvf"]).statistic), abs=1e-9
        )
        assert s.loc[m, "roc_auc"] == pytest.approx(
            roc_auc_score(ref["gvf"] >= 0.5, ref[m]), abs=1e-9
        )
        assert s.loc[m, "plcc_ci_lo"] <= s.loc[m, "plcc"] <= s.loc[m, "plcc_ci_hi"]
    g = gvf.loc[blur.index]
    assert s.loc["blurriness", "roc_auc"] == pytest.approx(roc_auc_score(g >= 0.5, -blur), abs=1e-9)
    assert not s.loc["blurriness", "higher_better"]
    assert s["best"].sum() == 1
    r = pd.read_csv(out / "raters.csv").set_index("rater_id")
    assert r.loc["sim-4", "excluded"] and not r.loc["sim-0", "excluded"]
    cats = pd.read_csv(out / "categories.csv")
    assert set(cats["breakdown"]) == {"label_class", "lighting"}
    assert set(pd.read_csv(out / "by_offset.csv")["y_offset_m"]) == {-2.0, -1.0, 0.0, 1.0, 2.0}


def test_target_proxy_and_undefined_metric(data, capsys):
    d, ratings, metrics = data
    metrics["flat"] = 0.5  # constant metric -> empty with reason
    metrics.to_csv(d / "m2.csv", index=False)
    rc, cap = _run_quick(d, d / "m2.csv", capsys, "--higher-better", "flat", "--target", "s_det")
    assert rc == 0, cap.err
    s = pd.read_csv(d / "o" / "summary.csv").set_index("metric")
    assert np.isnan(s.loc["flat", "plcc"]) and "constant metric" in s.loc["flat", "reason"]
    assert (
        np.isnan(s.loc["nvrq:dinov2-small", "roc_auc"])
        and "not binary" in s.loc["nvrq:dinov2-small", "reason"]
    )
    items = pd.read_csv(d / "o" / "items.csv")
    ok = items[["nvrq:dinov2-small", "s_det"]].dropna()
    assert s.loc["nvrq:dinov2-small", "srcc"] == pytest.approx(
        abs(st.spearmanr(ok["nvrq:dinov2-small"], ok["s_det"]).statistic), abs=1e-9
    )


def test_unknown_metric_ids_are_counted(data, capsys):
    d, ratings, metrics = data
    extra = pd.concat([metrics, metrics.head(3).assign(pair_id=["x:1", "x:2", "x:3"])])
    extra.to_csv(d / "m3.csv", index=False)
    rc, cap = _run_quick(d, d / "m3.csv", capsys)
    assert rc == 0
    assert "3 pair ids are not rated items" in (d / "o" / "report.md").read_text()


def _bad(d, ratings, mutate):
    df = mutate(ratings.copy())
    df.to_csv(d / "bad.csv", index=False)
    return d / "bad.csv"


@pytest.mark.parametrize(
    "mutate, needle",
    [
        (lambda r: r.drop(columns=["vote"]), "vote"),
        (
            lambda r: r.assign(vote=r["vote"].where(r.index != 5, 2)),
            "line 7: vote: expected 0 or 1",
        ),
        (lambda r: pd.concat([r, r.iloc[[0]]]), "one row per (rater_id, item_id, kind)"),
        (lambda r: r.iloc[:0], "at least one vote row"),
        (lambda r: r, "blurriness"),  # unknown direction without --lower-better
        (lambda r: r.assign(kind="test2"), "kind"),
    ],
)
def test_bad_input_exits_2_with_one_line(data, capsys, mutate, needle):
    d, ratings, _ = data
    path = _bad(d, ratings, mutate)
    rc, cap = _run([path, "--out", d / "o"], capsys)
    assert rc == 2
    assert len(cap.err.strip().splitlines()) == 1 and needle in cap.err
    assert not (d / "o").exists()  # nothing half-written


def test_bad_metrics_file_and_missing_file(data, capsys):
    d, ratings, metrics = data
    metrics["nvrq:x"] = "abc"
    metrics.to_csv(d / "m.csv", index=False)
    rc, cap = _run([d / "ratings.csv", "--metrics-table", d / "m.csv", "--out", d / "o"], capsys)
    assert rc == 2 and "numeric" in cap.err and len(cap.err.strip().splitlines()) == 1
    rc, cap = _run([d / "nope.csv", "--out", d / "o"], capsys)
    assert rc == 2 and "nope.csv" in cap.err


def test_screening_excludes_a_fast_straight_liner_by_default(data, capsys):
    d, ratings, metrics = data
    spam = ratings[(ratings["rater_id"] == "sim-0") & (ratings["kind"] == "test")].copy()
    spam["rater_id"], spam["vote"], spam["response_ms"] = "spammer", 1, 120
    pd.concat([ratings, spam]).to_csv(d / "r.csv", index=False)
    args = [d / "r.csv", "--metrics-table", d / "metrics.csv", "--lower-better", "blurriness"]
    args += ["--bootstrap", "0"]
    rc, cap = _run(args + ["--no-screen", "--out", d / "kept"], capsys)
    r = pd.read_csv(d / "kept" / "raters.csv").set_index("rater_id")
    assert rc == 0 and not r["excluded"].any()  # --no-screen: flags reported, nobody excluded
    assert (
        "median response" in r.loc["spammer", "flags"]
        and "agreement with the others" in r.loc["spammer", "flags"]  # J = 0 when straight-lining
    )
    assert "Screening off (--no-screen): kept despite its flags: " in cap.err and "spammer (" in cap.err
    rc, cap = _run(args + ["--out", d / "screened"], capsys)
    r = pd.read_csv(d / "screened" / "raters.csv").set_index("rater_id")
    assert rc == 0 and r.loc["spammer", "excluded"]
    # every exclusion is by the rule, with its flags as the reason (noisy sim raters may be flagged too)
    ex = r[r["excluded"]]
    assert all(
        reason == "screening: " + f
        for reason, f in zip(ex["excluded_reason"], ex["flags"], strict=True)
    )
    assert f"Excluded {len(ex)} of {len(r)} raters: " in cap.err  # on the terminal, who and why
    assert "spammer (screening: " + r.loc["spammer", "flags"] in cap.err
    assert "spammer (screening:" in (d / "screened" / "report.html").read_text()
    # the old --screen is the default now: the same report, and one note
    rc, cap = _run(args + ["--screen", "--out", d / "old"], capsys)
    assert rc == 0 and "note: --screen is deprecated" in cap.err
    assert pd.read_csv(d / "old" / "raters.csv")["excluded"].tolist() == r["excluded"].tolist()


def test_no_metric_columns_still_reports_gvf(data, capsys):
    d, ratings, _ = data
    ratings.drop(columns=["blurriness", "s_det"]).to_csv(d / "r.csv", index=False)
    rc, cap = _run([d / "r.csv", "--out", d / "o"], capsys)
    assert rc == 0, cap.err
    assert len(pd.read_csv(d / "o" / "summary.csv")) == 0
    assert "No metric has a defined SRCC" in (d / "o" / "report.html").read_text()


def test_report_is_replaced_whole_or_not_at_all(data, capsys, monkeypatch):
    import analysis.report.report as report

    d, _, _ = data
    rc, cap = _run_quick(d, d / "metrics.csv", capsys)
    assert rc == 0, cap.err
    before = sorted(p.name for p in (d / "o").iterdir())
    siblings = sorted(p.name for p in d.iterdir())

    def broken(a, tmp):
        (tmp / "report.html").write_text("half")
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "_build", broken)
    with pytest.raises(KeyboardInterrupt):
        report.write_report(None, d / "o")
    assert sorted(p.name for p in (d / "o").iterdir()) == before  # the old report stays
    assert (d / "o" / "report.html").read_text() != "half"
    assert sorted(p.name for p in d.iterdir()) == siblings  # no .part folder left


def test_bad_stability_or_timing_input_ends_before_the_statistics(data, capsys, monkeypatch):
    """Every input file is read before the bootstrap (issue 23 item 2): a missing --stability
    folder or a broken --timing file ends the run before any statistic is computed."""
    import analysis.pipeline

    def computed(*args, **kwargs):
        raise AssertionError("statistics computed before the inputs were all read")

    monkeypatch.setattr(analysis.pipeline, "summary_table", computed)
    d, _, _ = data
    rc, cap = _run_quick(d, d / "metrics.csv", capsys, "--stability", d / "no-such-dir")
    assert rc == 2 and "no-such-dir" in cap.err and len(cap.err.strip().splitlines()) == 1
    (d / "bad.timing.csv").write_text("metric,seconds\npsnr,1\n")
    rc, cap = _run_quick(d, d / "metrics.csv", capsys, "--timing", d / "bad.timing.csv")
    assert rc == 2 and "bad.timing.csv" in cap.err and len(cap.err.strip().splitlines()) == 1
    assert not (d / "o").exists()
