"""The viewpoint floor in the reports (analysis.common.viewpoint_floor): the rule that draws a log's floor,
the floor-against-perfect check, and the dashed floor line of the tents and off-path figures."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.cli import main as analyze
from analysis.common.viewpoint_floor import (
    FLOOR_COLOUR,
    MEASURED_GAPS,
    floor_check,
    floor_verdict,
    items_floor_verdict,
)
from analysis.report.methods_report import methods_tent_plot
from analysis.report.off_path import off_path_display, off_path_figure

sys.path.insert(0, str(Path(__file__).parents[1]))
from methods_data import NVRQ_CA, make_method_tables  # noqa: E402


@pytest.mark.parametrize("gaps, covered, draw, words", [
    ({-1.0: -0.05, 1.0: 0.1}, [-1.0, 1.0], True, "within 0.100 at every offset it covers (-1 m, +1 m)"),
    ({-1.0: -0.05, 1.0: 0.1001}, [-1.0, 1.0], False, "at +1 m its median NVRQ-CA is 0.100 above"),
    ({-1.0: -0.2, 1.0: 0.0}, [1.0], True, "(+1 m)"),  # -1 m is not covered: not judged
    ({-1.0: -0.2, 1.0: 0.0}, [-1.0, 1.0], False, "at -1 m its median NVRQ-CA is 0.200 below"),
    ({1.0: 0.0}, [1.0, 2.0], False, "not checked against a perfect render at +2 m"),
    ({1.0: np.nan}, [1.0], False, "not checked against a perfect render at +1 m"),
    ({1.0: 0.0}, [], False, "covers no offset"),
])
def test_the_rule_draws_the_floor_only_within_the_tolerance_at_every_covered_offset(gaps, covered, draw, words):
    v = floor_verdict(gaps, covered)
    assert v.draw is draw and words in v.sentence, v.sentence
    assert v.sentence.endswith(".") and v.sentence.count(". ") == 0  # one sentence


def _items(rng, n=40):
    """Floor and perfect rows of the same views, a perfect view without a floor, and a yaw view."""
    rows = []
    for k in range(n):
        for off in (-1.0, 1.0):
            obj = {"clip_id": "c", "camera": "f", "track_id": f"t{k % 7}", "timestamp_us": k, "y_offset_m": off,
                   "yaw_deg": 0.0}
            p = rng.uniform(0.2, 0.6)
            rows.append({**obj, "method": "perfect", "m": p})
            if k % 4:  # a floor row for three views in four
                rows.append({**obj, "method": "floor", "m": p + rng.normal(0.05 * off, 0.02)})
            rows.append({**obj, "method": "sharp", "m": p - 0.1})
        rows.append({"clip_id": "c", "camera": "f", "track_id": "t0", "timestamp_us": k, "y_offset_m": 0.0,
                     "yaw_deg": 5.0, "method": "floor", "m": 9.0})  # not a lateral view: never judged
    return pd.DataFrame(rows)


def test_floor_check_against_numpy_medians():
    items = _items(np.random.default_rng(0))
    check = floor_check(items, "m").set_index("offset")
    assert list(check.index) == [-1.0, 1.0]
    for off in (-1.0, 1.0):
        lat = items[(items["y_offset_m"] == off) & (items["yaw_deg"] == 0)]
        fl = lat[lat["method"] == "floor"].set_index("timestamp_us")["m"]
        pf = lat[lat["method"] == "perfect"].set_index("timestamp_us")["m"]
        assert check.loc[off, "n"] == len(fl)
        assert check.loc[off, "floor"] == pytest.approx(np.median(fl.to_numpy()))
        assert check.loc[off, "perfect"] == pytest.approx(np.median(pf.loc[fl.index].to_numpy()))
        assert check.loc[off, "perfect_all"] == pytest.approx(np.median(pf.to_numpy()))
        assert check.loc[off, "gap"] == pytest.approx(check.loc[off, "floor"] - check.loc[off, "perfect"])
    # the floor sits 0.05 above/below the perfect render: about -0.05 at -1 m, +0.05 at +1 m
    assert check.loc[-1.0, "gap"] == pytest.approx(-0.05, abs=0.02)
    assert check.loc[1.0, "gap"] == pytest.approx(0.05, abs=0.02)


def test_a_log_without_a_perfect_render_is_judged_on_the_measured_clip():
    items = _items(np.random.default_rng(1)).rename(columns={"m": NVRQ_CA})
    own = items_floor_verdict(items, ["psnr", NVRQ_CA])
    assert own.draw and own.sentence.endswith("on this clip.")
    log = items[items["method"] != "perfect"]
    v = items_floor_verdict(log, [NVRQ_CA])  # the lateral floor rows cover -1 m and +1 m
    assert v == floor_verdict(MEASURED_GAPS, [-1.0, 1.0], source="on the synthetic check clip (docs/FORMATS.md §3)")
    assert items_floor_verdict(items[items["method"] != "floor"], [NVRQ_CA]) is None


def _with_reference(method: str, gap: float):
    """The hand-built leaderboard tables with a reference method: the best method's scores moved
    by ``gap`` (a floor that stays ``gap`` from it)."""
    pairs, metrics = make_method_tables(n_tracks=6)
    ref = pairs[pairs["method"] == "sharp"].copy()
    ref["method"] = method
    ref["pair_id"] = ref["pair_id"].str.replace(":sharp", f":{method}")
    m = metrics[metrics["pair_id"].str.endswith(":sharp")].copy()
    m["pair_id"] = m["pair_id"].str.replace(":sharp", f":{method}")
    m[NVRQ_CA] += gap
    return pd.concat([pairs, ref], ignore_index=True), pd.concat([metrics, m], ignore_index=True)


def test_tents_draw_the_perfect_render_as_the_floor(tmp_path):
    pairs, metrics = _with_reference("perfect", 0.05)
    p, m = tmp_path / "pairs.csv", tmp_path / "metrics.csv"
    pairs.to_csv(p, index=False)
    metrics.to_csv(m, index=False)
    assert analyze(["--pairs", str(p), "--metrics-table", str(m), "--compare-methods", "--bootstrap", "50",
                    "--quiet", "--out", str(tmp_path / "rep")]) == 0
    table = pd.read_csv(tmp_path / "rep" / "methods.csv")
    methods = ["perfect", "sharp", "blurry"]
    fig = methods_tent_plot(table, [NVRQ_CA], {NVRQ_CA: True}, methods)
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    floor = next(ln for label, ln in lines.items() if label.startswith("viewpoint floor (perfect render) (n="))
    sharp = next(ln for label, ln in lines.items() if label.startswith("sharp (n="))
    assert floor.get_linestyle() == "--" and floor.get_color() == FLOOR_COLOUR
    assert sharp.get_linestyle() == "-"
    assert len(ax.collections) == 2  # a band for sharp and blurry, none for the floor
    # the floor's line is perfect's mean per offset, as in methods.csv
    rows = table[(table["breakdown"] == "y_offset_m") & (table["metric"] == NVRQ_CA) & (table["method"] == "perfect")]
    want = rows.assign(x=rows["group"].astype(float)).sort_values("x")["mean"].to_numpy()
    assert np.allclose(floor.get_ydata(), want)
    html = (tmp_path / "rep" / "report.html").read_text()
    assert "viewpoint floor (perfect render)" in html


def test_off_path_table_and_figure_list_the_floor():
    from types import SimpleNamespace

    table = pd.DataFrame({"method": ["a", "perfect", "floor"], "metric": ["psnr"] * 3,
                          "breakdown": ["y_offset_m"] * 3, "group": ["+1.00"] * 3, "n": [10, 10, 8],
                          "n_tracks": [5, 5, 4], "mean": [20.0, 22.0, 21.0], "ci_lo": [19.0] * 3, "ci_hi": [21.0] * 3})
    res = SimpleNamespace(table=table, metrics=["psnr"], directions={"psnr": True}, sets=None)
    shown = off_path_display(res)
    assert sorted(shown["method"]) == ["a", "viewpoint floor (perfect render)", "viewpoint floor (two GT views)"]
    fig = off_path_figure(res)
    styles = {ln.get_label().split(" (")[0]: ln.get_linestyle() for ln in fig.axes[0].get_lines()}
    assert styles == {"a": "-", "viewpoint floor": "--"}


def test_a_log_floor_that_misses_the_perfect_render_is_left_out_and_said(tmp_path, capsys):
    # floor and perfect: the floor 0.3 above the perfect render is left out, and the report says so
    pairs, metrics = _with_reference("perfect", 0.0)
    fp, fm = _with_reference("floor", 0.3)
    pairs = pd.concat([pairs, fp[fp["method"] == "floor"]], ignore_index=True)
    metrics = pd.concat([metrics, fm[fm["pair_id"].str.endswith(":floor")]], ignore_index=True)
    p, m = tmp_path / "pairs.csv", tmp_path / "metrics.csv"
    pairs.to_csv(p, index=False)
    metrics.to_csv(m, index=False)
    assert analyze(["--pairs", str(p), "--metrics-table", str(m), "--compare-methods", "--bootstrap", "50",
                    "--quiet", "--out", str(tmp_path / "rep")]) == 0
    table = pd.read_csv(tmp_path / "rep" / "methods.csv")
    assert "floor" not in set(table["method"]) and "perfect" in set(table["method"])
    html = (tmp_path / "rep" / "report.html").read_text()
    assert "The viewpoint floor (two GT views) is left out: at -2 m its median NVRQ-CA is 0.300 above" in html


def test_the_pairs_path_leaves_the_floor_out_of_the_pooled_statistics(tmp_path):
    pairs, metrics = make_method_tables(methods={"sharp": 0.5}, n_tracks=6)
    metrics["sev"] = -metrics["psnr"]  # a per-pair target
    fp, fm = _with_reference("floor", 0.0)
    floor = fp[fp["method"] == "floor"]
    fm = fm[fm["pair_id"].str.endswith(":floor")].assign(sev=np.nan)
    p, m = tmp_path / "pairs.csv", tmp_path / "metrics.csv"
    pd.concat([pairs, floor], ignore_index=True).to_csv(p, index=False)
    pd.concat([metrics, fm], ignore_index=True).to_csv(m, index=False)
    assert analyze(["--pairs", str(p), "--metrics-table", str(m), "--target", "sev", "--bootstrap", "20",
                    "--quiet", "--out", str(tmp_path / "rep")]) == 0
    summary = pd.read_csv(tmp_path / "rep" / "summary.csv")
    assert (summary.loc[summary["metric"] == "psnr", "n"] == len(pairs)).all()
    md = (tmp_path / "rep" / "report.md").read_text()
    assert f"{len(floor)} pairs of the viewpoint floor (method floor, two GT views) left out" in md


def test_floor_by_offset_is_the_perfect_renders_mean_per_offset():
    from analysis.common.viewpoint_floor import floor_by_offset
    from data_schema.errors import InputError

    pairs, metrics = _with_reference("perfect", 0.0)
    f = floor_by_offset(pairs, metrics).set_index(["y_offset_m", "column"])
    perfect = pairs[pairs["method"] == "perfect"].merge(metrics, on="pair_id")
    want = perfect.groupby("y_offset_m")[[NVRQ_CA, "psnr"]].mean()
    for off in want.index:
        assert f.loc[(off, NVRQ_CA), "mean"] == pytest.approx(want.loc[off, NVRQ_CA])
        assert f.loc[(off, "psnr"), "mean"] == pytest.approx(want.loc[off, "psnr"])
        assert f.loc[(off, "psnr"), "n"] == (perfect["y_offset_m"] == off).sum()
    with pytest.raises(InputError, match="pairs of method perfect"):
        floor_by_offset(pairs[pairs["method"] != "perfect"], metrics, where="p.csv")


def test_the_ratings_tent_draws_the_floor_in_each_metric_panel():
    from analysis.common.plots import tent_plot

    by_offset = pd.DataFrame({"y_offset_m": [-1.0, 0.0, 1.0] * 3, "column": ["gvf"] * 3 + ["psnr"] * 3 + ["ssim"] * 3,
                              "n": 10, "mean": [0.2, 0.9, 0.3, 12, 30, 13, 0.4, 0.9, 0.5], "std": 0.1})
    floor = pd.DataFrame({"y_offset_m": [-1.0, 0.0, 1.0], "column": "psnr", "n": 10, "mean": [14.0, 45.0, 15.0]})
    fig = tent_plot(by_offset, ["gvf", "psnr", "ssim"], {"psnr": True, "ssim": True}, floor=floor)
    dashed = [[ln for ln in ax.get_lines() if ln.get_linestyle() == "--"] for ax in fig.axes]
    assert [len(d) for d in dashed] == [0, 1, 0]  # GVF: none; psnr: the floor; ssim: no floor values
    assert dashed[1][0].get_ydata().tolist() == [14.0, 45.0, 15.0]
    assert dashed[1][0].get_color() == FLOOR_COLOUR


@pytest.mark.parametrize("given, other", [("--floor-pairs", "--floor-metrics"), ("--floor-metrics", "--floor-pairs")])
def test_floor_options_go_together(tmp_path, capsys, given, other):
    pairs, metrics = make_method_tables(n_tracks=3)
    p, m = tmp_path / "pairs.csv", tmp_path / "metrics.csv"
    pairs.to_csv(p, index=False)
    metrics.to_csv(m, index=False)
    assert analyze(["--pairs", str(p), "--metrics-table", str(m), "--compare-methods", given, str(p),
                    "--quiet", "--out", str(tmp_path / "rep")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {given}: expected {other} with it"), err
    assert not (tmp_path / "rep").exists()


def test_a_log_floor_in_the_tent_follows_the_rule():
    from analysis.common.viewpoint_floor import tent_floor

    pairs, metrics = _with_reference("perfect", 0.0)
    table, sentence = tent_floor(pairs, metrics)
    assert table is not None and sentence == ""  # a perfect render: always drawn
    fp, fm = _with_reference("floor", 0.0)
    log = fp[fp["y_offset_m"].isin([-1.0, 1.0])]  # covers what the check clip measured
    table, sentence = tent_floor(log, fm)
    want = floor_verdict(MEASURED_GAPS, [-1.0, 1.0], source="on the synthetic check clip (docs/FORMATS.md §3)")
    assert sentence == want.sentence and (table is not None) == want.draw
    table, sentence = tent_floor(fp[fp["y_offset_m"].isin([1.0, 2.0])], fm)  # +2 m was never checked
    assert table is None and "not checked against a perfect render at +2 m" in sentence
