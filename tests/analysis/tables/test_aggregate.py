"""crowd-kit aggregation: Dawid-Skene on crowd-kit's documented toy example."""

import numpy as np
import pandas as pd
import pytest

from analysis.tables.aggregate import aggregate

# crowd-kit's step-by-step Dawid-Skene example (Toloka/crowd-kit
# tests/aggregation/test_ds_aggregation.py, fixture `data`; w3 did not answer t1). After
# one EM iteration crowd-kit documents the labels t1 yes, t2 yes, t3 no, t4 yes, t5 no and
# P(yes) = 0.65, 0.74, 0.13, 1.00, 0.05.
ROWS = """t1 w1 no;t1 w2 yes;t1 w4 yes;t1 w5 no;t2 w1 yes;t2 w2 yes;t2 w3 yes;t2 w4 no;t2 w5 no;
t3 w1 yes;t3 w2 no;t3 w3 no;t3 w4 yes;t3 w5 no;t4 w1 yes;t4 w2 yes;t4 w3 yes;t4 w4 yes;
t4 w5 yes;t5 w1 yes;t5 w2 no;t5 w3 no;t5 w4 no;t5 w5 no"""


def test_dawid_skene_one_iteration_matches_crowd_kit_documented_example():
    from crowdkit.aggregation import DawidSkene

    rows = [r.split() for r in ROWS.replace("\n", "").split(";")]
    df = pd.DataFrame(rows, columns=["task", "worker", "label"])
    ds = DawidSkene(1).fit(df)
    assert ds.labels_.sort_index().tolist() == ["yes", "yes", "no", "yes", "no"]
    assert ds.probas_["yes"].round(2).tolist() == [0.65, 0.74, 0.13, 1.0, 0.05]
    votes = pd.DataFrame({"item_id": df["task"], "rater_id": df["worker"],
                          "vote": (df["label"] == "yes").astype(int)})
    items, raters = aggregate(votes, method="dawid-skene")
    # the same answers are crowd-kit's "toy YSDA" dataset (tests/conftest.py,
    # toy_answers_df); converged Dawid-Skene must give its toy_ground_truth_df labels
    # yes, yes, no, yes, no (test_aggregate_ds_on_toy_ysda)
    assert items["model_good"].tolist() == [True, True, False, True, False]
    assert {"model_sensitivity", "model_specificity"} <= set(raters.columns)


def test_unknown_method():
    with pytest.raises(ValueError, match="method"):
        aggregate(pd.DataFrame(columns=["item_id", "rater_id", "vote"]), method="nope")


@pytest.mark.parametrize("method", ["glad", "mace"])
def test_models_rank_a_random_rater_last(method):
    """Three raters who vote the truth with accuracy 0.9 and one coin: each model's rater
    quality must put the coin last, and its labels must beat the coin-diluted majority."""
    rng = np.random.default_rng(4)
    truth = rng.random(120) < 0.5
    rows = []
    for r, acc in (("a", 0.9), ("b", 0.9), ("c", 0.9), ("coin", None)):
        v = rng.random(120) < 0.5 if acc is None else np.where(rng.random(120) < acc, truth, ~truth)
        rows += [(f"i{i}", r, int(x)) for i, x in enumerate(v)]
    votes = pd.DataFrame(rows, columns=["item_id", "rater_id", "vote"])
    items, raters = aggregate(votes, method=method, seed=0)
    col = {"glad": "model_skill", "mace": "model_competence"}[method]
    assert raters.set_index("rater_id")[col].idxmin() == "coin"
    assert (items["model_good"].to_numpy() == truth).mean() >= 0.9
