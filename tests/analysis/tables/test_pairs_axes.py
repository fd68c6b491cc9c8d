"""``analyze --pairs`` on 6-DoF pairs (docs/FORMATS.md §9): the same per-axis outputs as the
ratings path (``by_axis.csv`` and one tent plot per axis), from the one implementation
(:func:`analysis.tables.axes.view_tables`); issue 23 item 5."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.cli import main
from data_schema.perturbation import PERTURBATION_COLUMNS, labels, view_suffix
from data_schema.tables import PAIRS_COLUMNS

VIEWS = np.array([[0, 0, 0, 0, 0, 0], [0, -1, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0],
                  [0, 0, 0.5, 0, 0, 0], [0, 0, 0, 0, 0, -10], [0, 0, 0, 0, 0, 10.0]])


def _pairs(rng):
    """6 views x 3 clips x 4 tracks x 2 frames = 144 pairs; metrics fall with the view's size."""
    rows = []
    for c in range(3):
        for t in range(4):
            for f in range(2):
                for v, suffix, lab in zip(VIEWS, view_suffix(VIEWS), labels(VIEWS), strict=True):
                    rows.append({"pair_id": f"c{c}:front:t{t}:{f * 100000}:{suffix}", "clip_id": f"c{c}",
                                 "camera": "front", "track_id": f"t{t}", "label_class": ["car", "pedestrian"][t % 2],
                                 "timestamp_us": f * 100000, "gt_path": "g.png", "render_path": "r.png",
                                 **dict.fromkeys(PAIRS_COLUMNS[9:], 0),
                                 **dict(zip(PERTURBATION_COLUMNS, v, strict=True)), "perturbation": lab})
    df = pd.DataFrame(rows)
    size = np.abs(df["y_offset_m"]) + 2 * df["z_offset_m"] + np.abs(df["yaw_deg"]) / 10
    q = np.exp(-size) + rng.normal(0, 0.05, len(df))
    df["clip_drop"] = 1 - q + rng.normal(0, 0.05, len(df))
    df["psnr"] = 20 + 10 * q + rng.normal(0, 1, len(df))
    df["ssim"] = q + rng.normal(0, 0.1, len(df))
    return df


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("pairs_axes")
    df = _pairs(np.random.default_rng(5))
    pairs_cols = list(PAIRS_COLUMNS) + list(PERTURBATION_COLUMNS[:1] + PERTURBATION_COLUMNS[2:]) + ["perturbation"]
    df[pairs_cols].to_csv(tmp_path / "pairs.csv", index=False)
    df[["pair_id", "psnr", "ssim"]].to_csv(tmp_path / "metrics.csv", index=False)
    df[["pair_id", "clip_drop"]].to_csv(tmp_path / "proxy.csv", index=False)
    # the same items rated by three raters; the ratings carry the view columns and clip_drop
    votes = []
    for r in range(3):
        v = df.drop(columns=["psnr", "ssim", "pair_id", "gt_path", "render_path", *PAIRS_COLUMNS[9:]])
        votes.append(v.assign(item_id=df["pair_id"], rater_id=f"r{r}", vote=(df["ssim"] > 0.3 + 0.1 * r).astype(int),
                              voted_at="2026-01-01T00:00:00Z", response_ms=1000, kind="test"))
    pd.concat(votes).to_csv(tmp_path / "ratings.csv", index=False)
    common = ["--metrics-table", str(tmp_path / "metrics.csv"), "--bootstrap", "0", "--quiet"]
    assert main(["--pairs", str(tmp_path / "pairs.csv"), "--metrics-table", str(tmp_path / "proxy.csv"),
                 "--target", "clip_drop", "--out", str(tmp_path / "rep_pairs"), *common]) == 0
    assert main([str(tmp_path / "ratings.csv"), "--target", "clip_drop", "--out", str(tmp_path / "rep_ratings"),
                 *common]) == 0
    return tmp_path, df


def test_pairs_path_writes_per_axis_tables_and_tent_plots_like_the_ratings_path(reports):
    d, df = reports
    rep = d / "rep_pairs"
    for axis in ("y", "z", "yaw"):
        assert (rep / f"tent_{axis}.png").is_file()
        assert f"Tent plot along {axis} " in (rep / "report.html").read_text()
    assert not (rep / "tent.png").exists()  # the per-axis plots replace the lateral one
    pairs_axis = pd.read_csv(rep / "by_axis.csv")
    ratings_axis = pd.read_csv(d / "rep_ratings" / "by_axis.csv")
    pd.testing.assert_frame_equal(pairs_axis, ratings_axis, rtol=1e-12, atol=1e-12)
    # by_offset: the lateral views only, both paths (the ratings path adds per-class rows and gvf)
    po = pd.read_csv(rep / "by_offset.csv")
    ro = pd.read_csv(d / "rep_ratings" / "by_offset.csv")
    ro = ro[(ro["label_class"] == "all") & (ro["column"] != "gvf")].reset_index(drop=True)
    pd.testing.assert_frame_equal(po, ro, rtol=1e-12, atol=1e-12)
    assert sorted(po["y_offset_m"].unique()) == [-1.0, 0.0, 1.0]


def test_per_axis_table_of_the_pairs_path_equals_a_pandas_groupby(reports):
    d, df = reports
    t = pd.read_csv(d / "rep_pairs" / "by_axis.csv")
    assert list(dict.fromkeys(t["axis"])) == ["y", "z", "yaw"]
    # independent: the view-'none' pairs are value 0 of every axis; the others belong to their axis
    for axis, col in (("y", "y_offset_m"), ("z", "z_offset_m"), ("yaw", "yaw_deg")):
        others = [c for c in PERTURBATION_COLUMNS if c != col]
        on_axis = df[(df[others] == 0).all(axis=1)]
        for metric in ("psnr", "clip_drop"):
            want = on_axis.groupby(col)[metric].agg(["count", "mean", "std"])
            got = t[(t["axis"] == axis) & (t["column"] == metric)].set_index("value")
            np.testing.assert_array_equal(got["n"], want["count"])
            np.testing.assert_allclose(got["mean"], want["mean"], rtol=1e-12)
            np.testing.assert_allclose(got["std"], want["std"], rtol=1e-12)


def test_lateral_pairs_write_no_per_axis_table(reports, tmp_path):
    d, df = reports
    lateral = df[(df[["z_offset_m", "yaw_deg"]] == 0).all(axis=1)]
    lateral[list(PAIRS_COLUMNS)].to_csv(tmp_path / "lat.csv", index=False)
    assert main(["--pairs", str(tmp_path / "lat.csv"), "--metrics-table", str(d / "metrics.csv"),
                 "--metrics-table", str(d / "proxy.csv"), "--target", "clip_drop", "--bootstrap", "0",
                 "--quiet", "--out", str(tmp_path / "rep_lat")]) == 0
    assert not (tmp_path / "rep_lat" / "by_axis.csv").exists()
    assert (tmp_path / "rep_lat" / "tent.png").is_file()
