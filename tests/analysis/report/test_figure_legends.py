"""Every figure of the demo-like reports, checked as drawn: its legends and texts lie inside
the figure's image (the PNG cuts off anything outside the figure's box), a legend inside an
axes covers none of its lines' points, and the ROC plot is square with its legend below it."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.lines import Line2D

#: a box may overshoot the figure's edge by this many pixels (antialiasing of the frame)
EDGE_PX = 1.0


@pytest.fixture(scope="module")
def figures(demo_report_pages):
    return demo_report_pages[2]


def _drawn(fig):
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def _inside(box, outer, tol=EDGE_PX) -> bool:
    return (box.x0 >= outer.x0 - tol and box.y0 >= outer.y0 - tol and box.x1 <= outer.x1 + tol
            and box.y1 <= outer.y1 + tol)


def test_the_reports_draw_the_demo_figures(figures):
    # the figures the demo's three pages show (an independent list: the report templates' sections)
    for name in ("roc", "tent", "agreement", "target_hist", "horizon_all", "horizon_timeline", "methods_tent",
                 "methods_by_class", "off_path", "bt_win_prob", "agreement_2afc"):
        assert name in figures, sorted(figures)


def test_every_legend_and_text_lies_inside_its_figure(figures):
    for name, fig in figures.items():
        renderer = _drawn(fig)
        legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
        for legend in legends:
            box = legend.get_window_extent(renderer)
            assert _inside(box, fig.bbox), f"{name}: legend {box.bounds} outside the figure {fig.bbox.bounds}"
        tight = fig.get_tightbbox(renderer)  # inches: every artist drawn
        w, h = fig.get_size_inches()
        assert tight.x0 >= -0.01 and tight.y0 >= -0.01 and tight.x1 <= w + 0.01 and tight.y1 <= h + 0.01, \
            f"{name}: drawn area {tight.bounds} beyond the figure ({w} x {h} in)"


def test_a_legend_inside_an_axes_covers_none_of_its_points(figures):
    for name, fig in figures.items():
        renderer = _drawn(fig)
        for ax in fig.axes:
            legend = ax.get_legend()
            if legend is None:
                continue
            box = legend.get_window_extent(renderer)
            for line in ax.get_lines():
                if not isinstance(line, Line2D) or line.get_marker() in (None, "None", "", " "):
                    continue  # a plain line (a reference line) may run behind a legend
                xy = ax.transData.transform(np.column_stack(line.get_data()).astype(float))
                xy = xy[np.isfinite(xy).all(axis=1)]
                inside = ((xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1))
                assert not inside.any(), f"{name}: the legend covers {int(inside.sum())} points of {line.get_label()}"


def test_the_roc_plot_is_square_with_its_legend_outside_the_axes(figures):
    fig = figures["roc"]
    renderer = _drawn(fig)
    (ax,) = fig.axes
    box = ax.get_window_extent(renderer)
    assert box.width == pytest.approx(box.height, rel=0.01)  # fixed aspect: a square plot
    assert ax.get_xlim() == (0, 1) and ax.get_ylim() == (0, 1)
    (legend,) = fig.legends
    lb = legend.get_window_extent(renderer)
    assert lb.y1 <= box.y0 and _inside(lb, fig.bbox)  # below the axes, inside the image
    assert len(legend.get_texts()) == min(3, len(ax.get_lines()) - 1)  # the curves, not the diagonal
