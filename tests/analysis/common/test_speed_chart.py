"""Speed axis: runtime variants as their own points, readable log ticks, old timing files."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg

from analysis.common import plots
from analysis.pipeline import read_timing


def _timing(tmp_path, rows, name="m.timing.csv"):
    pd.DataFrame(rows).to_csv(tmp_path / name, index=False)
    return tmp_path / name


def test_old_and_new_timing_files_are_read_together(tmp_path):
    old = _timing(tmp_path, {"metric": ["psnr"], "seconds": [2.0], "pairs": [100]}, "old.timing.csv")
    new = _timing(tmp_path, {"metric": ["nvrq:e", "nvrq:e@torch"], "seconds": [1.0, 10.0], "pairs": [100, 100],
                             "runtime": ["openvino", "torch"], "precision": ["fp32", "fp32"],
                             "threads": [2, 2], "device": ["cpu", "cpu"]})
    t = read_timing([old, new]).set_index("metric")
    assert t.loc["psnr", "pairs_per_s"] == 50.0 and pd.isna(t.loc["psnr", "runtime"])
    assert t.loc["nvrq:e@torch", "runtime"] == "torch" and t.loc["nvrq:e", "pairs_per_s"] == 100.0


def _visible_tick_boxes(fig, axis):
    FigureCanvasAgg(fig).draw()
    r = fig.canvas.get_renderer()
    lo, hi = axis.get_view_interval()
    boxes = []
    for tick in axis.get_major_ticks() + axis.get_minor_ticks():
        label = tick.label1
        if label.get_visible() and label.get_text() and lo <= tick.get_loc() <= hi:
            boxes.append(label.get_window_extent(r))
    return boxes


def test_variants_are_separate_points_and_tick_labels_do_not_overlap():
    # less than one decade of speed: matplotlib labelled every minor tick here, overlapping
    summary = pd.DataFrame({"metric": ["nvrq:e", "nvrq:e@torch", "nvrq:e@int8", "ssim"],
                            "srcc": [0.60, 0.60, 0.58, 0.40]})
    timing = pd.DataFrame({"metric": summary["metric"], "pairs_per_s": [95.0, 23.0, 180.0, 140.0],
                           "runtime": ["openvino", "torch", "openvino", ""],
                           "precision": ["fp32", "fp32", "int8", ""]})
    fig = plots.speed_accuracy_plot(summary, timing)
    ax = fig.axes[0]
    texts = [t.get_text() for t in ax.texts]
    assert {"nvrq:e [openvino fp32]", "nvrq:e@torch [torch fp32]", "nvrq:e@int8 [openvino int8]",
            "ssim"} <= set(texts)
    assert len(ax.collections[0].get_offsets()) == 4  # one point per variant
    boxes = _visible_tick_boxes(fig, ax.xaxis)
    assert len(boxes) >= 2  # some speed is labelled
    boxes.sort(key=lambda b: b.x0)
    assert all(a.x1 < b.x0 for a, b in zip(boxes, boxes[1:], strict=False)), [(b.x0, b.x1) for b in boxes]


def test_wide_speed_range_labels_powers_of_ten_only():
    summary = pd.DataFrame({"metric": ["a", "b"], "srcc": [0.5, 0.4]})
    timing = pd.DataFrame({"metric": ["a", "b"], "pairs_per_s": [2.0, 5000.0]})
    fig = plots.speed_accuracy_plot(summary, timing)
    FigureCanvasAgg(fig).draw()
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels() if t.get_text()]
    vals = [float(v) for v in labels]
    assert vals and all(np.isclose(np.log10(v), round(np.log10(v))) for v in vals)
