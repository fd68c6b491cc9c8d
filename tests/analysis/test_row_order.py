"""Row order never changes results (docs/FORMATS.md §6, issue 23 item 4): a shuffled ratings
file, or shuffled pairs and metric tables, give byte-identical report tables, bootstrap
intervals included; the report's header states the rule."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.cli import main
from analysis.tables.inputs import read_ratings
from tests.analysis.synth import make_ratings
from tests.analysis.test_all_pairs import _pairs

TABLES = ("summary.csv", "items.csv", "by_offset.csv", "categories.csv", "raters.csv", "encoders.csv")


def _same_report(a, b, tables=TABLES):
    for name in tables:
        if (a / name).exists() or (b / name).exists():
            assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert (a / "report.md").read_text() == (b / "report.md").read_text()


def test_shuffled_ratings_give_byte_identical_tables(tmp_path):
    ratings, metrics = make_ratings(n_clips=3, n_tracks=4, n_frames=2, n_raters=5, seed=4)
    a, b = tmp_path / "a", tmp_path / "b"  # the same file names: the report's title is the name
    a.mkdir()
    b.mkdir()
    ratings.to_csv(a / "ratings.csv", index=False)
    ratings.sample(frac=1.0, random_state=1).to_csv(b / "ratings.csv", index=False)
    metrics.to_csv(a / "metrics.csv", index=False)
    metrics.iloc[::-1].to_csv(b / "metrics.csv", index=False)
    for d in (a, b):
        assert main([str(d / "ratings.csv"), "--metrics-table", str(d / "metrics.csv"), "--out",
                     str(d / "report"), "--lower-better", "blurriness", "--bootstrap", "200",
                     "--quiet"]) == 0
    s = pd.read_csv(a / "report" / "summary.csv")
    assert s["srcc_ci_lo"].notna().all()  # the bootstrap ran: its intervals are compared too
    _same_report(a / "report", b / "report")
    assert "Row order: results use the canonical order" in (a / "report" / "report.html").read_text()


def test_votes_are_read_in_canonical_order(tmp_path):
    ratings, _ = make_ratings(n_clips=2, n_tracks=2, n_frames=1, n_raters=3, seed=0)
    ratings.sample(frac=1.0, random_state=2).to_csv(tmp_path / "r.csv", index=False)
    votes = read_ratings(tmp_path / "r.csv")
    keys = list(zip(votes["item_id"], votes["rater_id"], votes["kind"], strict=True))
    assert keys == sorted(keys) and len(set(keys)) == len(keys)  # Python's str order = codepoints


def test_shuffled_pairs_give_byte_identical_tables(tmp_path):
    full = _pairs(np.random.default_rng(7), n_clips=3, per_clip=40)
    pairs_cols = [c for c in full.columns if c not in ("clip_drop", "psnr", "ssim")]
    metric_cols = ["pair_id", "psnr", "ssim", "clip_drop"]
    shuffled = full.sample(frac=1.0, random_state=5)
    a, b = tmp_path / "a", tmp_path / "b"
    for d, pairs, metrics in ((a, full, full), (b, shuffled, shuffled.sample(frac=1.0, random_state=6))):
        d.mkdir()
        pairs[pairs_cols].to_csv(d / "pairs.csv", index=False)
        metrics[metric_cols].to_csv(d / "metrics.csv", index=False)
        assert main(["--pairs", str(d / "pairs.csv"), "--metrics-table", str(d / "metrics.csv"),
                     "--out", str(d / "report"), "--target", "clip_drop", "--bootstrap", "200",
                     "--quiet"]) == 0
    assert pd.read_csv(a / "report" / "summary.csv")["srcc_ci_lo"].notna().all()
    _same_report(a / "report", b / "report")
    assert "pairs sorted by clip_id, then pair_id" in (a / "report" / "report.md").read_text()


@pytest.mark.parametrize("seed", [0, 1])
def test_canonical_order_is_the_order_of_a_sorted_file(tmp_path, seed):
    # a file already in canonical order is analysed exactly as it is: the sort is the identity
    ratings, metrics = make_ratings(n_clips=2, n_tracks=3, n_frames=2, n_raters=4, seed=seed)
    ratings.sort_values(["item_id", "rater_id", "kind"]).to_csv(tmp_path / "r.csv", index=False)
    votes = read_ratings(tmp_path / "r.csv")
    np.testing.assert_array_equal(votes["item_id"], pd.read_csv(tmp_path / "r.csv")["item_id"])
