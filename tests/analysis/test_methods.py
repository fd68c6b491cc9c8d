"""The leaderboard of methods (analysis.methods, ``analyze --compare-methods``) on hand-built
pairs and metrics tables with a ``method`` column (tests/analysis/methods_data.py)."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.cli import main
from analysis.methods import compare_methods, holm
from analysis.stats import bootstrap as bs

sys.path.insert(0, str(Path(__file__).parent))
from methods_data import NVRQ_CA, make_method_tables  # noqa: E402

DIRECTIONS = {"psnr": True, NVRQ_CA: True}


def _items(pairs, metrics):
    items = pairs.merge(metrics, on="pair_id")
    clusters = pd.factorize(items["clip_id"] + ":" + items["track_id"])[0]
    return items, clusters


@pytest.fixture(scope="module")
def result():
    items, clusters = _items(*make_method_tables())
    return items, clusters, compare_methods(items, ["psnr", NVRQ_CA], DIRECTIONS, clusters=clusters,
                                            attributes=["lighting"], n_boot=400, seed=0)


def test_holm_against_the_step_down_definition():
    # Holm (1979) by hand for m = 4: sorted 0.001, 0.01, 0.02, 0.5 -> 4*0.001 = 0.004,
    # 3*0.01 = 0.03, max(0.03, 2*0.02) = 0.04, max(0.04, 1*0.5) = 0.5; NaN is not a comparison
    p = np.array([0.02, 0.5, np.nan, 0.001, 0.01])
    np.testing.assert_allclose(holm(p), [0.04, 0.5, np.nan, 0.004, 0.03])


def test_methods_table_against_pandas(result):
    items, _, res = result
    t = res.table
    views = t[(t["breakdown"] == "y_offset_m") & (t["metric"] == "psnr")]
    for (m, off), g in items.groupby(["method", "y_offset_m"]):
        row = views[(views["method"] == m) & (views["group"].astype(float) == off)].iloc[0]
        assert row["n"] == len(g)
        assert row["mean"] == pytest.approx(g["psnr"].mean())
        assert row["median"] == pytest.approx(g["psnr"].median())
        assert row["n_tracks"] == g[["clip_id", "track_id"]].drop_duplicates().shape[0]
    cls = t[(t["breakdown"] == "label_class") & (t["metric"] == NVRQ_CA)]
    want = items.groupby(["method", "label_class"])[NVRQ_CA].mean()
    for r in cls.itertuples():
        assert r.mean == pytest.approx(want[(r.method, r.group)])
    assert set(t["breakdown"]) == {"off-path", "on-path", "y_offset_m", "label_class", "lighting"}


def test_paired_interval_is_the_cluster_bootstrap_of_the_differences(result):
    """The paired interval at offset +1 equals a direct bootstrap: the same track draws
    (bootstrap.draw_cluster_counts, seed 0), each drawn track's differences duplicated."""
    items, clusters, res = result
    sel = items["y_offset_m"] == 1.0
    wide = items[sel].pivot_table(index=["clip_id", "track_id", "timestamp_us"], columns="method",
                                  values="psnr")
    d = (wide["sharp"] - wide["blurry"]).reset_index()
    track = pd.factorize(items["clip_id"] + ":" + items["track_id"])
    code = dict(zip(track[1], range(len(track[1])), strict=True))
    dc = np.array([code[f"{c}:{t}"] for c, t in zip(d["clip_id"], d["track_id"], strict=True)])
    # --bootstrap 400, raised for Holm over the paired rows (bootstrap.replicates_for)
    assert res.n_boot == bs.replicates_for(400, len(res.paired)) > 400
    counts = bs.draw_cluster_counts(len(track[1]), res.n_boot, seed=0)
    reps = np.array([np.repeat(d[0].to_numpy(), counts[b][dc]).mean() for b in range(res.n_boot)])
    lo, hi = np.quantile(reps, [0.025, 0.975])
    row = res.paired[(res.paired["metric"] == "psnr") & (res.paired["offset"] == 1.0)].iloc[0]
    assert (row["method_a"], row["method_b"]) == ("sharp", "blurry")
    assert row["mean_diff"] == pytest.approx(d[0].mean())
    assert (row["ci_lo"], row["ci_hi"]) == pytest.approx((lo, hi))
    assert row["win_rate"] == pytest.approx((d[0] > 0).mean())


