"""``analyze --aggregate`` end to end: posterior target, side-by-side labels, ceiling columns,
per-item Wilson intervals and per-condition means (issue 14 items 2-4)."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats as st

from analysis.cli import main
from annotate.results import wilson_interval
from tests.analysis.synth import make_ratings


def test_aggregate_dawid_skene_end_to_end(tmp_path, capsys):
    ratings, metrics = make_ratings()
    ratings.to_csv(tmp_path / "r.csv", index=False)
    metrics.to_csv(tmp_path / "m.csv", index=False)
    out = tmp_path / "rep"
    rc = main([str(tmp_path / "r.csv"), "--metrics-table", str(tmp_path / "m.csv"), "--lower-better",
               "blurriness", "--aggregate", "dawid-skene", "--bootstrap", "0", "--quiet",
               "--out", str(out)])
    assert rc == 0, capsys.readouterr().err
    items = pd.read_csv(out / "items.csv")
    assert items["p_good"].between(0, 1).all()
    assert (items["model_good"] == (items["p_good"] >= 0.5)).all()
    # Wilson interval of GVF: the formula in annotate.results, checked by hand for 2 of 3 below
    lo, hi = wilson_interval(items["n_good"], items["n_votes"])
    np.testing.assert_allclose(items["gvf_ci_lo"], lo)
    assert ((items["gvf_ci_lo"] <= items["gvf"]) & (items["gvf"] <= items["gvf_ci_hi"])).all()
    summary = pd.read_csv(out / "summary.csv")
    # the target is the posterior: SRCC against it, as SciPy computes it
    m = summary.set_index("metric").loc["nvrq:dinov2-small"]
    want = abs(st.spearmanr(items["nvrq:dinov2-small"], items["p_good"]).statistic)
    assert m["srcc"] == pytest.approx(want)
    assert (summary["srcc_ceiling"] > 0).all() and (summary["srcc_ceiling"] <= 1).all()
    raters = pd.read_csv(out / "raters.csv")
    kept = ~raters["excluded"]  # screening (the default) leaves flagged raters out of the model
    assert raters.loc[kept, "model_sensitivity"].between(0, 1).all()
    assert raters.loc[~kept, "model_sensitivity"].isna().all()
    md = (out / "report.md").read_text()
    differ = int((items["majority_good"] != items["model_good"]).sum())
    assert f"majority vote against dawid-skene: {differ} of {len(items)} item labels differ" in md
    assert "srcc_majority" in md and "Noise ceiling" in md
    by = pd.read_csv(out / "by_offset.csv")
    cond = by[(by["label_class"] != "all") & (by["column"] == "gvf")]
    ref = items.groupby(["y_offset_m", "label_class"])["gvf"].mean()
    got = cond.set_index(["y_offset_m", "label_class"])["mean"]
    np.testing.assert_allclose(got.loc[ref.index], ref)


def test_wilson_interval_hand_worked():
    # 2 good of 3, z = 1.96: centre (2/3 + z^2/6) / (1 + z^2/3) = 0.5731,
    # half-width z sqrt(2/27 + z^2/36) / (1 + z^2/3) = 0.3654
    lo, hi = wilson_interval(np.array([2]), np.array([3]))
    assert (lo[0], hi[0]) == pytest.approx((0.2077, 0.9385), abs=1e-4)
    assert np.isnan(wilson_interval(np.array([0]), np.array([0]))[0][0])
