"""Issue 29 part A: a leaderboard a reviewer would accept (docs/FORMATS.md §11).

Intervals and p-values only where a group has enough tracks; an exact sign-flip test over
tracks (checked by hand and against SciPy); on-path and off-path in place of "all"; crossed
breakdowns (class x offset); figures whose colours, labels and names agree. Inputs are the
hand-built tables of tests/analysis/methods_data.py (2 clips x 5 tracks: 6 automobile and 4
pedestrian tracks)."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_hex
from scipy.stats import permutation_test

from analysis.cli import main
from analysis.common.plots import method_colours
from analysis.methods import MIN_CLUSTERS, PAIRED_COLUMNS, TABLE_COLUMNS, compare_methods
from analysis.pairwise import run_pairwise_analysis
from analysis.report import methods_report as mr
from analysis.report.pairwise_report import bt_display, win_prob_plot
from analysis.stats.signflip import draw_signs, sign_flip_p

sys.path.insert(0, str(Path(__file__).parent))
from methods_data import NVRQ_CA, make_method_tables, make_pairwise_votes  # noqa: E402

DIRECTIONS = {"psnr": True, NVRQ_CA: True}
ROOT = Path(__file__).resolve().parents[2]


def _items(pairs, metrics):
    items = pairs.merge(metrics, on="pair_id")
    clusters = pd.factorize(items["clip_id"] + ":" + items["track_id"])[0]
    return items, clusters


def _compare(pairs=None, metrics=None, **kw):
    if pairs is None:
        pairs, metrics = make_method_tables()
    items, clusters = _items(pairs, metrics)
    kw = {"n_boot": 200, "seed": 0, **kw}
    return items, compare_methods(items, ["psnr", NVRQ_CA], DIRECTIONS, clusters=clusters,
                                  attributes=["lighting"], **kw)


@pytest.fixture(scope="module")
def crossed():
    return _compare(by=["class", "offset"])


# --- 1. intervals only where they mean something -------------------------------------------

def test_two_tracks_give_no_interval_and_no_p_value():
    # issue 29: 2 tracks gave sharp a "95% interval" [0.9072, 0.9074], the two track means
    pairs, metrics = make_method_tables(n_clips=1, n_tracks=2)
    _, res = _compare(pairs, metrics)
    for t in (res.table, res.paired):
        assert t["ci_lo"].isna().all() and t["ci_hi"].isna().all()
        # one track per class (automobile t0, pedestrian t1), two in every other group
        want = np.where(t["n_tracks"] == 1, "1 track", "2 tracks")
        assert (t["reason"] == pd.Series(want, index=t.index) + ", fewer than the 5 an interval or "
                "p-value needs").all()
    assert res.paired["p"].isna().all() and res.paired["p_holm"].isna().all()
    assert res.paired["better"].isna().all()  # no test, no verdict
    assert (res.leaderboard["n_tracks"] == 2).all() and res.leaderboard["ci_lo"].isna().all()
    assert "undefined" in mr.leaderboard_display(res)["vs next"].iloc[0]


def test_a_class_with_two_tracks_gets_no_interval_and_says_why(tmp_path, capsys):
    pairs, metrics = make_method_tables()
    # pedestrians: 2 tracks of clip 0 (t1, t3); every other track is an automobile
    ped = (pairs["clip_id"] == "clip0") & pairs["track_id"].isin(["t1", "t3"])
    pairs = pairs.assign(label_class=np.where(ped, "pedestrian", "automobile"))
    pairs.to_csv(tmp_path / "pairs.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    rc = main(["--pairs", str(tmp_path / "pairs.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
               "--compare-methods", "--by", "class,offset", "--bootstrap", "100", "--quiet",
               "--out", str(tmp_path / "rep")])
    assert rc == 0, capsys.readouterr().err
    t = pd.read_csv(tmp_path / "rep" / "methods.csv")
    cls = t[t["breakdown"] == "label_class"].set_index(["method", "metric", "group"])
    ped_rows = cls.xs("pedestrian", level="group")
    assert ped_rows["ci_lo"].isna().all() and (ped_rows["n_tracks"] == 2).all()
    assert ped_rows["reason"].str.startswith("2 tracks, fewer than the 5").all()
    car = cls.xs("automobile", level="group")
    assert (car["n_tracks"] == 8).all() and car["ci_lo"].notna().all() and car["reason"].isna().all()
    p = pd.read_csv(tmp_path / "rep" / "methods_paired.csv")
    cells = p[p["by"] == "label_class,view"]
    assert set(cells["group"]) == {"automobile", "pedestrian"}
    pc = cells[cells["group"] == "pedestrian"]
    assert pc["p"].isna().all() and pc["ci_lo"].isna().all()
    assert pc["reason"].str.startswith("2 tracks").all()
    assert cells.loc[cells["group"] == "automobile", "p"].notna().all()


def test_n_tracks_stands_beside_n_in_every_table_and_figure(crossed):
    items, res = crossed
    tracks = items.groupby("y_offset_m").apply(lambda g: g[["clip_id", "track_id"]].drop_duplicates().shape[0])
    rows = res.paired[(res.paired["axis"] == "y_offset_m") & (res.paired["by"] == "")]
    for r in rows.itertuples():
        assert r.n_tracks == tracks[r.offset]
    assert PAIRED_COLUMNS.index("n_tracks") == PAIRED_COLUMNS.index("n") + 1
    assert TABLE_COLUMNS.index("n_tracks") == TABLE_COLUMNS.index("n") + 1
    assert list(res.leaderboard["n_tracks"]) == [10, 10]
    assert mr.leaderboard_display(res)["n (tracks)"].tolist() == ["80 (10)", "80 (10)"]
    # off-path (4 offsets x 20 objects), on-path and the 5 offsets of 20 objects, 10 tracks each
    assert mr.paired_display(res)["n (tracks)"].tolist() == ["80 (10)"] + ["20 (10)"] * 6
    for name, _, fig in mr.method_figures(res):
        texts = [t.get_text() for ax in fig.axes for t in ax.texts]
        legend = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().texts]
        assert any("tracks" in s or " tr." in s for s in texts + legend), name


def test_min_clusters_is_an_option_checked_with_the_rest(tmp_path, capsys):
    pairs, metrics = make_method_tables()
    _, res = _compare(pairs, metrics, min_clusters=11)  # 10 tracks in all: no interval anywhere
    assert res.paired["p"].isna().all() and res.table["ci_lo"].isna().all()
    assert res.table["reason"].str.contains("fewer than the 11").all()
    pairs.to_csv(tmp_path / "pairs.csv", index=False)
    metrics.to_csv(tmp_path / "metrics.csv", index=False)
    base = ["--pairs", str(tmp_path / "pairs.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
            "--quiet", "--out", str(tmp_path / "rep")]
    for extra, message in ((["--compare-methods", "--min-clusters", "1"], "--min-clusters"),
                           (["--min-clusters", "3", "--target", "psnr"],
                            "--min-clusters: expected --compare-methods as well"),
                           (["--compare-methods", "--by", "class,weather"], "--by: weather: expected class, offset")):
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err
        assert not (tmp_path / "rep").exists()
    assert MIN_CLUSTERS == 5


# --- 2. p-values that say what they are ------------------------------------------------------

def test_sign_flip_p_by_hand():
    # 3 tracks, sums 1, 2, 3: T = 6; the 8 patterns give +-6, +-4, +-2, 0, 0 -> |T*| >= 6 twice
    p, floor, exact = sign_flip_p(np.array([[1.0, 2.0, 3.0]]), signs=None)
    assert p[0] == 0.25 and floor[0] == 0.25 and exact[0]
    # sums 3, -1, 2: T = 4; patterns 4, 0, 6, 2 and their negatives -> |T*| >= 4 four times
    assert sign_flip_p(np.array([[3.0, -1.0, 2.0]]), signs=None)[0][0] == 0.5
    # NaN: a track without objects in the row does not count; no track at all: undefined
    p, floor, _ = sign_flip_p(np.array([[1.0, np.nan, 3.0], [np.nan] * 3]), signs=None)
    assert p[0] == 0.5 and floor[0] == 0.5 and np.isnan(p[1])


@pytest.mark.parametrize("n", [2, 5, 9, 16])
def test_exact_sign_flip_p_equals_scipy_permutation_test(n):
    rng = np.random.default_rng(n)
    x = rng.normal(0.4, 1.0, n)
    want = permutation_test((x,), lambda v, axis=-1: v.sum(axis=axis), permutation_type="samples",
                            n_resamples=np.inf, alternative="two-sided").pvalue
    p, floor, exact = sign_flip_p(x[None], signs=None)
    assert p[0] == pytest.approx(want, rel=1e-12) and exact[0] and floor[0] == 2 / 2 ** n


def test_monte_carlo_sign_flip_beyond_16_tracks():
    # 18 tracks: SciPy enumerates all 2^18 patterns; the Monte Carlo p (add-one rule) lies
    # within 4 standard errors of it
    rng = np.random.default_rng(3)
    x = rng.normal(0.3, 1.0, 18)
    want = permutation_test((x,), lambda v, axis=-1: v.sum(axis=axis), permutation_type="samples",
                            n_resamples=np.inf, alternative="two-sided").pvalue
    b = 20_000
    p, floor, exact = sign_flip_p(x[None], signs=draw_signs(18, b, seed=0))
    assert not exact[0] and floor[0] == 1 / (b + 1)
    assert abs(p[0] - want) < 4 * np.sqrt(want * (1 - want) / b)
    # all of 30 tracks far above 0: no pattern reaches T, the add-one floor 1 / (B + 1)
    p, floor, _ = sign_flip_p(np.full((1, 30), 5.0) + np.arange(30), signs=draw_signs(30, 999, seed=0))
    assert p[0] == floor[0] == 1 / 1000


def test_monte_carlo_patterns_in_chunks_bound_memory_only(monkeypatch):
    import analysis.stats.signflip as sf

    x = np.random.default_rng(4).normal(0.2, 1.0, (3, 20))
    signs = draw_signs(20, 500, seed=0)
    whole = sign_flip_p(x, signs=signs)[0]
    monkeypatch.setattr(sf, "CHUNK_CELLS", 7)  # one pattern per product
    np.testing.assert_array_equal(sign_flip_p(x, signs=signs)[0], whole)


def test_paired_p_is_the_sign_flip_test_of_the_track_sums(crossed):
    items, res = crossed
    # independently: per track, the sum of sharp - blurry PSNR at offset +1 (pandas), and
    # SciPy's exact sign-flip test of those 10 sums
    sel = items[items["y_offset_m"] == 1.0]
    wide = sel.pivot_table(index=["clip_id", "track_id", "timestamp_us"], columns="method", values="psnr")
    sums = (wide["sharp"] - wide["blurry"]).groupby(level=["clip_id", "track_id"]).sum().to_numpy()
    want = permutation_test((sums,), lambda v, axis=-1: v.sum(axis=axis), permutation_type="samples",
                            n_resamples=np.inf).pvalue
    row = res.paired[(res.paired["metric"] == "psnr") & (res.paired["axis"] == "y_offset_m")
                     & (res.paired["offset"] == 1.0) & (res.paired["by"] == "")].iloc[0]
    assert row["p"] == pytest.approx(want) and row["p_test"] == "exact"
    assert row["p_floor"] == 2 / 2 ** 10 and row["n_tracks"] == 10
    # Holm within the default rows: 14 of them (2 metrics x (off, on, 5 offsets))
    default = res.paired[res.paired["by"] == ""]
    assert len(default) == 14 and row["p_holm"] == pytest.approx(min(1, 14 * row["p"]))


def test_p_values_at_the_floor_say_so(crossed):
    _, res = crossed
    # a Monte Carlo p at 1/(B+1) is a bound: "<" raw, "<=" after Holm; an exact p is exact
    assert mr.p_text(1 / 2561, 1 / 2561, "monte-carlo") == "p < 0.00039"
    assert mr.p_text(14 / 2561, 1 / 2561, "monte-carlo", raw=1 / 2561) == "p \u2264 0.0055"
    assert mr.p_text(2 / 1024, 2 / 1024, "exact") == "p = 0.002 (the smallest possible)"
    vs = mr.leaderboard_display(res)["vs next"].iloc[0]
    # Holm 14 x 2/1024 = 0.0273; the floor 2/2^10 of 10 tracks is stated beside it
    assert vs == "better than blurry (p = 0.027, Holm; smallest possible p 0.002)", vs
    assert "sign-flip test over tracks" in mr.leaderboard_text(res)


# --- 3. on the recorded path and off it -------------------------------------------------------

def test_off_path_and_on_path_replace_all_and_the_leaderboard_ranks_off_path():
    pairs, metrics = make_method_tables()
    # on the recorded view blurry is far better in both metrics; off it, sharp is
    zero = metrics["pair_id"].str.contains(":+0.00:", regex=False) & metrics["pair_id"].str.endswith(":blurry")
    metrics = metrics.assign(psnr=metrics["psnr"] + 40 * zero, **{NVRQ_CA: metrics[NVRQ_CA] + 0.9 * zero})
    items, res = _compare(pairs, metrics)
    assert set(res.paired["axis"]) == {"off-path", "on-path", "y_offset_m"}
    assert set(res.table["breakdown"]) >= {"off-path", "on-path"} and "all" not in set(res.table["breakdown"])
    wide = items.pivot_table(index=["clip_id", "track_id", "timestamp_us", "y_offset_m"], columns="method",
                             values="psnr").reset_index()
    d = wide["sharp"] - wide["blurry"]
    rows = res.paired[res.paired["metric"] == "psnr"].set_index("axis")
    assert rows.loc["off-path", "mean_diff"] == pytest.approx(d[wide["y_offset_m"] != 0].mean())
    assert rows.loc["on-path", "mean_diff"] == pytest.approx(d[wide["y_offset_m"] == 0].mean())
    assert rows.loc["off-path", "better"] == "sharp" and rows.loc["on-path", "better"] == "blurry"
    assert res.rank_view == "off-path" and res.methods == ["sharp", "blurry"]
    assert (res.leaderboard["view"] == "off-path").all()
    _, on = _compare(pairs, metrics, rank_view="on-path")
    assert on.methods == ["blurry", "sharp"] and on.leaderboard["better_than_next"].iloc[0]


def test_only_the_recorded_view_ranks_on_path_with_a_note():
    pairs, metrics = make_method_tables()
    keep = pairs["y_offset_m"] == 0
    _, res = _compare(pairs[keep], metrics[metrics["pair_id"].isin(pairs.loc[keep, "pair_id"])])
    assert res.rank_view == "on-path" and (res.leaderboard["view"] == "on-path").all()
    assert "no off-path objects: the leaderboard ranks the on-path view" in res.notes
    assert set(res.paired["axis"]) == {"on-path", "y_offset_m"}


def test_formats_and_code_agree_on_the_leaderboard_tables():
    # docs/FORMATS.md §11 lists the columns of methods.csv and methods_paired.csv in order,
    # and says what offset 0 (on-path) reports
    text = (ROOT / "docs" / "FORMATS.md").read_text()
    sec = text[text.index("## 11."):text.index("## 12.")]
    for name, cols in (("methods.csv", TABLE_COLUMNS), ("methods_paired.csv", PAIRED_COLUMNS)):
        head = f"- `{name}`: `"
        listed = sec[sec.index(head) + len(head):]
        listed = listed[:listed.index("`")].replace("\n", " ")
        assert [c.strip() for c in listed.split(",")] == cols, name
    assert "never a win" not in sec and "on-path" in sec and "off-path" in sec


# --- 4. crossed breakdowns ---------------------------------------------------------------------

def test_by_class_and_offset_gives_paired_rows_per_cell(crossed):
    items, res = crossed
    cells = res.paired[(res.paired["by"] == "label_class,view") & (res.paired["metric"] == NVRQ_CA)]
    wide = items.pivot_table(index=["clip_id", "track_id", "timestamp_us", "y_offset_m", "label_class"],
                             columns="method", values=NVRQ_CA).reset_index()
    want = (wide["sharp"] - wide["blurry"]).groupby([wide["label_class"], wide["y_offset_m"]]).mean()
    assert len(cells) == len(want) == 10
    for r in cells.itertuples():
        assert r.axis == "y_offset_m" and r.mean_diff == pytest.approx(want[(r.group, r.offset)])
    # pedestrians have 4 tracks: no test; automobiles 6: exact test, floor 2/2^6
    assert cells.loc[cells["group"] == "pedestrian", "p"].isna().all()
    assert (cells.loc[cells["group"] == "automobile", "p_floor"] == 2 / 64).all()
    # its own Holm family: 2 metrics x 2 classes x 5 offsets = 20 rows, 10 with a p-value
    fam = res.paired[res.paired["by"] == "label_class,view"]
    auto = fam[fam["p"].notna()]
    assert len(fam) == 20 and len(auto) == 10
    assert auto["p_holm"].to_numpy() == pytest.approx(np.minimum(1, 10 * auto["p"].to_numpy()))
    table = mr.class_offset_display(res)
    assert list(table.columns) == ["a - b", "class", "y = -2 m", "y = -1 m", "y = 0 m", "y = +1 m", "y = +2 m"]
    car = table.set_index("class").loc["automobile"]
    assert car["y = +2 m"].startswith("+0.16") and car["y = +2 m"].endswith("(-)")  # 6 tracks: 0.03125 x 10
    assert table.set_index("class").loc["pedestrian", "y = +1 m"].endswith("(4 tracks)")
    names = [n for n, _, _ in mr.method_figures(res)]
    assert "methods_class_offset" in names


def test_by_a_clip_attribute_splits_on_and_off_path():
    _, res = _compare(by=["lighting"])
    rows = res.paired[res.paired["by"] == "lighting"]
    assert set(zip(rows["group"], rows["axis"], strict=True)) == {
        ("day", "off-path"), ("day", "on-path"), ("night", "off-path"), ("night", "on-path")}
    assert (rows["n_tracks"] == 5).all() and rows["p"].notna().all()


# --- 8. figures and names that agree ----------------------------------------------------------

def _inside(fig) -> list[str]:
    """The axes (with their titles, labels, drawn tick labels, cell labels and legends; a
    colour bar is an axes) whose drawn extent leaves the figure, by their label."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    r = canvas.get_renderer()
    box = fig.bbox
    out = []
    for ax in fig.axes:
        e = ax.get_tightbbox(r)
        if e.x0 < box.x0 - 1 or e.x1 > box.x1 + 1 or e.y0 < box.y0 - 1 or e.y1 > box.y1 + 1:
            out.append(ax.get_title() or ax.get_ylabel() or ax.get_label())
    return out


