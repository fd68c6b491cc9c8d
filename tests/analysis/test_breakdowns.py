"""Breakdown tables against scipy per group and pandas groupby."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats as st

from analysis.breakdowns import category_table, encoder_table, offset_table


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
