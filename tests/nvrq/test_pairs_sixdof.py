"""6-DoF views end to end (a tiny synthetic clip with y, z and yaw grids) and files written
before 6-DoF views existed (tests/data/pre_sixdof, made by commit 30ff5d6 with ``nvrq synth ... --seed 0 --seconds 0.5
--fps 4 --size 320x180 --offsets=-1,0,1``, ``nvrq pairs`` and ``analyze --bootstrap 200`` on
the first 60 items of a demo's ratings) loading unchanged."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

from analysis.cli import main as analyze_main
from annotate.cli import main as annotate_main
from data_schema.perturbation import axes, axis_values, perturbation_array
from data_schema.scene import load_scene
from nvrq.cli import main as nvrq_main
from nvrq.pairs import make_pairs
from nvrq.synth import generate_scene

OLD = Path(__file__).resolve().parents[1] / "data" / "pre_sixdof"


def _ok(rc):
    assert rc == 0


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    d = tmp_path_factory.mktemp("sixdof")
    _ok(nvrq_main(["synth", str(d / "scene"), "--seed", "0", "--seconds", "0.5", "--fps", "4", "--size",
                   "320x180", "--perturb", "y=-1:1:1,z=0:1:1,yaw=-10:10:10", "--quiet"]))
    return d


def test_synthetic_clip_with_y_z_yaw_grids_goes_to_one_tent_plot_per_axis(clip, capsys):
    d = clip
    _ok(nvrq_main(["pairs", str(d / "scene"), "--out", str(d / "pairs.csv")]))
    assert "axis z:" in capsys.readouterr().out  # drop reasons reported per axis
    pairs = pd.read_csv(d / "pairs.csv")
    assert {"x_offset_m", "z_offset_m", "roll_deg", "pitch_deg", "yaw_deg", "perturbation"} <= set(pairs.columns)
    assert set(axes(perturbation_array(pairs))) == {"none", "y", "z", "yaw"}
    _ok(nvrq_main(["score", str(d / "pairs.csv"), "--out", str(d / "metrics.csv"), "--metrics", "psnr,ssim"]))
    _ok(annotate_main(["build", str(d / "study"), "--pairs", str(d / "pairs.csv"), "--metrics",
                       str(d / "metrics.csv"), "--tracks", "3", "--frames-per-track", "2"]))
    items = pd.read_csv(d / "study" / "items.csv")
    test = items[items["kind"] == "test"]
    assert set(test["perturbation"]) >= {"none", "y=+1.00", "z=+1.00", "yaw=-10.00"}  # items across axes
    # raters never see the view: crop files are opaque ids
    assert not items["ref_file"].str.contains("=|offset|yaw").any()
    _ok(annotate_main(["simulate", str(d / "study"), "--raters", "3"]))
    _ok(annotate_main(["export", str(d / "study"), "--out", str(d / "ratings.csv")]))
    _ok(analyze_main([str(d / "ratings.csv"), "--out", str(d / "report"), "--bootstrap", "50", "--quiet"]))
    rep = d / "report"
    for axis in ("y", "z", "yaw"):
        assert (rep / f"tent_{axis}.png").is_file()
        assert f"Tent plot along {axis} " in (rep / "report.html").read_text()
    by_axis = pd.read_csv(rep / "by_axis.csv")
    assert list(dict.fromkeys(by_axis["axis"])) == ["y", "z", "yaw"]
    # the breakdown by axis and magnitude counts each test item once per axis (+ the zero view)
    n_test = len(test)
    gvf = by_axis[by_axis["column"] == "gvf"]
    assert gvf["n"].sum() == n_test + 2 * int((test["perturbation"] == "none").sum())


def test_synthetic_degradation_grows_with_the_perturbation_size(clip):
    deg = pd.read_csv(clip / "scene" / "degradation.csv")
    P = perturbation_array(deg)
    ax, val = axes(P), np.abs(axis_values(P))
    for axis in ("y", "z", "yaw"):
        zero = deg["severity"][ax == "none"].mean()
        far = deg["severity"][(ax == axis) & (val == val[ax == axis].max())].mean()
        assert far > zero + 0.05, axis
    images = load_scene(clip / "scene").images
    assert "images/front/render_yaw-10.00/0.png" in set(images["path"])


def test_scene_written_before_6dof_is_reproduced_byte_for_byte_and_pairs_are_unchanged(tmp_path):
    # the fixture files are the pre-change outputs of exactly this call (nvrq synth at 30ff5d6)
    out = generate_scene(tmp_path / "s", seed=0, seconds=0.5, fps=4, offsets=(-1, 0, 1), size=(320, 180),
                         progress=False)
    ref = json.loads((OLD / "scene_reference.json").read_text())
    got = {str(p.relative_to(out)): hashlib.sha256(p.read_bytes()).hexdigest()
           for p in sorted(out.rglob("*")) if p.is_file()}
    assert set(got) == set(ref["sha256"])
    pngs = [k for k in got if k.endswith(".png")]
    if cv2.__version__ == ref["opencv"]:  # the OpenCV that wrote the fixture: every byte equal
        assert got == ref["sha256"]
    else:  # another OpenCV may rasterise or encode differently: same images up to noise
        for k in pngs:
            np.testing.assert_allclose(cv2.imread(str(out / k)).reshape(-1, 3).mean(0),
                                       ref["png_channel_means"][k], atol=1.0, err_msg=k)
    for k in got.keys() - set(pngs):  # scene.json, images.csv, degradation.csv
        assert got[k] == ref["sha256"][k], k
    assert (out / "images.csv").read_bytes() == (OLD / "images.csv").read_bytes()
    pairs, _ = make_pairs(load_scene(out), min_visible=0, progress=False)  # the paper's protocol
    old = pd.read_csv(OLD / "pairs.csv")
    pd.testing.assert_frame_equal(pd.read_csv(pd.io.common.StringIO(pairs.to_csv(index=False)))[old.columns], old)
    # old tables read as lateral-only views
    assert set(axes(perturbation_array(old))) == {"none", "y"}


def test_ratings_written_before_6dof_give_the_same_report_tables(tmp_path):
    # --no-screen: the old report was made before screening was on by default (issue 29)
    _ok(analyze_main([str(OLD / "ratings.csv"), "--out", str(tmp_path / "r"), "--bootstrap", "200", "--quiet",
                      "--no-screen"]))
    # bootstrap columns: since the canonical row order (docs/FORMATS.md §6, issue 23) the draws
    # go to tracks in sorted order, not in this file's order, so they differ by Monte Carlo
    # noise only (200 replicates); the report's header says so for reports made before
    boot = [c for c in pd.read_csv(OLD / "report_summary.csv").columns
            if c.endswith(("_ci_lo", "_ci_hi")) or c in ("p_vs_best", "significant_vs_best")]
    for name in ("summary.csv", "by_offset.csv", "categories.csv"):
        new, old = pd.read_csv(tmp_path / "r" / name), pd.read_csv(OLD / f"report_{name}")
        if "label_class" in new.columns and name == "by_offset.csv":  # per-condition rows added
            new = new[new["label_class"] == "all"].reset_index(drop=True)
        if name == "summary.csv":  # the view-only baseline rows were added after this report
            new = new[~new["metric"].astype(str).str.startswith("view_only")].reset_index(drop=True)
            if "note" in old and new["note"].isna().all():  # the rows left carry no note, as before
                new["note"] = new["note"].astype(old["note"].dtype)
        exact = [c for c in old.columns if c not in boot and c != "plcc_logistic"]
        # the same numbers in every old column (issue 14 added columns: ceiling, CIs)
        pd.testing.assert_frame_equal(new[exact], old[exact], rtol=1e-12, atol=1e-12)
        if name == "summary.csv":  # the fit's stopping point moves with the order of its sums
            np.testing.assert_allclose(new["plcc_logistic"], old["plcc_logistic"], rtol=1e-7)
            ci = [c for c in boot if c.endswith(("_ci_lo", "_ci_hi"))]
            np.testing.assert_allclose(new[ci], old[ci], atol=0.1)
    assert not (tmp_path / "r" / "by_axis.csv").exists() and (tmp_path / "r" / "tent.png").is_file()
    assert "Reports made before this rule followed the file's row order" in (tmp_path / "r" / "report.md").read_text()
