"""Issue 38 item 19: the stability figure's log axis is labelled at more than 1.0, and its
legends sit beside the panels, covering no data."""

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg

from nvrq.stability import stability_figure


def test_snr_axis_labels_and_legends_outside_the_data():
    metrics, names = ["psnr", "ssim", "nvrq:e"], ["brightness", "jpeg", "box_jitter"]
    # SNR inside one decade (0.6-4): the old locator labelled 1 alone
    snr = pd.DataFrame([{"metric": m, "nuisance": n, "snr": 0.6 + 0.4 * (i + 3 * k)}
                        for k, m in enumerate(metrics) for i, n in enumerate(names)])
    stab = pd.DataFrame([{"metric": m, "nuisance_or_artefact": a, "kind": kind, "strength": s,
                          "mean_abs_change": s * (k + 1) / 10}
                         for k, m in enumerate(metrics)
                         for a, kind in (("box_jitter", "nuisance"), ("blur", "artefact"))
                         for s in (0.25, 0.5, 0.75, 1.0)])
    fig = stability_figure(stab, snr)
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    ax1, ax2 = fig.axes
    lo, hi = ax1.get_ylim()
    shown = [t.get_text() for t in ax1.get_yticklabels() if t.get_text()
             and lo <= t.get_position()[1] <= hi]
    assert {"1", "2"} <= set(shown), shown  # the old axis showed "1" alone
    for ax in (ax1, ax2):
        leg = ax.get_legend().get_window_extent(renderer)
        area = ax.get_window_extent(renderer)
        assert leg.x0 >= area.x1 - 1, "legend inside the panel"  # beside it: covers no data
        assert fig.bbox.x1 >= leg.x1, "legend cut off"
    assert np.isfinite(snr["snr"]).all()