def test_less_degraded_method_leads_and_offset_zero_is_a_tie(result):
    _, _, res = result
    assert res.methods == ["sharp", "blurry"] and res.rank_metric == NVRQ_CA
    board = res.leaderboard
    assert list(board["method"]) == ["sharp", "blurry"] and board["better_than_next"].iloc[0]
    p = res.paired
    for metric in ("psnr", NVRQ_CA):
        rows = p[(p["metric"] == metric) & (p["axis"] == "y_offset_m")]
        far = rows[rows["offset"].abs() >= 1]
        assert len(far) == 4 and (far["ci_lo"] > 0).all() and (far["better"] == "sharp").all()
        zero = rows[rows["offset"] == 0].iloc[0]
        # the methods differ at offset 0 by independent noise only: the interval includes 0
        assert zero["ci_lo"] < 0 < zero["ci_hi"] and zero["better"] == "neither"


def test_direction_aware_win_rate_for_a_lower_is_better_metric():
    pairs, metrics = make_method_tables()
    metrics = metrics.assign(lpips=-metrics["psnr"] / 100)  # the same ranking, lower is better
    items, clusters = _items(pairs, metrics)
    res = compare_methods(items, ["psnr", "lpips"], {"psnr": True, "lpips": False},
                          clusters=clusters, n_boot=100, rank_metric="lpips")
    p = res.paired.set_index(["metric", "axis", "offset"])
    ps, lp = p.loc[("psnr", "y_offset_m", 2.0)], p.loc[("lpips", "y_offset_m", 2.0)]
    assert lp["win_rate"] == ps["win_rate"] == 1.0 and lp["better"] == "sharp"
    assert lp["mean_diff"] < 0 < ps["mean_diff"]
    assert list(res.leaderboard["method"]) == ["sharp", "blurry"]


def test_an_object_seen_by_one_method_only_is_left_out_and_counted():
    pairs, metrics = make_method_tables()
    drop = (pairs["method"] == "blurry") & (pairs["track_id"] == "t0") & (pairs["y_offset_m"] == 2.0)
    items, clusters = _items(pairs[~drop], metrics)
    res = compare_methods(items, ["psnr"], {"psnr": True}, clusters=clusters, n_boot=50)
    row = res.paired[(res.paired["axis"] == "y_offset_m") & (res.paired["offset"] == 2.0)].iloc[0]
    assert row["n_only_a"] == int(drop.sum()) and row["n_only_b"] == 0
    assert row["n"] == (pairs["method"] == "sharp").sum() / 5 - drop.sum()
    assert any(f"{int(drop.sum())} objects of method 'sharp' have no row of method 'blurry'" in n
               for n in res.notes)


def _cli(tmp_path, pairs, metrics, *extra):
    pairs.to_csv(tmp_path / "pairs.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    return main(["--pairs", str(tmp_path / "pairs.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
                 "--compare-methods", "--bootstrap", "100", "--quiet", "--out", str(tmp_path / "rep"),
                 *extra])


def test_cli_writes_the_leaderboard(tmp_path, capsys):
    assert _cli(tmp_path, *make_method_tables()) == 0
    rep = tmp_path / "rep"
    for f in ("methods.csv", "methods_paired.csv", "methods_tent.png", "methods_by_class.png"):
        assert (rep / f).is_file(), f
    html = (rep / "report.html").read_text()
    assert "Leaderboard of methods by nvrq_ca:dinov2-small" in html
    assert "better than blurry" in html and "Metrics against" not in html
    paired = pd.read_csv(rep / "methods_paired.csv")
    assert list(paired.columns[:6]) == ["method_a", "method_b", "metric", "axis", "offset", "n"]
    assert "better than blurry" in capsys.readouterr().out


