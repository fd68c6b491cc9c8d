"""Per-view thresholds of the trust horizon: a threshold per view in nvrq.horizon, the table a
user gives, the viewpoint floor, the people's per-view fit with its interval, fitted thresholds
clipped to the rated values, and what horizon.json records per row. Hand-made tables whose
answers are worked out by hand."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from analysis.cli import main as analyze_main
from analysis.stats.horizon_fit import fit_logistic, logistic_threshold, vote_threshold
from analysis.stats.horizon_views import (
    floor_views,
    grid_of,
    people_views,
    read_view_table,
    viewpoint_floor,
)
from data_schema.errors import InputError
from nvrq.horizon import Threshold, trust_horizon

OFFSETS = [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]
#: what a render with no artefact scores at each |offset| (the viewpoint alone)
FLOOR = {0.0: 0.99, 1.0: 0.5, 2.0: 0.3, 3.0: 0.2}


def scene(n_tracks=10, methods=(("perfect", 0.0), ("sharp", 0.05), ("blurry", 0.3))) -> pd.DataFrame:
    """Each method scores the floor of its view less its own loss (off the path), +-0.01 per track."""
    rows = []
    for method, loss in methods:
        for t in range(n_tracks):
            for y in OFFSETS:
                score = FLOOR[abs(y)] - (loss if y else 0.0) + 0.01 * (t % 3 - 1)
                rows.append({"clip_id": "c", "track_id": f"t{t:02d}", "label_class": "automobile",
                             "method": method, "y_offset_m": y, "score": score})
    return pd.DataFrame(rows)


def _h(table, th):
    h = trust_horizon(table, threshold=th, n_boot=0)
    return h.set_index(["method", "direction"])


def test_a_threshold_per_view_judges_each_view_by_its_own():
    s = scene()
    # one threshold (0.4) reads the viewpoint: even perfect stops at 1 m
    one = _h(s, Threshold("score", 0.4))
    assert one.loc[("perfect", "left"), "horizon"] == 1.0 and one.loc[("sharp", "left"), "horizon"] == 1.0
    # a threshold per view, 0.1 below the floor: perfect and sharp beyond the grid, blurry 0 m
    views = pd.DataFrame({"axis": ["none"] + ["y"] * 6, "offset": [0.0, -3, -2, -1, 1, 2, 3],
                          "threshold": [FLOOR[0.0] - 0.1] + [FLOOR[abs(o)] - 0.1 for o in (-3, -2, -1, 1, 2, 3)],
                          "source": "by hand"})
    per = _h(s, Threshold("score", np.nan, views=views))
    for d in ("left", "right"):
        assert per.loc[("perfect", d), "reason"] == "beyond the grid" and per.loc[("sharp", d), "horizon"] == 3.0
        assert per.loc[("blurry", d), "horizon"] == 0.0
    assert (per["threshold_source"] == "by hand").all() and per["threshold"].isna().all()
    # offset 0 is the recorded view whatever axis the table gives it
    same = _h(s, Threshold("score", np.nan, views=views.assign(axis="y")))
    pd.testing.assert_frame_equal(same, per)
    with pytest.raises(InputError, match="none at y \\+3"):
        _h(s, Threshold("score", np.nan, views=views[views["offset"] != 3]))


def test_a_user_table_must_cover_the_grid(tmp_path):
    s = scene()
    grid = grid_of(s)
    assert grid == [("none", 0.0)] + [("y", o) for o in (-3.0, -2.0, -1.0, 1.0, 2.0, 3.0)]
    path = tmp_path / "t.csv"
    pd.DataFrame({"offset": OFFSETS, "threshold": [0.1, 0.2, 0.4, 0.9, 0.4, 0.2, 0.1]}).to_csv(path, index=False)
    t = read_view_table(path, grid, metric="score")
    assert t.set_index("offset").loc[0.0, "axis"] == "none" and t.set_index("offset").loc[2.0, "threshold"] == 0.2
    pd.DataFrame({"offset": OFFSETS[1:], "threshold": 0.1}).to_csv(path, index=False)
    with pytest.raises(InputError, match="none for y -3"):
        read_view_table(path, grid, metric="score")
    pd.DataFrame({"offset": OFFSETS, "threshold": 0.1, "metric": "psnr"}).to_csv(path, index=False)
    with pytest.raises(InputError, match="psnr"):
        read_view_table(path, grid, metric="score")


def test_the_floor_is_the_median_of_perfect_and_the_threshold_its_excess():
    s = scene()
    floor = viewpoint_floor(s, "score").set_index("offset")
    assert floor.loc[2.0, "floor"] == pytest.approx(0.3) and (floor["method"] == "perfect").all()
    assert floor.loc[0.0, "axis"] == "none" and (floor["n"] == 10).all()
    views = floor_views(viewpoint_floor(s, "score"), -0.1, grid_of(s))
    assert np.allclose(views.set_index("offset").loc[[0.0, 1.0, -3.0], "threshold"], [0.89, 0.4, 0.1])
    h = _h(s, Threshold("score", -0.1, views=views))
    assert h.loc[("sharp", "left"), "horizon"] == 3.0 and h.loc[("blurry", "right"), "horizon"] == 0.0
    assert h["threshold_source"].str.startswith("given, over the viewpoint floor (median of method perfect").all()
    # real logs: method floor (two GT views) when there is no perfect render
    real = s.assign(method=s["method"].replace({"perfect": "floor"}))
    assert (viewpoint_floor(real, "score")["method"] == "floor").all()
    # a view without a floor: every view keeps the threshold, and the source names the view
    part = floor_views(viewpoint_floor(s[s["y_offset_m"] != 3.0], "score"), 0.4, grid_of(s))
    assert (part["threshold"] == 0.4).all() and "no viewpoint floor at y +3" in part["source"].iloc[0]


def test_analyze_pairs_uses_the_floor_and_records_the_source_per_row(tmp_path):
    s = scene()
    s["pair_id"] = [f"p{i}" for i in range(len(s))]
    s["camera"], s["timestamp_us"] = "front", 0
    s.drop(columns=["score"]).to_csv(tmp_path / "pairs.csv", index=False)
    s[["pair_id", "score"]].to_csv(tmp_path / "m.csv", index=False)
    base = ["--pairs", str(tmp_path / "pairs.csv"), "--metrics-table", str(tmp_path / "m.csv"),
            "--higher-better", "score", "--metric", "score", "--horizon", "--bootstrap", "0", "--quiet"]
    assert analyze_main([*base, "--threshold", "-0.1", "--out", str(tmp_path / "f")]) == 0
    doc = json.loads((tmp_path / "f" / "horizon.json").read_text())
    rows = pd.DataFrame(doc["horizons"]).set_index(["method", "direction"])
    assert (rows["threshold_kind"] == "floor").all() and rows.loc[("sharp", "left"), "horizon"] == 3.0
    assert len(doc["view_thresholds"]) == 7 and (tmp_path / "f" / "horizon_view_thresholds.csv").is_file()
    # --no-floor: the paper's protocol, one threshold on the metric itself
    assert analyze_main([*base, "--threshold", "0.4", "--no-floor", "--out", str(tmp_path / "n")]) == 0
    doc = json.loads((tmp_path / "n" / "horizon.json").read_text())
    rows = pd.DataFrame(doc["horizons"]).set_index(["method", "direction"])
    assert (rows["threshold_kind"] == "given").all() and rows.loc[("perfect", "left"), "horizon"] == 1.0
    assert (rows["threshold_source"] == "given (a fixed threshold)").all() and doc["view_thresholds"] == []
    # the floor run's per-view thresholds, given back as a table, judge the pairs the same way
    table = tmp_path / "f" / "horizon_view_thresholds.csv"
    assert analyze_main([*base, "--threshold-table", str(table), "--out", str(tmp_path / "t")]) == 0
    doc = json.loads((tmp_path / "t" / "horizon.json").read_text())
    given = pd.DataFrame(doc["horizons"]).set_index(["method", "direction"])
    floor = pd.read_csv(tmp_path / "f" / "horizon.csv").set_index(["method", "direction"])
    assert (given["threshold_kind"] == "given_view").all() and doc["threshold"]["value"] is None
    assert given["horizon"].equals(floor["horizon"])


def _votes(seed=0, n_items=400, raters=6):
    """Votes on items at 3 views whose metric falls with the view; people judge the render (q)."""
    rng = np.random.default_rng(seed)
    view = rng.integers(0, 3, n_items)
    q = rng.uniform(0, 1, n_items)  # the render's quality
    m = 0.9 - 0.3 * view - 0.2 * (1 - q) + rng.normal(0, 0.03, n_items)
    items = pd.DataFrame({"y_offset_m": view.astype(float)})
    r = np.repeat(np.arange(raters), n_items)
    i = np.tile(np.arange(n_items), raters)
    y = (rng.random(len(i)) < 1 / (1 + np.exp(-12 * (q[i] - 0.5)))).astype(float)
    return items.iloc[i].reset_index(drop=True).assign(x=m[i], vote=y, rater=r, track=i % 40)


@pytest.mark.parametrize("fit", ["monotone", "logistic"])
def test_people_views_give_each_view_its_threshold_and_an_interval_around_it(fit):
    votes = _votes()
    v = people_views("m", votes, good_prob=0.5, n_boot=100, seed=0, fit=fit).set_index("offset")
    assert list(v.index) == [0.0, 1.0, 2.0] and list(v["axis"]) == ["none", "y", "y"]
    # P(good) = 0.5 at q = 0.5: the metric 0.8, 0.5, 0.2 at the three views
    assert np.allclose(v["threshold"], [0.8, 0.5, 0.2], atol=0.02), v["threshold"]
    assert ((v["ci_lo"] <= v["threshold"]) & (v["threshold"] <= v["ci_hi"])).all()
    assert (v["reason"] == "").all() and (v["n_votes"] == np.bincount(votes["y_offset_m"].astype(int))).all()


@pytest.mark.parametrize("fit", ["monotone", "logistic"])
def test_a_view_whose_votes_are_one_outcome_gets_the_edge_of_the_rated_values(fit):
    votes = _votes(seed=1)
    votes.loc[votes["y_offset_m"] == 2.0, "vote"] = 1.0  # every vote at 2 m good
    v = people_views("m", votes, good_prob=0.5, n_boot=0, seed=0, fit=fit).set_index("offset")
    assert v.loc[2.0, "threshold"] == pytest.approx(votes["x"].min())
    assert v.loc[2.0, "reason"].startswith("every rated value at this view is judged good")
    # lower is better (the metric negated): every object at 2 m is good below the highest value
    low = people_views("m", votes.assign(x=-votes["x"]), good_prob=0.5, n_boot=0, seed=0, fit=fit,
                       increasing=False).set_index("offset")
    assert low.loc[2.0, "threshold"] == pytest.approx(-votes["x"].min())
    assert np.allclose(low["threshold"], -v["threshold"], atol=1e-9)


def test_an_impossible_threshold_is_clipped_to_the_rated_values():
    # a metric that says nothing about the votes (an entropy in [0.5, 3]): the fitted crossing lies
    # far outside what it can take, as -0.77 [-48, 54] did
    rng = np.random.default_rng(4)
    x = rng.uniform(0.5, 3.0, 600)
    y = (rng.random(600) < 0.8).astype(float)
    raw = float(logistic_threshold(*fit_logistic(x, y), 0.5)[0])
    assert not 0.5 <= raw <= 3.0  # unclipped, the threshold is impossible
    r = vote_threshold(x, y, np.arange(600) % 6, np.arange(600) % 30, n_boot=200, seed=0)
    lo, hi = x.min(), x.max()
    assert r["value"] in (lo, hi) and "clipped to" in r["reason"]
    assert np.isnan(r["ci_lo"]) or lo <= r["ci_lo"] <= r["value"] <= r["ci_hi"] <= hi


def _class_votes() -> pd.DataFrame:
    """At +1 m, cars turn good from 0.3 on and buses from 0.7 on (each rated value voted 3 times);
    at the recorded view every vote is good."""
    rows = []
    for cls, xs in (("automobile", (0.1, 0.2, 0.3, 0.4)), ("bus", (0.5, 0.6, 0.7, 0.8))):
        for i, x in enumerate(xs):
            for r in range(3):
                rows.append({"label_class": cls, "y_offset_m": 1.0, "x": x, "vote": float(i >= 2), "rater": r,
                             "track": i})
                rows.append({"label_class": cls, "y_offset_m": 0.0, "x": 0.9, "vote": 1.0, "rater": r, "track": i})
    return pd.DataFrame(rows)


def test_each_class_gets_its_own_threshold_where_it_has_the_votes():
    votes = _class_votes()
    per = people_views("score", votes, good_prob=0.5, n_boot=0, seed=0, by_class=True).set_index(
        ["label_class", "offset"])
    # every class together (pool-adjacent-violators by hand: 0, 0, .5, .5, .5, .5, 1, 1 over
    # 0.1..0.8): P(good) reaches 0.5 at 0.3, the midpoint with 0.2 is 0.25
    assert per.loc[("all", 1.0), "threshold"] == pytest.approx(0.25)
    # each class alone: cars between 0.2 and 0.3, buses between 0.6 and 0.7
    assert per.loc[("automobile", 1.0), "threshold"] == pytest.approx(0.25)
    assert per.loc[("bus", 1.0), "threshold"] == pytest.approx(0.65)
    assert per.loc[("bus", 1.0), "source"].startswith("people, per view for class bus:")
    # the recorded view: every vote good, no class row (it needs good and bad votes)
    assert ("bus", 0.0) not in per.index and ("all", 0.0) in per.index
    # fewer than MIN_CLASS_VOTES (10) votes at a view: no class row either
    few = people_views("score", votes[votes["rater"] < 2], good_prob=0.5, n_boot=0, seed=0, by_class=True)
    assert set(few["label_class"]) == {"all"}
    assert set(people_views("score", votes, good_prob=0.5, n_boot=0, seed=0)["label_class"]) == {"all"}

    # the horizon judges a bus at +1 m scoring 0.6 by the bus row (bad), a car at 0.3 by the
    # car row (good); without the class rows both are good
    s = pd.DataFrame({"clip_id": "c", "track_id": ["a", "a", "b", "b"], "label_class": ["automobile"] * 2 + ["bus"] * 2,
                      "y_offset_m": [0.0, 1.0] * 2, "score": [0.9, 0.3, 0.9, 0.6]})
    views = per.reset_index()
    h = trust_horizon(s, threshold=Threshold("score", np.nan, views=views), n_boot=0).set_index("label_class")
    assert h.loc["automobile", "horizon"] == 1.0 and h.loc["bus", "horizon"] == 0.0
    assert h.loc["bus", "threshold_source"].startswith("people, per view for class bus:")
    assert h.loc["automobile", "threshold_source"].startswith("people, per view for class automobile:")
    pooled = trust_horizon(s, threshold=Threshold("score", np.nan, views=views[views["label_class"] == "all"]),
                           n_boot=0).set_index("label_class")
    assert (pooled["horizon"] == 1.0).all()


def test_a_user_table_may_give_class_rows(tmp_path):
    grid = [("none", 0.0), ("y", 1.0)]
    path = tmp_path / "t.csv"
    pd.DataFrame({"offset": [0.0, 1.0, 1.0], "threshold": [0.1, 0.2, 0.5],
                  "label_class": ["", "", "bus"]}).to_csv(path, index=False)
    t = read_view_table(path, grid, metric="score")
    assert t["label_class"].tolist() == ["all", "all", "bus"]
    pd.DataFrame({"offset": [0.0, 1.0, 1.0], "threshold": [0.1, 0.5, 0.6],
                  "label_class": ["all", "bus", "bus"]}).to_csv(path, index=False)
    with pytest.raises(InputError, match="one threshold per view and class"):
        read_view_table(path, grid, metric="score")
    # class rows alone do not cover the grid: every view needs a row for every class
    pd.DataFrame({"offset": [0.0, 1.0], "threshold": [0.1, 0.5], "label_class": ["all", "bus"]}).to_csv(path, index=False)
    with pytest.raises(InputError, match="none for y \\+1"):
        read_view_table(path, grid, metric="score")
