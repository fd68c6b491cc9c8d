"""Figures: panel count of the tent plot, Pareto front, optional plots."""

import numpy as np
import pandas as pd

from analysis import plots
from analysis.breakdowns import offset_table


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