@pytest.fixture(scope="module")
def pairwise(tmp_path_factory):
    pairs, metrics = make_method_tables()
    d = tmp_path_factory.mktemp("pw")
    make_pairwise_votes(pairs, n_raters=3).to_csv(d / "votes.csv", index=False)
    return run_pairwise_analysis(d / "votes.csv", n_boot=50)


def test_one_colour_per_method_in_every_figure(crossed, pairwise):
    _, res = crossed
    want = method_colours(["sharp", "blurry"])
    assert want == {"blurry": "C0", "sharp": "C1"}
    tent = [f for n, _, f in mr.method_figures(res) if n == "methods_tent"][0]
    for ax in tent.axes:
        for line in ax.get_lines():
            m = line.get_label().split(" (")[0]
            assert to_hex(line.get_color()) == to_hex(want[m]), m
    bt = win_prob_plot(pairwise.bradley_terry, pairwise.methods)
    lines = [ln for ax in bt.axes for ln in ax.get_lines() if ln.get_label().startswith("P(")]
    assert lines and all(to_hex(ln.get_color()) == to_hex(want["sharp"]) for ln in lines)


def test_no_label_leaves_its_figure(crossed, pairwise):
    _, res = crossed
    figs = [(n, f) for n, _, f in mr.method_figures(res)]
    figs.append(("bt_win_prob", win_prob_plot(pairwise.bradley_terry, pairwise.methods)))
    for name, fig in figs:
        assert _inside(fig) == [], name