@pytest.mark.parametrize("case, message", [
    ("one method", "pairs.csv: column 'method': expected at least two methods to compare"),
    ("missing from metrics", "metrics.csv: column 'psnr': expected values for the pairs of every "
                             "compared method (pair ids ending ':blurry' of"),
    ("unknown --methods", "--methods: nerf: expected a method of"),
    ("unknown --leaderboard-metric", "--leaderboard-metric: lpips: expected a metric column"),
    ("no method column", "pairs.csv: column 'method': expected a method per row"),
])
def test_bad_input_is_one_line_exit_2_and_no_output(tmp_path, capsys, case, message):
    pairs, metrics = make_method_tables()
    extra = []
    if case == "one method":
        pairs = pairs[pairs["method"] == "sharp"]
    elif case == "missing from metrics":
        metrics = metrics[~metrics["pair_id"].str.endswith(":blurry")]
    elif case == "unknown --methods":
        extra = ["--methods", "sharp,nerf"]
    elif case == "unknown --leaderboard-metric":
        extra = ["--leaderboard-metric", "lpips"]
    else:
        pairs = pairs.drop(columns="method")
    assert _cli(tmp_path, pairs, metrics, *extra) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "rep").exists()


def test_ratings_path_ranks_methods_by_gvf_too(tmp_path, capsys):
    """Binary ratings of a multi-method study (object columns + method): GVF joins the metrics."""
    pairs, metrics = make_method_tables(n_tracks=3)
    rng = np.random.default_rng(1)
    votes = []
    for r in range(4):
        scale = pairs["method"].map({"sharp": 0.5, "blurry": 1.5})
        p_good = np.exp(-scale * pairs["y_offset_m"].abs())
        votes.append(pairs.assign(item_id=pairs["pair_id"], rater_id=f"sim-{r}", kind="test",
                                  vote=(rng.random(len(pairs)) < p_good).astype(int),
                                  voted_at="2026-01-01T00:00:00Z", response_ms=900.0))
    ratings = pd.concat(votes).drop(columns="pair_id")
    ratings.to_csv(tmp_path / "ratings.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    rc = main([str(tmp_path / "ratings.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
               "--compare-methods", "--leaderboard-metric", "gvf", "--bootstrap", "100", "--quiet",
               "--out", str(tmp_path / "rep")])
    assert rc == 0, capsys.readouterr().err
    t = pd.read_csv(tmp_path / "rep" / "methods.csv")
    assert {"gvf", "psnr", NVRQ_CA} == set(t["metric"])
    html = (tmp_path / "rep" / "report.html").read_text()
    assert "Leaderboard of methods by gvf" in html and "Metrics against GVF" in html


