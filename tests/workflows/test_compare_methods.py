"""Issue 20 acceptance, end to end through the commands a user runs: a synthetic clip rendered
by two methods (artefact scales 0.5 and 1.5) is ranked by ``analyze --compare-methods``, and a
pairwise study of it with 5 simulated raters confirms the ranking (docs/FORMATS.md §11-12).

What the clip shows (measured at 320x180, seeds 0 and 1): NVRQ-CA ranks the less degraded method first
at every offset. PSNR does so at offset 0 only: at |offset| >= 1 the render is seen from
another viewpoint than the GT crop, and under that misalignment the blurrier render scores
no worse (at -1 m on seed 1 significantly better: -0.35 dB [-0.51, -0.15]). The leaderboard
must report that as it is: a verdict only where the paired interval says so."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from crowdkit.aggregation import BradleyTerry

from analysis.cli import main as analyze_main
from annotate.cli import main as annotate_main
from tests.workflows.two_methods import ok as _ok
from tests.workflows.two_methods import scored_clip

pytestmark = pytest.mark.slow

NVRQ_CA = "nvrq_ca:efficientnet-lite0"


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    d = tmp_path_factory.mktemp("compare")
    # 640x360 keeps 12 tracks (320x180: 8): a sign-flip test over 8 tracks cannot go below
    # 2/2^8, and Holm over the 14 paired rows of two metrics then calls nothing (issue 29)
    scored_clip(d, offsets="-2,-1,0,1,2", metrics="psnr,nvrq_ca")
    return d


def test_leaderboard_puts_the_less_degraded_method_first(clip):
    _ok(analyze_main(["--pairs", str(clip / "pairs.csv"), "--metrics-table", str(clip / "metrics.csv"),
                      "--compare-methods", "--bootstrap", "500", "--quiet", "--out", str(clip / "board")]))
    paired = pd.read_csv(clip / "board" / "methods_paired.csv")
    table = pd.read_csv(clip / "board" / "methods.csv")
    assert (paired[["method_a", "method_b"]] == ["sharp", "blurry"]).all(axis=None)
    # NVRQ-CA ranks sharp first off the recorded path, PSNR on it only (module docstring)
    for metric, view in ((NVRQ_CA, "off-path"), ("psnr", "on-path")):
        overall = table[(table["metric"] == metric) & (table["breakdown"] == view)].set_index("method")
        assert overall.loc["sharp", "mean"] > overall.loc["blurry", "mean"]
        rows = paired[(paired["metric"] == metric) & (paired["axis"] == "y_offset_m") & paired["by"].isna()]
        assert sorted(rows["offset"]) == [-2, -1, 0, 1, 2]
        # every verdict is the paired interval's: 'a' or 'b' only when it excludes 0 (Holm p < 0.05)
        excludes = (rows["ci_lo"] > 0) | (rows["ci_hi"] < 0)
        assert ((rows["better"] != "neither") <= (excludes & (rows["p_holm"] < 0.05))).all()
        named = np.where(rows["mean_diff"] > 0, "sharp", "blurry")  # better names the method
        assert (rows["better"] == named)[rows["better"] != "neither"].all()
    nv = paired[(paired["metric"] == NVRQ_CA) & (paired["axis"] == "y_offset_m")]
    far = nv[nv["offset"].abs() >= 1]
    assert (far["ci_lo"] > 0).all() and (far["better"] == "sharp").all(), far
    # offset 0 is the on-path row: tested like any view (at 320x180 its difference was under a
    # quarter of those at |offset| >= 1; at 640x360 the blur shows there too, 0.037 against
    # 0.080 at +-2 m, and the test says so)
    zero = nv[nv["offset"] == 0].iloc[0]
    on = paired[(paired["metric"] == NVRQ_CA) & (paired["axis"] == "on-path")].iloc[0]
    assert (on[["n", "mean_diff", "p", "better"]] == zero[["n", "mean_diff", "p", "better"]]).all()
    ps = paired[(paired["metric"] == "psnr") & (paired["axis"] == "y_offset_m")]
    assert ps.loc[ps["offset"] == 0, "better"].iloc[0] == "sharp"  # aligned crops: PSNR sees the blur
    html = (clip / "board" / "report.html").read_text()
    assert "Leaderboard of methods by " + NVRQ_CA in html and "better than blurry" in html


def test_pairwise_study_confirms_the_ranking(clip):
    study, votes = clip / "study", clip / "votes.csv"
    _ok(annotate_main(["build", str(study), "--pairs", str(clip / "pairs.csv"), "--metrics-table",
                       str(clip / "metrics.csv"), "--design", "pairwise", "--seed", "0"]))
    _ok(annotate_main(["simulate", str(study), "--raters", "5", "--seed", "0"]))
    _ok(annotate_main(["export", str(study), "--out", str(votes)]))
    _ok(analyze_main([str(votes), "--metrics-table", str(clip / "metrics.csv"), "--bootstrap", "200",
                      "--quiet", "--out", str(clip / "pairwise")]))
    bt = pd.read_csv(clip / "pairwise" / "bradley_terry.csv")
    overall = bt[bt["axis"] == "all"].set_index("method")
    ours = overall.loc["sharp", "win_prob"]
    assert ours > 0.5
    # crowd-kit's BradleyTerry on the exported test votes of the raters kept; "a tie counts half" in its integer
    # counts: each vote is two comparisons won by the chosen side, a tie one for each side
    v = pd.read_csv(votes)
    raters = pd.read_csv(clip / "pairwise" / "raters.csv")  # the fit uses the raters screening kept
    v = v[(v["kind"] == "test") & v["rater_id"].isin(raters.loc[~raters["excluded"], "rater_id"])]
    rows = []
    for r in v.itertuples():
        won = {"a": [r.method_a] * 2, "b": [r.method_b] * 2, "tie": [r.method_a, r.method_b]}[r.choice]
        rows += [(r.rater_id, r.method_a, r.method_b, w) for w in won]
    kit = BradleyTerry(n_iter=100).fit(pd.DataFrame(rows, columns=["worker", "left", "right", "label"]))
    s = kit.scores_
    assert abs(ours - s["sharp"] / (s["sharp"] + s["blurry"])) < 0.02
    agree = pd.read_csv(clip / "pairwise" / "agreement_2afc.csv").set_index("metric")
    assert np.isfinite(agree.loc[NVRQ_CA, "agreement"]) and agree.loc[NVRQ_CA, "n_votes"] > 0


def test_default_report_excludes_the_careless_simulated_rater(clip):
    """Issue 29: with default options the pairwise report leaves out the simulated rater who
    presses at random (caught by the agreement tests on sides, whatever its gold and repeats
    say) and keeps the careful ones; Bradley-Terry and the ceiling use the raters kept."""
    if not (clip / "votes.csv").is_file():
        test_pairwise_study_confirms_the_ranking(clip)
    r = pd.read_csv(clip / "pairwise" / "raters.csv").set_index("rater_id")
    assert r.loc["sim-careless", "excluded"] and "agreement with the others" in r.loc["sim-careless", "flags"]
    assert not r.drop("sim-careless")["excluded"].any()
    v = pd.read_csv(clip / "votes.csv")
    bt = pd.read_csv(clip / "pairwise" / "bradley_terry.csv")
    kept = v[(v["kind"] == "test") & (v["rater_id"] != "sim-careless")]
    assert bt.loc[bt["axis"] == "all", "n_votes"].iloc[0] == len(kept)
    assert "Excluded 1 of 5 raters: sim-careless (screening:" in (clip / "pairwise" / "report.html").read_text()