def test_y_axes_name_the_metric_and_its_direction(crossed):
    pairs, metrics = make_method_tables()
    metrics = metrics.assign(lpips=-metrics["psnr"] / 100)
    items, clusters = _items(pairs, metrics)
    res = compare_methods(items, ["psnr", "lpips"], {"psnr": True, "lpips": False}, clusters=clusters,
                          n_boot=50)
    tent = mr.methods_tent_plot(res.table, res.metrics, res.directions, res.methods)
    assert [ax.get_ylabel() for ax in tent.axes] == ["psnr (higher is better \u2191)",
                                                     "lpips (lower is better \u2193)"]
    heat = mr.method_class_heatmap(res.table, "lpips", res.methods, higher_better=False)
    assert heat.axes[-1].get_ylabel() == "mean lpips\n(lower is better \u2193)"


def test_better_names_the_method_and_offsets_read_one_way(crossed, pairwise):
    _, res = crossed
    assert set(res.paired["better"].dropna()) <= {"sharp", "blurry", "neither"}
    assert "sharp better" in set(mr.paired_display(res)["result"])
    assert sorted(res.table.loc[res.table["breakdown"] == "y_offset_m", "group"].unique()) == \
        ["+1", "+2", "-1", "-2", "0"]
    assert set(mr.paired_display(res)["view"]) == {"off-path", "on-path", "y = -2 m", "y = -1 m",
                                                   "y = 0 m", "y = +1 m", "y = +2 m"}
    heat = [f for n, _, f in mr.method_figures(res) if n == "methods_class_offset"][0]
    assert [t.get_text() for t in heat.axes[0].get_xticklabels()] == ["-2", "-1", "0", "+1", "+2"]
    assert list(bt_display(pairwise.bradley_terry, "y_offset_m")["view"].unique()) == ["-2", "-1", "0", "+1", "+2"]


def test_two_methods_get_one_bradley_terry_line(pairwise):
    fig = win_prob_plot(pairwise.bradley_terry, pairwise.methods)
    ax = fig.axes[0]
    lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]
    assert [ln.get_label() for ln in lines] == ["P(sharp beats blurry)"]
    assert ax.get_ylabel() == "P(sharp beats blurry)"
    bt = pairwise.bradley_terry
    s = bt[(bt["axis"] == "y_offset_m") & (bt["method"] == "sharp")].sort_values("offset")
    np.testing.assert_allclose(lines[0].get_ydata(), s["win_prob"].to_numpy(float))
