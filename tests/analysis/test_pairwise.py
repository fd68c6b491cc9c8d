"""Pairwise votes (analysis.pairwise, ``analyze VOTES.csv``): Bradley-Terry against SciPy and
crowd-kit, the 2AFC agreement by hand, the two-way bootstrap, screening, the CLI."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from crowdkit.aggregation import BradleyTerry
from scipy.optimize import minimize
from scipy.stats import binom, fisher_exact

from analysis.cli import main
from analysis.pairwise import agreement_table, rater_table, run_pairwise_analysis, side_pair_ids
from analysis.stats.bradley_terry import Draws, bradley_terry
from annotate.screening import screen

sys.path.insert(0, str(Path(__file__).parent))
from methods_data import make_method_tables, make_pairwise_votes  # noqa: E402


def _crowdkit_rows(votes: pd.DataFrame) -> pd.DataFrame:
    """Votes as crowd-kit's (worker, left, right, label) in integer counts with "a tie counts
    half": every vote becomes two comparisons, both won by the chosen side, or one won by each
    side for a tie."""
    rows = []
    for v in votes.itertuples():
        a, b = v.method_a, v.method_b
        labels = {"a": [a, a], "b": [b, b], "tie": [a, b]}[v.choice]
        rows += [(v.rater_id, a, b, lab) for lab in labels]
    return pd.DataFrame(rows, columns=["worker", "left", "right", "label"])


def test_bradley_terry_is_the_maximum_likelihood_fit():
    rng = np.random.default_rng(3)
    w = rng.integers(1, 30, (4, 4)).astype(float) + rng.integers(0, 2, (4, 4)) * 0.5
    np.fill_diagonal(w, 0)

    def nll(theta):  # -log L of the BT model, theta = log strengths with theta_0 = 0
        t = np.r_[0.0, theta]
        return -(w * (t[:, None] - np.logaddexp(t[:, None], t[None, :]))).sum()

    fit = minimize(nll, np.zeros(3), method="BFGS", options={"gtol": 1e-10})
    want = np.exp(np.r_[0.0, fit.x])
    np.testing.assert_allclose(bradley_terry(w), want / want.sum(), atol=1e-6)
    # replicates: a stack of win matrices is fitted one by one
    np.testing.assert_allclose(bradley_terry(np.stack([w, w.T])), [bradley_terry(w), bradley_terry(w.T)])


def test_a_method_that_never_won_tends_to_zero():
    p = bradley_terry(np.array([[0.0, 5.0], [0.0, 0.0]]))
    np.testing.assert_allclose(p, [1.0, 0.0], atol=1e-12)


@pytest.fixture(scope="module")
def study():
    pairs, metrics = make_method_tables()
    return pairs, metrics, make_pairwise_votes(pairs, n_raters=5)


def test_simulated_study_prefers_the_better_method_like_crowdkit(study, tmp_path_factory):
    _, metrics, votes = study
    d = tmp_path_factory.mktemp("pw")
    votes.to_csv(d / "votes.csv", index=False)
    metrics.to_csv(d / "metrics.csv", index=False)
    res = run_pairwise_analysis(d / "votes.csv", metrics_paths=[d / "metrics.csv"], n_boot=200)
    bt = res.bradley_terry.set_index(["axis", "method"]).loc["all"]
    kit = BradleyTerry(n_iter=100).fit(_crowdkit_rows(votes)).scores_
    assert bt.loc["sharp", "win_prob"] > 0.5
    assert abs(bt.loc["sharp", "win_prob"] - kit["sharp"] / (kit["sharp"] + kit["blurry"])) < 0.02
    assert bt.loc["sharp", "win_prob_ci_lo"] > 0.5
    # the metrics prefer the less degraded render, as the raters do: agreement well above chance
    agree = res.agreement.set_index("metric")
    assert agree.loc["psnr", "agreement"] > 0.7 and agree.loc["psnr", "n_votes"] == len(votes)


@pytest.mark.parametrize("chunk", [50, 8_000_000])  # replicates in chunks, or all at once
def test_two_way_bootstrap_weighs_a_vote_by_its_rater_and_item_draws(monkeypatch, chunk):
    monkeypatch.setattr("analysis.stats.bootstrap.CHUNK_CELLS", chunk)
    rng = np.random.default_rng(0)
    r, i = rng.integers(0, 4, 50), rng.integers(0, 7, 50)
    x = rng.random(50)
    draws = Draws.make(4, 7, 30, seed=1)
    explicit = (draws.raters[:, r] * draws.items[:, i] * x).sum(axis=1)
    np.testing.assert_allclose(draws.total(r, i, x), explicit)


def _votes(rows):
    cols = ["item_id", "rater_id", "choice"]
    df = pd.DataFrame(rows, columns=cols)
    return df.assign(kind="test", method_a="m1", method_b="m2", side_a="left", clip_id="c",
                     camera="front", track_id=df["item_id"], timestamp_us=0, y_offset_m=1.0)


def test_2afc_agreement_and_ceiling_by_hand():
    votes = _votes([("i1", "r1", "a"), ("i1", "r2", "b"), ("i1", "r3", "tie"),
                    ("i2", "r1", "a"), ("i2", "r2", "a")])
    # psnr prefers m1 (side a) on i1 (30 > 25) and ties on i2 (20 = 20)
    sides = {"a": {"psnr": np.array([30.0, 30, 30, 20, 20])},
             "b": {"psnr": np.array([25.0, 25, 25, 20, 20])}}
    t = agreement_table(votes, sides, {"psnr": True}, draws=None, r_codes=np.zeros(5, int),
                        i_codes=np.array([0, 0, 0, 1, 1])).set_index("metric")
    # per vote: 1 (chose a), 0 (chose b), 0.5 (rater tie), 0.5 and 0.5 (metric tie): 2.5 / 5
    assert t.loc["psnr", "agreement"] == pytest.approx(0.5)
    # two different raters of i1 (choices 1, 0, 0.5): pairs agree 0, 0.5, 0.5 -> 1/3; of i2: 1;
    # weighted by the items' votes: (3 * 1/3 + 2 * 1) / 5 = 0.6
    assert t.loc["raters (ceiling)", "agreement"] == pytest.approx(0.6)


def test_side_pair_ids_follow_the_pairs_format():
    votes = _votes([("t7", "r1", "a"), ("t8", "r1", "b")])
    assert side_pair_ids(votes, "a") == ["c:front:t7:0:+1.00:m1", "c:front:t8:0:+1.00:m1"]
    assert side_pair_ids(votes, "b") == ["c:front:t7:0:+1.00:m2", "c:front:t8:0:+1.00:m2"]
    # the export's own pair ids win where given (a gold vote's GT side has none)
    votes["pair_id_a"] = ["", "other:id"]
    assert side_pair_ids(votes, "a") == ["c:front:t7:0:+1.00:m1", "other:id"]


def test_the_exports_sided_metric_columns_serve_without_a_metrics_table(study, tmp_path):
    pairs, metrics, votes = study
    ids = {s: side_pair_ids(votes, s) for s in ("a", "b")}
    psnr = metrics.set_index("pair_id")["psnr"]
    sided = votes.assign(psnr_a=psnr.reindex(ids["a"]).to_numpy(), psnr_b=psnr.reindex(ids["b"]).to_numpy())
    sided.to_csv(tmp_path / "v.csv", index=False)
    metrics.to_csv(tmp_path / "m.csv", index=False)
    a = run_pairwise_analysis(tmp_path / "v.csv", n_boot=0).agreement.set_index("metric")
    b = run_pairwise_analysis(tmp_path / "v.csv", metrics_paths=[tmp_path / "m.csv"],
                              n_boot=0).agreement.set_index("metric")
    assert a.loc["psnr", "agreement"] == b.loc["psnr", "agreement"] > 0.7


def test_screening_flags_gold_failures_and_inconsistent_repeats():
    rows = []
    for r in ("good", "careless"):
        for k in range(12):
            rows.append({"item_id": f"g{k}", "rater_id": r, "kind": "gold", "method_a": "gt",
                         "method_b": "m1", "side_a": "left", "choice": "a" if r == "good" else "b"})
            test_choice = "a"
            rows.append({"item_id": f"t{k}", "rater_id": r, "kind": "test", "method_a": "m1",
                         "method_b": "m2", "side_a": "left", "choice": test_choice})
            rows.append({"item_id": f"t{k}", "rater_id": r, "kind": "repeat", "method_a": "m1",
                         "method_b": "m2", "side_a": "right",
                         "choice": test_choice if r == "good" or k % 2 else "b"})
    t = rater_table(pd.DataFrame(rows).assign(response_ms=900.0)).set_index("rater_id")
    assert t.loc["good", "gold_failures"] == 0 and t.loc["careless", "gold_failures"] == 12
    assert t.loc["good", "repeat_agreement"] == 1.0
    assert t.loc["careless", "repeat_agreement"] == 0.5
    # exact binomial tails: P(X >= 12), X ~ Bin(12, 0.25); P(X <= 6), X ~ Bin(12, 0.7)
    assert t.loc["careless", "gold_p"] == pytest.approx(0.25 ** 12)
    assert t.loc["careless", "repeat_p"] == pytest.approx(binom.cdf(6, 12, 0.7))
    flagged = screen(t.reset_index(), use_rule=True).set_index("rater_id")
    assert flagged.loc["careless", "excluded"] and not flagged.loc["good", "excluded"]


def test_cli_pairwise_report(study, tmp_path, capsys):
    pairs, metrics, votes = study
    votes.to_csv(tmp_path / "votes.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    rc = main([str(tmp_path / "votes.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
               "--bootstrap", "50", "--quiet", "--out", str(tmp_path / "rep")])
    assert rc == 0, capsys.readouterr().err
    rep = tmp_path / "rep"
    for f in ("bradley_terry.csv", "agreement_2afc.csv", "raters.csv", "report.html", "report.md",
              "bt_win_prob.png", "agreement_2afc.png"):
        assert (rep / f).is_file(), f
    bt = pd.read_csv(rep / "bradley_terry.csv")
    assert set(bt["axis"]) == {"all", "y_offset_m"}
    assert "methods by Bradley-Terry" in capsys.readouterr().out


@pytest.mark.parametrize("change, message", [
    (lambda v: v.assign(choice=v["choice"].where(v.index != 3, "left")),
     "votes.csv: line 5: choice: expected one of a, tie, b, got left"),
    (lambda v: v.assign(method_b=v["method_a"]), "votes.csv: line 2: method_b: expected a method other than"),
])
def test_bad_pairwise_votes_one_line_exit_2(study, tmp_path, capsys, change, message):
    _, _, votes = study
    change(votes).to_csv(tmp_path / "votes.csv", index=False)
    assert main([str(tmp_path / "votes.csv"), "--quiet", "--out", str(tmp_path / "rep")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "rep").exists()


def test_metrics_table_without_the_voted_pairs_is_refused(study, tmp_path, capsys):
    _, metrics, votes = study
    votes.to_csv(tmp_path / "votes.csv", index=False)
    metrics.assign(pair_id="x" + metrics["pair_id"]).to_csv(tmp_path / "m.csv", index=False)
    assert main([str(tmp_path / "votes.csv"), "--metrics-table", str(tmp_path / "m.csv"),
                 "--quiet", "--out", str(tmp_path / "rep")]) == 2
    assert "m.csv: pair_id: expected the pairs of the voted methods' renders" in capsys.readouterr().err


def _sided_votes(*, n_items=200, honest=5, seed=0) -> pd.DataFrame:
    """Test votes of ``honest`` raters who prefer ``m2`` (b) 90% of the time and one careless
    rater who presses left 70% of the time without looking; A's side counterbalanced per
    rater (half the items left), as :func:`annotate.assign.pairwise_sides` shows it. No gold
    and no repeats: only the agreement tests can catch the careless rater."""
    rng = np.random.default_rng(seed)
    rows = []
    for r in [f"h{k}" for k in range(honest)] + ["careless"]:
        a_left = rng.permutation(n_items) % 2 == 0
        for i in range(n_items):
            if r == "careless":
                choice = "a" if (rng.random() < 0.7) == a_left[i] else "b"
            else:
                choice = rng.choice(["b", "a", "tie"], p=[0.9, 0.05, 0.05])
            rows.append({"item_id": f"i{i}", "rater_id": r, "kind": "test", "method_a": "m1",
                         "method_b": "m2", "side_a": "left" if a_left[i] else "right",
                         "choice": choice, "response_ms": 900.0, "clip_id": "c", "camera": "front",
                         "track_id": f"t{i % 20}", "label_class": "automobile",
                         "timestamp_us": 1000 * (i // 20), "y_offset_m": 1.0})
    return pd.DataFrame(rows)


def test_a_rater_who_does_not_look_is_flagged_by_the_sides_he_pressed():
    votes = _sided_votes()
    t = rater_table(votes).set_index("rater_id")
    # by hand: per vote, the other raters' unique modal choice (a or b) and the rater's choice
    # (a or b) as sides; scipy's one-sided Fisher exact test of pressed side against mode side
    for r in ("h0", "careless"):
        mine = votes[votes["rater_id"] == r].set_index("item_id")
        others = votes[votes["rater_id"] != r]
        table = np.zeros((2, 2), int)
        for item, v in mine.iterrows():
            counts = others[others["item_id"] == item]["choice"].value_counts()
            top = counts[counts == counts.max()]
            if len(top) != 1 or top.index[0] == "tie" or v["choice"] == "tie":
                continue
            left = v["side_a"] == "left"
            mode_left = (top.index[0] == "a") == left
            pressed_left = (v["choice"] == "a") == left
            table[int(not mode_left), int(not pressed_left)] += 1
        n1, n0 = table.sum(axis=1)
        assert t.loc[r, "youden_j"] == pytest.approx(table[0, 0] / n1 + table[1, 1] / n0 - 1)
        p = fisher_exact(table, alternative="greater").pvalue
        assert t.loc[r, "skill_p"] == pytest.approx(p, rel=1e-6)
    assert t.loc["careless", "youden_j"] < 0.15 < 0.6 < t.drop("careless")["youden_j"].min()
    flagged = screen(t.reset_index(), use_rule=True).set_index("rater_id")
    assert flagged.loc["careless", "excluded"]
    assert "agreement with the others" in flagged.loc["careless", "flags"]
    assert not flagged.drop("careless")["excluded"].any()


def test_default_screening_fits_and_ceiling_use_the_raters_kept(tmp_path, capsys):
    votes = _sided_votes()
    votes.to_csv(tmp_path / "votes.csv", index=False)
    screened = run_pairwise_analysis(tmp_path / "votes.csv", n_boot=0)
    kept = run_pairwise_analysis(tmp_path / "votes.csv", n_boot=0, screen_raters=False)
    assert screened.screen and screened.raters.set_index("rater_id").loc["careless", "excluded"]
    # the same analysis with the careless rater removed by hand gives the default's numbers
    votes[votes["rater_id"] != "careless"].to_csv(tmp_path / "honest.csv", index=False)
    honest = run_pairwise_analysis(tmp_path / "honest.csv", n_boot=0, screen_raters=False)
    ceiling = {a.agreement.iloc[-1]["agreement"] for a in (screened, honest)}
    assert len(ceiling) == 1 and ceiling.pop() > kept.agreement.iloc[-1]["agreement"]
    pd.testing.assert_frame_equal(screened.bradley_terry, honest.bradley_terry)
    # the command says who and why, and the report too; --no-screen keeps the rater
    assert main([str(tmp_path / "votes.csv"), "--bootstrap", "0", "--quiet", "--out",
                 str(tmp_path / "rep")]) == 0
    err = capsys.readouterr().err
    assert "Excluded 1 of 6 raters: careless (screening: agreement with the others" in err
    assert "careless (screening: agreement" in (tmp_path / "rep" / "report.html").read_text()
    assert main([str(tmp_path / "votes.csv"), "--no-screen", "--bootstrap", "0", "--quiet",
                 "--out", str(tmp_path / "all")]) == 0
    assert "kept despite its flags: careless (" in capsys.readouterr().err
    assert not pd.read_csv(tmp_path / "all" / "raters.csv")["excluded"].any()


@pytest.mark.parametrize("extra", [["--compare-methods"], ["--rank-by", "plcc"], ["--margin", "0.05"],
                                   ["--target", "x"], ["--aggregate", "glad"], ["--timing", "t.csv"],
                                   ["--compare-methods", "--methods", "sharp,blurry"]])
def test_options_of_other_inputs_are_refused_with_pairwise_votes(study, tmp_path, capsys, extra):
    """Issue 29: `analyze votes.csv --compare-methods` on pairwise votes used to ignore the flag."""
    _, _, votes = study
    votes.to_csv(tmp_path / "votes.csv", index=False)
    rc = main([str(tmp_path / "votes.csv"), *extra, "--quiet", "--out", str(tmp_path / "rep")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert err[0].startswith(f"error: {extra[0]}: expected no {extra[0]} with pairwise votes"), err
    assert not (tmp_path / "rep").exists()


def test_a_metric_nan_on_every_render_is_reported_undefined(study, tmp_path):
    _, metrics, votes = study
    votes.to_csv(tmp_path / "votes.csv", index=False)
    metrics.assign(niqe=np.nan).to_csv(tmp_path / "metrics.csv", index=False)
    res = run_pairwise_analysis(tmp_path / "votes.csv", metrics_paths=[tmp_path / "metrics.csv"], n_boot=0)
    assert "niqe" not in set(res.agreement["metric"]) and "psnr" in set(res.agreement["metric"])
    n = 2 * int((votes["kind"] == "test").sum())  # both sides of every test vote kept
    assert f"niqe: undefined for every one of these {n} voted renders, left out" in " ".join(res.notes)


@pytest.mark.parametrize("n_raters", [1, 2, 3])
def test_rater_bootstraps_give_no_interval_below_the_minimum_of_raters(study, tmp_path, n_raters):
    # one rater used to give zero-width intervals (a resample of one rater is that rater)
    from analysis.stats.bootstrap import MIN_RATERS

    pairs, metrics, _ = study
    make_pairwise_votes(pairs, n_raters=n_raters).to_csv(tmp_path / "votes.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    res = run_pairwise_analysis(tmp_path / "votes.csv", metrics_paths=[tmp_path / "metrics.csv"], n_boot=100,
                                screen_raters=False)
    tables = {"bradley_terry": (res.bradley_terry[res.bradley_terry["n_votes"] > 0], "score_ci_lo"),
              "jod": (res.jod[res.jod["n_votes"] > 0], "jod_ci_lo"),
              "agreement": (res.agreement[res.agreement["metric"] != "raters (ceiling)"], "ci_lo")}
    for name, (t, lo) in tables.items():
        assert len(t), name
        if n_raters < MIN_RATERS:
            assert t[lo].isna().all(), name
            assert t["reason"].str.contains(f"no interval from {n_raters} rater").all(), name
        else:
            assert t[lo].notna().any(), name
    # the ceiling resamples items only: it keeps its interval
    ceiling = res.agreement.set_index("metric").loc["raters (ceiling)"]
    assert n_raters == 1 or np.isfinite(ceiling["ci_lo"])


def test_every_interval_contains_its_estimate(study, tmp_path):
    # thin, sparse studies: 3 raters voting on a few items each (the two-way bootstrap can put
    # every replicate on one side of the estimate; such an interval is left out with the reason)
    pairs, metrics, _ = study
    votes = make_pairwise_votes(pairs, n_raters=6, seed=2)
    rng = np.random.default_rng(0)
    for trial in range(4):
        v = votes[rng.random(len(votes)) < 0.15]
        v.to_csv(tmp_path / "votes.csv", index=False)
        res = run_pairwise_analysis(tmp_path / "votes.csv", n_boot=60, seed=trial, screen_raters=False)
        for t, est, lo, hi in [(res.bradley_terry, "score", "score_ci_lo", "score_ci_hi"),
                               (res.bradley_terry, "win_prob", "win_prob_ci_lo", "win_prob_ci_hi"),
                               (res.jod, "jod", "jod_ci_lo", "jod_ci_hi")]:
            given = t[t[lo].notna()]
            assert ((given[lo] <= given[est]) & (given[est] <= given[hi])).all(), (trial, est)