def test_six_dof_views_get_one_breakdown_per_axis():
    """Views along yaw: methods.csv and methods_paired.csv break down by the yaw column, with
    the real camera's view (all components 0) as value 0 of both axes (docs/FORMATS.md §9)."""
    pairs, metrics = make_method_tables(n_tracks=3)
    yaw = pairs[pairs["y_offset_m"] > 0].assign(
        yaw_deg=lambda d: d["y_offset_m"] * 5, y_offset_m=0.0,
        pair_id=lambda d: d["pair_id"].str.replace(r":\+(\d)\.00:", r":yaw=+\g<1>.00:", regex=True))
    ymet = metrics.set_index("pair_id").loc[pairs.loc[pairs["y_offset_m"] > 0, "pair_id"]]
    ymet = ymet.assign(psnr=ymet["psnr"] - 1).set_index(yaw["pair_id"]).reset_index()
    allp = pd.concat([pairs.assign(yaw_deg=0.0), yaw], ignore_index=True)
    items, clusters = _items(allp, pd.concat([metrics, ymet], ignore_index=True))
    res = compare_methods(items, ["psnr"], {"psnr": True}, clusters=clusters, n_boot=50)
    t = res.table[res.table["metric"] == "psnr"]
    assert set(t["breakdown"]) == {"off-path", "on-path", "y_offset_m", "yaw_deg", "label_class"}
    assert sorted(t.loc[t["breakdown"] == "yaw_deg", "group"].astype(float).unique()) == [0, 5, 10]
    yaw_rows = res.paired[res.paired["axis"] == "yaw_deg"]
    assert sorted(yaw_rows["offset"]) == [0.0, 5.0, 10.0]
    zero = items[(items["y_offset_m"] == 0) & (items["yaw_deg"] == 0) & (items["method"] == "sharp")]
    assert yaw_rows.loc[yaw_rows["offset"] == 0, "n"].iloc[0] == len(zero)


@pytest.mark.parametrize("chunk", [7, 10**12])  # a few replicates per product, or all at once
def test_the_bootstrap_chunk_size_bounds_memory_only(result, monkeypatch, chunk):
    # analysis.stats.bootstrap.CHUNK_CELLS is the one chunk size; the replicate means do not depend
    # on it (each replicate is its own weighted mean)
    from analysis.methods import _replicate_means

    items, clusters, _ = result
    v = items["psnr"].to_numpy(np.float64)
    ok = np.isfinite(v)
    groups = pd.factorize(items["method"])[0]
    counts = bs.draw_cluster_counts(int(clusters.max()) + 1, 50, seed=1)
    reference = _replicate_means(v, ok, groups, groups.max() + 1, clusters, counts)
    monkeypatch.setattr(bs, "CHUNK_CELLS", chunk)
    chunked = _replicate_means(v, ok, groups, groups.max() + 1, clusters, counts)
    for a, b in zip(reference, chunked, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12)
    # and the replicate means by their definition: weighted by how often each track was drawn
    w = counts[:, clusters].astype(np.float64)
    g0 = ok & (groups == 0)
    np.testing.assert_allclose(chunked[3][:, 0], (w[:, g0] * v[g0]).sum(1) / w[:, g0].sum(1), rtol=1e-12)


def test_the_pairs_analysis_is_built_with_its_margin_and_leaderboard(tmp_path):
    # the library computes the leaderboard itself (the CLI no longer sets it afterwards): the
    # same tables as compare_methods called directly on the analysis' items and metrics
    from analysis.all_pairs import run_pairs_analysis
    from data_schema.errors import InputError

    pairs, metrics = make_method_tables()
    pairs.to_csv(tmp_path / "pairs.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    kw = dict(metrics_paths=[tmp_path / "metrics.csv"], n_boot=100, progress=False)
    a = run_pairs_analysis(tmp_path / "pairs.csv", compare_methods=True, margin=0.05, **kw)
    assert a.margin == 0.05 and set(a.attributes) - {"method"} == {"lighting"}
    clusters = pd.factorize(a.items["clip_id"].astype(str) + ":" + a.items["track_id"].astype(str))[0]
    want = compare_methods(a.items, a.metrics, a.directions, clusters=clusters, attributes=["lighting"],
                           n_boot=100, seed=0)
    assert a.methods.methods == want.methods and a.methods.rank_metric == want.rank_metric
    for name in ("table", "paired", "leaderboard"):
        pd.testing.assert_frame_equal(getattr(a.methods, name), getattr(want, name))
    assert run_pairs_analysis(tmp_path / "pairs.csv", target="psnr", **kw).methods is None
    with pytest.raises(InputError, match="^margin: expected a non-negative number"):
        run_pairs_analysis(tmp_path / "pairs.csv", compare_methods=True, margin=-0.1, **kw)
