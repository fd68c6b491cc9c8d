"""Breakdown tables against scipy per group and pandas groupby."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats as st

from analysis.tables.breakdowns import category_table, encoder_table, offset_table


def _items(seed=0, n=400):
    rng = np.random.default_rng(seed)
    gvf = rng.integers(0, 6, n) / 5  # GVF of 5 votes: ties
    return pd.DataFrame(
        {
            "gvf": gvf,
            "m": np.round(gvf + rng.normal(0, 0.3, n), 1),
            "label_class": rng.choice(["car", "truck", "ped"], n),
            "lighting": rng.choice(["day", "night", None], n),
            "clip_id": rng.choice([f"c{i}" for i in range(7)], n),
            "y_offset_m": rng.choice([-1.0, 0.0, 1.0, 2.0], n),
        }
    )


def test_category_table_equals_scipy_per_group():
    items = _items()
    t = category_table(items, ["m"], by=["label_class", "lighting"], progress=False)
    for _, r in t.iterrows():
        col = items[r["breakdown"]].fillna("(missing)")
        g = items[col == r["group"]]
        assert r["n"] == len(g) and r["k"] == g["clip_id"].nunique()
        assert r["plcc_signed"] == pytest.approx(st.pearsonr(g["m"], g["gvf"]).statistic, abs=1e-12)
        assert r["srcc"] == pytest.approx(abs(st.spearmanr(g["m"], g["gvf"]).statistic), abs=1e-12)


def test_category_table_undefined_group():
    items = pd.DataFrame(
        {
            "gvf": [0.0, 1.0, 0.5, 0.2, 0.4],
            "m": [1.0, 2.0, 3.0, 4.0, 5.0],
            "label_class": ["a", "a", "a", "b", "b"],
            "clip_id": "c",
        }
    )
    t = category_table(items, ["m"], by=["label_class"], progress=False).set_index("group")
    assert np.isnan(t.loc["b", "plcc"]) and t.loc["b", "reason"] == "n < 3"


def test_offset_table_equals_pandas_groupby():
    items = _items(1)
    items.loc[::7, "m"] = np.nan
    t = offset_table(items, ["gvf", "m"])
    ref = items.groupby("y_offset_m")["m"].agg(["count", "mean", "std"])  # pandas: ddof=1
    mine = t[t["column"] == "m"].set_index("y_offset_m")
    np.testing.assert_allclose(mine["n"], ref["count"])
    np.testing.assert_allclose(mine["mean"], ref["mean"])
    np.testing.assert_allclose(mine["std"], ref["std"])


def test_encoder_table_pairs_families():
    s = pd.DataFrame(
        {
            "metric": ["nvrq:a", "nvrq_ca:a", "nvrq:b", "psnr"],
            "plcc": [0.1, 0.2, 0.3, 0.4],
            "srcc": [0.5, 0.6, 0.7, 0.8],
            "n": [1, 2, 3, 4],
        }
    )
    e = encoder_table(s).set_index("encoder")
    assert e.loc["a", "nvrq_ca_srcc"] == 0.6 and e.loc["a", "nvrq_plcc"] == 0.1
    assert np.isnan(e.loc["b", "nvrq_ca_plcc"]) and "psnr" not in e.index


def test_condition_table_cis_and_sampling_spread():
    items = _items(2)
    items["n_votes"] = 5
    t = offset_table(items, ["gvf", "m"], by="label_class")
    ref = items.groupby(["y_offset_m", "label_class"])["m"]
    mine = t[t["column"] == "m"].set_index(["y_offset_m", "label_class"])
    for key, g in ref:
        lo, hi = st.t.interval(0.95, len(g) - 1, loc=g.mean(), scale=st.sem(g))  # SciPy
        assert mine.loc[key, "n"] == len(g)
        assert (mine.loc[key, "ci_lo"], mine.loc[key, "ci_hi"]) == pytest.approx((lo, hi))
    # sampling spread by hand: two items of 5 votes, GVF 0.4 and 1.0:
    # sqrt(mean(0.4 * 0.6 / 4, 0)) = sqrt(0.03)
    two = pd.DataFrame({"gvf": [0.4, 1.0], "n_votes": [5, 5], "y_offset_m": [0.0, 0.0]})
    s = offset_table(two, ["gvf"])
    assert s.loc[0, "label_class"] == "all"
    assert s.loc[0, "sampling_std"] == pytest.approx(np.sqrt(0.03))


def test_thousands_of_text_columns_get_a_capped_set_of_breakdowns(tmp_path, capsys):
    """Issue 38 item 37 (attack): 3000 extra text columns used to make 3000 breakdowns (about
    60 ms each). Now label_class, ``lighting`` and the first MAX_BREAKDOWNS - 1 extra columns
    with few values; an id-like column is skipped, and the report's note says what was."""
    import sys
    from pathlib import Path

    from analysis.cli import main
    from analysis.tables.breakdowns import MAX_BREAKDOWNS, MAX_GROUPS

    sys.path.insert(0, str(Path(__file__).parents[1]))
    from synth import make_ratings

    ratings, metrics = make_ratings()
    ratings["free_text"] = [f"note {i}" for i in range(len(ratings))]  # > MAX_GROUPS values
    extra = pd.DataFrame({f"x{i}": np.where(np.arange(len(ratings)) % 2, "a", "b")
                          for i in range(3000)}, index=ratings.index)
    pd.concat([ratings, extra], axis=1).to_csv(tmp_path / "r.csv", index=False)
    metrics.to_csv(tmp_path / "m.csv", index=False)
    rc = main([str(tmp_path / "r.csv"), "--metrics-table", str(tmp_path / "m.csv"),
               "--lower-better", "blurriness", "--bootstrap", "0", "--out", str(tmp_path / "o"),
               "--quiet"])
    assert rc == 0, capsys.readouterr().err
    got = list(dict.fromkeys(pd.read_csv(tmp_path / "o" / "categories.csv")["breakdown"]))
    want = ["label_class", "lighting"] + [f"x{i}" for i in range(MAX_BREAKDOWNS - 1)]
    assert got == want
    md = (tmp_path / "o" / "report.md").read_text()
    assert f"1 with more than {MAX_GROUPS} values (free_text)" in md
    assert f"{3000 - (MAX_BREAKDOWNS - 1)} past the first {MAX_BREAKDOWNS}" in md
