"""Speed chart point labels: near-coincident variants of one encoder get labels that do not
overlap each other and stay inside the figure (issue 23 item 7)."""

from __future__ import annotations

import itertools

import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from analysis import plots


def _chart():
    # four runtime/precision variants of one encoder within 3% of speed and 0.002 of SRCC
    # (the demo report's case), a metric exactly on top of one of them, and two far points
    metric = ["nvrq:e", "nvrq:e@torch", "nvrq:e@int8", "nvrq:e@bf16", "nvrq_ca:e", "psnr", "ssim"]
    summary = pd.DataFrame({"metric": metric,
                            "srcc": [0.600, 0.601, 0.599, 0.600, 0.600, 0.31, 0.45]})
    timing = pd.DataFrame({"metric": metric,
                           "pairs_per_s": [95.0, 96.0, 97.5, 94.0, 95.0, 4000.0, 900.0],
                           "runtime": ["openvino", "torch", "openvino", "onnxruntime", "openvino",
                                       "", ""],
                           "precision": ["fp32", "fp32", "int8", "bf16", "fp32", "", ""]})
    return plots.speed_accuracy_plot(summary, timing), metric


@pytest.mark.parametrize("dpi", [100, 120])  # 120: the dpi save_figure writes the PNG at
def test_speed_chart_labels_do_not_overlap_and_stay_inside(dpi):
    fig, metric = _chart()
    fig.set_dpi(dpi)
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    labels = [t for t in ax.texts if t.get_text()]
    assert len(labels) == len(metric)
    boxes = [t.get_window_extent(renderer) for t in labels]
    for (i, a), (j, b) in itertools.combinations(enumerate(boxes), 2):
        assert not a.overlaps(b), (labels[i].get_text(), labels[j].get_text(), a, b)
    fig_box = fig.bbox
    for t, b in zip(labels, boxes, strict=True):
        assert fig_box.x0 <= b.x0 and b.x1 <= fig_box.x1, (t.get_text(), b, fig_box)
        assert fig_box.y0 <= b.y0 and b.y1 <= fig_box.y1, (t.get_text(), b, fig_box)


def test_labels_moved_away_from_their_point_get_a_leader_line():
    fig, _ = _chart()
    ax = fig.axes[0]
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    labels = [t.get_window_extent(renderer) for t in ax.texts if t.get_text()]
    lines = [t for t in ax.texts if not t.get_text()]
    # five labels around one spot cannot all sit beside their points: some are moved away and
    # joined to their point (one of the cluster's) by a line ending at the label's edge
    assert lines
    for ln in lines:
        assert 90 < ln.xy[0] < 100 and abs(ln.xy[1] - 0.6) < 0.002
        line_box = ln.arrow_patch.get_window_extent(renderer)
        assert any(b.expanded(1.0, 1.0).padded(2).overlaps(line_box) for b in labels)
