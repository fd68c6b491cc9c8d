"""Demo-like reports built in seconds from synthetic tables: the three pages ``nvrq demo`` and
``nvrq demo --methods`` end with (the binary study's report with its ROC curves, wide tables
and trust horizon; the method leaderboard with NTA-IoU; the pairwise study with
Bradley-Terry and JOD), for the figure and browser tests.

Every figure the reports draw is recorded (:func:`recording_figures`), so a test checks the
figures as they are drawn, not a hand-picked list of functions.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.cli import main
from analysis.common import plots
from tests.analysis.methods_data import make_method_tables, make_pairwise_votes
from tests.analysis.synth import make_ratings

__all__ = ["binary_report", "leaderboard_report", "pairwise_report", "demo_reports", "recording_figures"]

#: Metric names as long as the demo's (the breakdown tables grow as wide as the demo's).
LONG_NAMES = [f"nvrq_ca:very-long-encoder-name-{i}" for i in range(6)]


def binary_report(d: Path) -> Path:
    """``analyze RATINGS --horizon``: synthetic binary votes with many metric columns, a
    straight-lining rater excluded by screening (a long reason in its row); its report.html."""
    d.mkdir(parents=True, exist_ok=True)
    ratings, metrics = make_ratings(n_tracks=5)
    rng = np.random.default_rng(1)
    for c in LONG_NAMES:
        metrics[c] = metrics["nvrq:dinov2-small"] + rng.normal(0, 0.1, len(metrics))
    ratings = ratings.drop(columns="blurriness", errors="ignore")
    liar = ratings[ratings["rater_id"] == "sim-0"].assign(rater_id="sim-careless", vote=1, response_ms=50)
    pd.concat([ratings, liar]).to_csv(d / "ratings.csv", index=False)
    metrics.to_csv(d / "metrics.csv", index=False)
    out = d / "report"
    assert main([str(d / "ratings.csv"), "--metrics-table", str(d / "metrics.csv"), "--higher-better",
                 ",".join(LONG_NAMES), "--bootstrap", "50", "--horizon", "--metric", LONG_NAMES[0],
                 "--out", str(out), "--quiet"]) == 0
    return out / "report.html"


def leaderboard_report(d: Path) -> Path:
    """``analyze --pairs --compare-methods --by class,offset --nta``: two methods; report.html."""
    d.mkdir(parents=True, exist_ok=True)
    pairs, metrics = make_method_tables()
    pairs.to_csv(d / "pairs.csv", index=False)
    metrics.to_csv(d / "metrics.csv", index=False)
    rng = np.random.default_rng(2)
    iou = np.clip(0.9 - 0.1 * pairs["y_offset_m"].abs() * pairs["method"].map({"sharp": 0.5, "blurry": 1.5})
                  + rng.normal(0, 0.05, len(pairs)), 0, 1)
    pd.DataFrame({"pair_id": pairs["pair_id"], "iou": iou, "protocol": "simulated"}).to_csv(d / "nta.csv", index=False)
    out = d / "leaderboard"
    assert main(["--pairs", str(d / "pairs.csv"), "--metrics-table", str(d / "metrics.csv"), "--compare-methods",
                 "--by", "class,offset", "--nta", str(d / "nta.csv"), "--bootstrap", "50", "--out", str(out),
                 "--quiet"]) == 0
    return out / "report.html"


def pairwise_report(d: Path) -> Path:
    """``analyze VOTES``: pairwise votes of five simulated raters between two methods; report.html."""
    d.mkdir(parents=True, exist_ok=True)
    pairs, metrics = make_method_tables()
    make_pairwise_votes(pairs, n_raters=5).to_csv(d / "votes.csv", index=False)
    metrics.to_csv(d / "metrics.csv", index=False)
    out = d / "pairwise"
    assert main([str(d / "votes.csv"), "--metrics-table", str(d / "metrics.csv"), "--bootstrap", "50",
                 "--out", str(out), "--quiet"]) == 0
    return out / "report.html"


def demo_reports(d: Path) -> dict[str, Path]:
    """The three reports in ``d``: ``{'report', 'leaderboard', 'pairwise'}`` to report.html."""
    return {"report": binary_report(d / "binary"), "leaderboard": leaderboard_report(d / "methods"),
            "pairwise": pairwise_report(d / "methods")}


@contextlib.contextmanager
def recording_figures(monkeypatch):
    """Within the block, every figure a report saves (:func:`analysis.common.plots.save_figure`) is
    appended, with its file name, to the yielded list (saved as before)."""
    seen: list[tuple[str, object]] = []
    save = plots.save_figure

    def record(fig, directory, name):
        seen.append((name, fig))
        return save(fig, directory, name)

    monkeypatch.setattr(plots, "save_figure", record)
    yield seen
