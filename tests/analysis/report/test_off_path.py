"""The report's off-path metrics (issue 35): the table's cells and figure, and ``analyze
--compare-methods --nta NTA.csv --sets SETS.csv`` end to end on a two-method synthetic clip."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd

from analysis.report.off_path import off_path_display, off_path_figure

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "nvrq" / "proxies"))


def _res():
    table = pd.DataFrame({"method": ["a", "b", "a", "a"], "metric": ["nta_iou", "nta_iou", "psnr", "nta_iou"],
                          "breakdown": ["y_offset_m", "y_offset_m", "y_offset_m", "off-path"],
                          "group": ["+1.00", "+1.00", "-2.00", "all"], "n": [10, 12, 10, 30],
                          "n_tracks": [5, 6, 5, 8], "mean": [0.5, 0.25, 20.0, 0.4],
                          "ci_lo": [0.4, np.nan, 19.0, 0.3], "ci_hi": [0.6, np.nan, 21.0, 0.5]})
    sets = pd.DataFrame({"set_id": ["frames:a:y=+1.00"], "kind": ["frames"], "method": ["a"], "y_offset_m": [1.0],
                         "n_render": [40], "n_gt": [40], "fd:enc": [12.5], "kid:enc": [0.01], "kid_std:enc": [0.002]})
    return SimpleNamespace(table=table, metrics=["nta_iou", "psnr"], directions={"nta_iou": True, "psnr": True},
                           sets=sets), sets


def test_off_path_cells():
    res, sets = _res()
    t = off_path_display(res, sets).set_index(["offset", "method"])
    # the cells restate methods.csv's y_offset_m rows and the sets row (the off-path row is not per offset)
    assert t.loc[("+1", "a"), "nta_iou (higher is better \u2191)"] == "0.500 [0.400, 0.600] (n=10, 5 tr.)"
    assert t.loc[("+1", "b"), "nta_iou (higher is better \u2191)"] == "0.250 (n=12, 6 tr.)"
    assert t.loc[("-2", "a"), "psnr (higher is better \u2191)"] == "20.000 [19.000, 21.000] (n=10, 5 tr.)"
    assert t.loc[("+1", "a"), "kid:enc (frames) (lower is better \u2193)"] == "0.0100 \u00b1 0.0020 (n=40)"
    assert t.loc[("+1", "a"), "fd:enc (frames) (lower is better \u2193)"] == "12.500 (n=40)"
    fig = off_path_figure(res, sets)
    assert len(fig.axes) == 4  # nta_iou, psnr, fd, kid


def test_an_empty_fd_is_a_cell_with_its_reason_and_kid_without_spread_says_why():
    res, _ = _res()
    fd_reason = "FD needs more than 1280 images per side (the feature dimension): 40"
    kid_reason = "KID has no spread: every subset is the whole of both sets"
    sets = pd.DataFrame({"set_id": ["frames:a:y=+1.00", "frames:b:y=+1.00"], "kind": ["frames"] * 2,
                         "method": ["a", "b"], "y_offset_m": [1.0, 1.0], "n_render": [40, 2000], "n_gt": [40, 2000],
                         "fd:enc": [np.nan, 7.25], "kid:enc": [0.01, 0.02], "kid_std:enc": [np.nan, 0.003],
                         "reason": [f"{fd_reason}; {kid_reason}", ""]})
    t = off_path_display(res, sets).set_index(["offset", "method"])
    fd, kid = "fd:enc (frames) (lower is better \u2193)", "kid:enc (frames) (lower is better \u2193)"
    assert fd in t.columns  # the column is kept though one set has no FD
    assert t.loc[("+1", "a"), fd] == "\u2014 (no FD: n \u2264 1280, the feature dimension; n=40)"
    assert t.loc[("+1", "b"), fd] == "7.250 (n=2000)"
    assert t.loc[("+1", "a"), kid] == "0.0100 (n=40; no spread: the subsets are the whole sets)"  # not "± 0"
    assert t.loc[("+1", "b"), kid] == "0.0200 \u00b1 0.0030 (n=2000)"
    assert "\u00b1 0.0000" not in " ".join(t.to_numpy(str).ravel())
    fig = off_path_figure(res, sets)  # the empty FD has no point; the figure still draws the rest
    assert len(fig.axes) == 4
    # a table of an earlier version wrote 0 for that spread: recognised from the subset size
    old = sets.assign(**{"kid_std:enc": [0.0, 0.003], "kid_subset_size": [40, 1000], "reason": [fd_reason, ""]})
    assert off_path_display(res, old).set_index(["offset", "method"]).loc[("+1", "a"), kid] == \
        "0.0100 (n=40; no spread: the subsets are the whole sets)"


def test_analyze_compare_methods_with_nta(tmp_path):
    from test_nta_iou import _jittered_dets

    from analysis.cli import main as analyze
    from nvrq.cli import main

    scene = tmp_path / "scene"
    assert main(["synth", str(scene), "--seconds", "0.5", "--size", "320x180", "--methods", "sharp:0.5,blurry:1.5",
                 "--quiet"]) == 0
    assert main(["pairs", str(scene), "--out", str(tmp_path / "pairs.csv"), "--min-side", "10", "--min-visible", "0",
                 "--quiet"]) == 0
    dets, _ = _jittered_dets(scene)
    dets.to_csv(tmp_path / "dets.csv", index=False)
    assert main(["proxy", "nta-iou", str(scene), "--detections", str(tmp_path / "dets.csv"), "--out",
                 str(tmp_path / "nta.csv"), "--min-side", "10", "--bootstrap", "0"]) == 0
    sets = pd.DataFrame({"set_id": ["frames:sharp:y=+1.00"], "kind": ["frames"], "method": ["sharp"],
                         "y_offset_m": [1.0], "n_render": [5], "n_gt": [5], "kid:enc": [0.1], "kid_std:enc": [0.0]})
    sets.to_csv(tmp_path / "sets.csv", index=False)
    assert analyze(["--pairs", str(tmp_path / "pairs.csv"), "--compare-methods", "--nta", str(tmp_path / "nta.csv"),
                    "--sets", str(tmp_path / "sets.csv"), "--bootstrap", "200", "--out", str(tmp_path / "rep"),
                    "--quiet"]) == 0
    paired = pd.read_csv(tmp_path / "rep" / "methods_paired.csv")
    row = paired[(paired.metric == "nta_iou") & (paired.axis == "off-path")].iloc[0]
    # NTA-IoU of the pairs' objects, paired per object: sharp's detections are jittered less
    assert row.better == "sharp" and np.isfinite(row.p) and row.p_test in ("exact", "monte-carlo")
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "### Off-path metrics" in md and "kid:enc (frames)" in md
    assert (tmp_path / "rep" / "off_path.png").is_file()
