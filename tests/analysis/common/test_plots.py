"""Figures: panel count of the tent plot, Pareto front, optional plots."""

import numpy as np
import pandas as pd

from analysis.common import plots
from analysis.tables.breakdowns import offset_table


def test_tent_plot_has_one_panel_per_metric_plus_gvf(tmp_path):
    rng = np.random.default_rng(0)
    items = pd.DataFrame({"y_offset_m": np.repeat([-1.0, 0.0, 1.0], 10), "gvf": rng.random(30)})
    names = ["a", "b", "c", "d", "e"]
    for m in names:
        items[m] = rng.random(30)
    t = offset_table(items, ["gvf"] + names)
    fig = plots.tent_plot(t, ["gvf"] + names, {m: m != "b" for m in names})
    assert len(fig.axes) == 1 + len(names)
    assert fig.axes[0].get_title() == "GVF"
    assert fig.axes[2].yaxis_inverted() and not fig.axes[1].yaxis_inverted()  # b: lower is better
    png = plots.save_figure(fig, tmp_path, "tent")
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and (tmp_path / "tent.svg").is_file()


def test_pareto_front_hand_worked():
    # (speed, acc): (1, .9) (10, .8) (100, .5) (5, .7) (50, .4): (5,.7) and (50,.4) are dominated
    sp = np.array([1.0, 10.0, 100.0, 5.0, 50.0])
    acc = np.array([0.9, 0.8, 0.5, 0.7, 0.4])
    assert sorted(plots.pareto_front(sp, acc).tolist()) == [0, 1, 2]


def test_speed_plot_without_matching_timings_is_none():
    s = pd.DataFrame({"metric": ["a"], "srcc": [0.5]})
    tm = pd.DataFrame({"metric": ["b"], "pairs_per_s": [3.0]})
    assert plots.speed_accuracy_plot(s, tm) is None


def test_gvf_band_stays_in_0_1_and_ticks_sit_on_the_data():
    """Issue 38 item 19: GVF 0.9 +/- 0.3 used to draw a band up to 1.2; yaw views at
    multiples of 5 got ticks at +-7.5 from matplotlib's locator."""
    t = pd.DataFrame({"y_offset_m": [-10.0, -5.0, 0.0, 5.0, 10.0], "column": "gvf",
                      "mean": [0.2, 0.6, 0.9, 0.6, 0.05], "std": 0.3})
    fig = plots.tent_plot(t, ["gvf"], {})
    ax = fig.axes[0]
    band = ax.collections[0].get_paths()[0].vertices[:, 1]
    assert band.min() >= 0.0 and band.max() <= 1.0
    assert ax.get_xticks().tolist() == [-10.0, -5.0, 0.0, 5.0, 10.0]
    fig.canvas.draw()
    assert [x.get_text() for x in ax.get_xticklabels()] == ["-10", "-5", "0", "+5", "+10"]


def test_roc_plot_says_when_curves_are_identical():
    """Three metrics, two of them a monotone transform of each other (the same ranking, so the
    same ROC curve: sklearn's roc_curve is rank-based): one line, its legend naming both."""
    rng = np.random.default_rng(0)
    a = rng.random(60)
    items = pd.DataFrame({"a": a, "a_log": np.log(a), "b": rng.random(60)})
    summary = pd.DataFrame({"metric": ["a", "a_log", "b"], "higher_better": True,
                            "roc_auc": [0.7, 0.7, 0.5]})
    fig = plots.roc_plot(items, summary, a + rng.normal(0, 0.2, 60) > 0.5)
    (legend,) = fig.legends  # below the axes (tests/analysis/report/test_figure_legends.py)
    texts = [t.get_text().replace("\n", " ") for t in legend.get_texts()]
    assert len(texts) == 2 and "identical curves" in texts[0] and "a_log" in texts[0]


def test_a_stalled_legend_placement_neither_fails_nor_moves_the_legend(tmp_path, monkeypatch):
    """matplotlib warns when a loc="best" legend took over a second of wall clock (a stalled
    process on a loaded machine): save_figure writes the same PNG as without the stall, and the
    warning does not escape (the suite turns warnings into errors)."""
    import itertools

    import matplotlib.legend
    from matplotlib.figure import Figure

    def figure():
        fig = Figure(figsize=(3, 2))
        ax = fig.subplots()
        ax.plot([0, 1, 2], [2, 1, 0], label="a")
        ax.fill_between([0, 1, 2], [1.5, 0.5, 0], [2, 1.5, 1], alpha=0.2)
        ax.legend()
        return fig

    calm = plots.save_figure(figure(), tmp_path, "calm")
    clock = itertools.count(step=2.0)  # every reading two seconds after the last
    monkeypatch.setattr(matplotlib.legend.time, "perf_counter", lambda: next(clock))
    stalled = plots.save_figure(figure(), tmp_path, "stalled")
    assert stalled == calm
    assert (tmp_path / "stalled.svg").is_file()
