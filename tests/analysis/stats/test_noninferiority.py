"""Non-inferiority recommendation: decisions both ways on hand-made bootstrap distributions."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.stats.noninferiority import recommend, recommend_from_tables, upper_bound

# hand-made paired replicates: best's SRCC is 0.62 in every replicate, so
# SRCC(best) - SRCC(x) = 0.62 - reps[x]; the one-sided 95% bound is that difference's 95th
# percentile (numpy's linear interpolation over 21 values k/20: the 0.95 quantile is the
# 20th value exactly).
B = np.full(21, 0.62)
CLOSE = 0.62 - np.linspace(0.0, 0.019, 21)   # differences 0 .. 0.019: bound 0.01805 < 0.02
WIDE = 0.62 - np.linspace(-0.05, 0.30, 21)   # includes 0 ("n.s.") but bound 0.2825 > 0.02


def test_upper_bound_is_the_95th_percentile_of_the_paired_difference():
    assert upper_bound(B, CLOSE) == pytest.approx(0.019 * 19 / 20, abs=1e-12)
    assert upper_bound(B, WIDE) == pytest.approx(-0.05 + 0.35 * 19 / 20, abs=1e-12)


def test_faster_noninferior_metric_is_recommended():
    r = recommend({"nvrq": 0.62, "psnr": 0.61}, {"nvrq": 10.0, "psnr": 500.0},
                  {"nvrq": B, "psnr": CLOSE}, margin=0.02)
    assert (r.metric, r.best) == ("psnr", "nvrq") and r.bound < 0.02
    assert "Recommended: psnr" in r.sentence()


def test_not_significant_is_not_enough():
    # psnr's interval includes 0 (not significantly worse) but its bound exceeds the margin
    r = recommend({"nvrq": 0.62, "psnr": 0.48}, {"nvrq": 10.0, "psnr": 500.0},
                  {"nvrq": B, "psnr": WIDE}, margin=0.02)
    assert r.metric == "nvrq" and r.checked[0][0] == "psnr" and r.checked[0][1] > 0.02
    assert "No faster metric is non-inferior" in r.sentence()
    # and with a generous margin the same distribution passes
    assert recommend({"nvrq": 0.62, "psnr": 0.48}, {"nvrq": 10.0, "psnr": 500.0},
                     {"nvrq": B, "psnr": WIDE}, margin=0.3).metric == "psnr"


def test_fastest_passing_candidate_wins_and_ties_go_to_the_faster_best():
    srcc = {"nvrq:e": 0.62, "nvrq_ca:e": 0.62, "ssim": 0.60, "psnr": 0.40}
    speed = {"nvrq:e": 10.0, "nvrq_ca:e": 12.0, "ssim": 100.0, "psnr": 900.0}
    reps = {"nvrq:e": B, "nvrq_ca:e": B, "ssim": CLOSE, "psnr": WIDE}
    r = recommend(srcc, speed, reps)
    assert r.best == "nvrq_ca:e"  # tie in SRCC: the faster one is the best
    assert r.metric == "ssim" and [m for m, _ in r.checked] == ["psnr", "ssim"]


def test_from_tables_reads_replicates_from_summary_attrs():
    summary = pd.DataFrame({"metric": ["nvrq:e", "psnr"], "srcc": [0.62, 0.61]})
    summary.attrs["srcc_replicates"] = {"nvrq:e": B, "psnr": CLOSE}
    timing = pd.DataFrame({"metric": ["nvrq:e", "psnr"], "pairs_per_s": [10.0, 500.0]})
    assert recommend_from_tables(summary, timing).metric == "psnr"
    assert recommend_from_tables(summary, None) is None
