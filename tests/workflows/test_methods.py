"""Several reconstruction methods in one scene (docs/FORMATS.md §2-4, issue 20 items 1-3).

The clip: ``nvrq synth`` with the arguments of tests/data/pre_sixdof (seed 0, 0.5 s at 4 fps,
320x180, offsets -1, 0, 1) and three methods: ``good`` (severity x 0.5), ``bad`` (x 1.5) and
``same`` (x 1). ``same`` must reproduce the single-method files of that fixture (the scale 1
changes nothing), which ties the new path to the old, independently recorded outputs.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pandas as pd
import pytest

from analysis.all_pairs import read_all_pairs
from analysis.tables.inputs import classify_columns
from annotate.cli import main as annotate_main
from annotate.simulate import item_severity
from annotate.study import load_study
from data_schema import datasets as ds
from data_schema.errors import InputError
from data_schema.scene import load_scene
from nvrq.cli import main as nvrq_main
from nvrq.engines.shards import plan_shards, read_sources
from nvrq.pairs import PAIRS_OUTPUT_COLUMNS, make_pairs
from nvrq.scoring.batches import iter_crop_batches
from nvrq.scoring.driver import score_pairs
from nvrq.scoring.plan import ScorePlan

OLD = Path(__file__).resolve().parents[1] / "data" / "pre_sixdof"
CLIP = ["--seed", "0", "--seconds", "0.5", "--fps", "4", "--size", "320x180", "--offsets=-1,0,1", "--quiet"]
METHODS = {"good": 0.5, "bad": 1.5, "same": 1.0}
KEY = ["camera", "timestamp_us", "track_id", "y_offset_m"]


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    d = tmp_path_factory.mktemp("methods")
    spec = ",".join(f"{k}:{v}" for k, v in METHODS.items())
    assert nvrq_main(["synth", str(d / "scene"), *CLIP, "--methods", spec]) == 0
    assert nvrq_main(["pairs", str(d / "scene"), "--out", str(d / "pairs.csv"), "--min-visible", "0"]) == 0
    return d


def _strip(pairs: pd.DataFrame, method: str) -> pd.DataFrame:
    """One method's pairs as a single-method table: no method column, no ':method' in the ids."""
    one = pairs[pairs["method"] == method].drop(columns=["method", "scene_root"]).reset_index(drop=True)
    assert one["pair_id"].str.endswith(f":{method}").all()
    return one.assign(pair_id=one["pair_id"].str.removesuffix(f":{method}"))


# --- 1. the scene format -----------------------------------------------------------------------

def test_images_csv_names_the_method_of_every_render_and_none_for_gt(clip):
    images = pd.read_csv(clip / "scene" / "images.csv", keep_default_na=False)
    assert images.columns[-1] == "method"
    gt, ren = images[images["source"] == "gt"], images[images["source"] == "render"]
    assert (gt["method"] == "").all() and len(gt) == 2
    assert sorted(ren["method"].unique()) == sorted(METHODS)
    # one render per (camera, timestamp, view) and method: 2 frames x 3 offsets x 3 methods
    assert len(ren) == 18 and not ren.duplicated(["camera", "timestamp_us", "y_offset_m", "method"]).any()
    scene = load_scene(clip / "scene")
    assert list(scene.images.columns)[-1] == "method"


def test_old_scene_reads_and_pairs_exactly_as_before(clip, tmp_path):
    # the fixture's images.csv (no method column) against the same file with an empty one
    scene_dir = tmp_path / "old"
    shutil.copytree(clip / "scene", scene_dir)
    shutil.copy(OLD / "images.csv", scene_dir / "images.csv")
    for p in pd.read_csv(OLD / "images.csv")["path"]:  # the old layout's files: the scale-1 method's
        src = p.replace("/0.png", "/same/0.png").replace("/250000.png", "/same/250000.png") \
            if "render" in p else p
        (scene_dir / p).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(clip / "scene" / src, scene_dir / p)
    old_scene = load_scene(scene_dir)
    assert "method" not in old_scene.images.columns
    old_pairs, _ = make_pairs(old_scene, min_visible=0, progress=False)
    ref = pd.read_csv(OLD / "pairs.csv")
    # exactly the columns of a pairs table before methods (the fixture predates the 6-DoF ones)
    assert list(old_pairs.columns) == [*PAIRS_OUTPUT_COLUMNS, "lighting", "road_type", "scene_root"]
    got = pd.read_csv(pd.io.common.StringIO(old_pairs.to_csv(index=False)))[ref.columns]
    pd.testing.assert_frame_equal(got, ref)
    # an all-empty method column is the same single-method scene
    pd.read_csv(OLD / "images.csv").assign(method="").to_csv(scene_dir / "images.csv", index=False)
    again, _ = make_pairs(load_scene(scene_dir), min_visible=0, progress=False)
    pd.testing.assert_frame_equal(again, old_pairs)


def test_scale_one_method_reproduces_the_single_method_clip(clip):
    # degradation rows of 'same' = the fixture's (written before methods existed), to the byte
    deg = pd.read_csv(clip / "scene" / "degradation.csv")
    same = deg[deg["method"] == "same"].drop(columns="method")
    assert same.to_csv(index=False) == (OLD / "degradation.csv").read_text()
    ref = json.loads((OLD / "scene_reference.json").read_text())
    for old_rel in [k for k in ref["sha256"] if "render_" in k]:
        new = clip / "scene" / old_rel.replace("/0.png", "/same/0.png").replace("/250000.png", "/same/250000.png")
        if cv2.__version__ == ref["opencv"]:
            assert hashlib.sha256(new.read_bytes()).hexdigest() == ref["sha256"][old_rel], old_rel
        else:
            np.testing.assert_allclose(cv2.imread(str(new)).reshape(-1, 3).mean(0),
                                       ref["png_channel_means"][old_rel], atol=1.0, err_msg=old_rel)
    # and its pairs are the old pairs, ids and all, once the method is taken off
    pairs = pd.read_csv(clip / "pairs.csv")
    old = pd.read_csv(OLD / "pairs.csv")
    got = _strip(pairs, "same")[old.columns]
    got["render_path"] = got["render_path"].str.replace("/same/", "/")
    pd.testing.assert_frame_equal(got, old)


def test_scales_order_the_severities(clip):
    deg = pd.read_csv(clip / "scene" / "degradation.csv")
    wide = deg.pivot_table(index=KEY, columns="method", values="severity")
    assert len(wide) == len(deg) // 3 and wide.notna().all().all()
    assert (wide["good"] <= wide["same"]).all() and (wide["same"] <= wide["bad"]).all()
    # away from the clip at [0.001, 1] each severity is the scale-1 one times the scale (rounded to 1e-5)
    free = (wide["same"] * 1.5 < 1) & (wide["same"] * 0.5 > 1e-3)
    assert free.mean() > 0.9
    for m, scale in METHODS.items():
        np.testing.assert_allclose(wide.loc[free, m], scale * wide.loc[free, "same"], atol=1.5e-5)
    assert (wide.loc[free, "good"] < wide.loc[free, "bad"]).all()


# --- 3. pairs and scores per method --------------------------------------------------------------

def test_pairs_carry_the_method_and_ids_name_it(clip):
    pairs = pd.read_csv(clip / "pairs.csv")
    cols = list(pairs.columns)
    assert cols[cols.index("novel_visible") + 1] == "method"  # after the view and visibility, before the attributes
    assert pairs["pair_id"].is_unique
    assert (pairs["pair_id"] == pairs["pair_id"].str.rsplit(":", n=1).str[0] + ":" + pairs["method"]).all()
    # the same objects for every method, sharing the GT crop
    per = {m: _strip(pairs, m).drop(columns=["render_path"]) for m in METHODS}
    for m in METHODS:
        pd.testing.assert_frame_equal(per[m], per["same"])


class CountingEncoder:
    """A fake encoder: 16x16 inputs, the embedding is the mean colour of each 4x4 tile; counts
    every image it embeds."""

    spec = SimpleNamespace(input_size=16, name="count")
    device, threads = "cpu", 1

    def __init__(self):
        self.images = 0

    def embed(self, x: np.ndarray) -> np.ndarray:
        self.images += len(x)
        return x.reshape(len(x), 4, 4, 4, 4, 3).mean(axis=(2, 4)).reshape(len(x), -1).astype(np.float32)


def test_each_gt_crop_is_embedded_once_for_every_method_and_view(clip):
    pairs = pd.read_csv(clip / "pairs.csv")
    n_methods = pairs["method"].nunique()
    G = len(pairs.drop_duplicates(["gt_path", "gt_x0", "gt_y0", "gt_x1", "gt_y1"]))  # GT crops
    R = len(pairs) // n_methods  # renders (pairs) per method
    assert G < R and len(pairs) == n_methods * R
    col = "nvrq:count"
    for max_pairs in (256, 5):  # small batches still keep a GT image's methods together
        enc = CountingEncoder()
        res = score_pairs(pairs.sample(frac=1, random_state=1), ScorePlan.for_columns([col], encoder=enc, max_pairs=max_pairs),
                          encoder=enc, progress=False)
        assert enc.images == res.n_encoder_images == G + n_methods * R  # not M·(G + R)
    # the same scores as each method scored on its own (which embeds its GT crops again)
    alone, n_alone = [], 0
    for _, sub in pairs.groupby("method"):
        enc = CountingEncoder()
        alone.append(score_pairs(sub, ScorePlan.for_columns([col, "psnr"], encoder=enc),
                                 encoder=enc, progress=False).table)
        n_alone += enc.images
    assert n_alone == n_methods * (G + R)
    alone = pd.concat(alone).set_index("pair_id").loc[pairs["pair_id"]]
    together = score_pairs(pairs, ScorePlan.for_columns([col, "psnr"], encoder=CountingEncoder()),
                           encoder=CountingEncoder(), progress=False).table
    np.testing.assert_allclose(together[col].to_numpy(), alone[col].to_numpy(), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(together["psnr"].to_numpy(), alone["psnr"].to_numpy())
    # batches: every GT image's pairs (all methods) in one batch
    groups = pairs.groupby("gt_path").size()
    seen = {}
    for batch in iter_crop_batches(pairs, max_pairs=5, background=False):
        for g, n in pairs["gt_path"].iloc[batch.rows].value_counts().items():
            assert g not in seen and n == groups[g]
            seen[g] = n


@pytest.mark.slow  # ~20 s on 2 busy cores, mostly loading the encoder
def test_method_clip_end_to_end_ranks_the_less_degraded_first(clip, tmp_path):
    enc = "efficientnet-lite0"
    assert nvrq_main(["score", str(clip / "pairs.csv"), "--out", str(tmp_path / "m.csv"), "--metrics",
                      "psnr,nvrq_ca", "--encoder", enc, "--runtime", "torch", "--quiet"]) == 0
    metrics = pd.read_csv(tmp_path / "m.csv")
    assert list(metrics.columns) == ["pair_id", "psnr", f"nvrq_ca:{enc}"]  # no method column: join on pair_id
    pairs = pd.read_csv(clip / "pairs.csv").merge(metrics, on="pair_id")
    assert len(pairs) == len(metrics)
    wide = pairs.pivot_table(index=["timestamp_us", "track_id", "y_offset_m"], columns="method",
                             values=["psnr", f"nvrq_ca:{enc}"])
    far = wide.index.get_level_values("y_offset_m") != 0
    ca = wide[f"nvrq_ca:{enc}"][far]  # the object seen from another view: NVRQ-CA follows the scale
    assert (ca["good"] > ca["bad"]).mean() >= 0.8
    assert ca["good"].mean() > ca["same"].mean() > ca["bad"].mean()
    # PSNR where the views align (offset 0); away from it PSNR is dominated by the view change
    # and rewards blur-like artefacts (the report's caveat), so it is not asserted there
    ps = wide["psnr"][~far]
    assert (ps["good"] > ps["bad"]).all() and ps["good"].mean() > ps["same"].mean() > ps["bad"].mean()


def test_analyze_pairs_carries_the_method_through(clip, tmp_path):
    assert nvrq_main(["score", str(clip / "pairs.csv"), "--out", str(tmp_path / "m.csv"),
                      "--metrics", "psnr", "--quiet"]) == 0
    items, _, unknown = read_all_pairs(clip / "pairs.csv", metrics_paths=[tmp_path / "m.csv"], progress=False)
    assert sorted(items["method"].astype(str).unique()) == sorted(METHODS) and not any(unknown.values())
    _, _, attributes, _ = classify_columns(items, lower=set(), higher=set(), target="psnr", where="x")
    assert "method" not in attributes and "lighting" in attributes


@pytest.fixture(scope="module")
def fleet(clip, tmp_path_factory):
    """A pairs dataset of the 3-method clip and a single-method clip (seed 1)."""
    d = tmp_path_factory.mktemp("fleet")
    assert nvrq_main(["synth", str(d / "single"), *CLIP, "--seed", "1"]) == 0
    assert nvrq_main(["pairs", str(clip / "scene"), str(d / "single"), "--out", str(d / "ds"), "--quiet"]) == 0
    return d / "ds"


def test_fleet_dataset_and_ray_shards_keep_methods_with_their_gt(fleet):
    # one schema: method empty in the single-method clip, whose pair ids are unchanged
    table = ds.read_dataset(fleet)
    by_clip = table.groupby("clip_id")["method"].agg(lambda s: sorted(set(s.fillna(""))))
    assert by_clip["synth-000000"] == sorted(METHODS) and by_clip["synth-000001"] == [""]
    assert not table.loc[table["clip_id"] == "synth-000001", "pair_id"].str.count(":").ne(4).any()
    shards = plan_shards(read_sources(fleet, required=("pair_id", "gt_path")), max_pairs=7)
    owner = {}
    for s in shards:
        part = table[table["clip_id"] == s.clip_id].reset_index(drop=True).iloc[list(s.rows)]
        for g in part["gt_path"].unique():
            assert owner.setdefault((s.clip_id, g), s.index) == s.index  # never split across shards


@pytest.mark.slow  # starts a local Ray instance
def test_ray_engine_scores_method_pairs_as_the_local_engine(fleet, tmp_path):
    ray = pytest.importorskip("ray")
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    started = not ray.is_initialized()
    if started:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        assert nvrq_main(["score", str(fleet), "--out", str(tmp_path / "m"), "--metrics", "psnr,ssim",
                          "--engine", "ray", "--shard-pairs", "7", "--quiet"]) == 0
    finally:
        if started:
            ray.shutdown()
    got = ds.read_dataset(tmp_path / "m")
    pairs = ds.read_dataset(fleet)
    want = score_pairs(pairs, ScorePlan.for_columns(["psnr", "ssim"]), progress=False).table
    assert got["pair_id"].tolist() == pairs["pair_id"].tolist()  # every method's pair, once
    for c in ("psnr", "ssim"):
        np.testing.assert_array_equal(got[c].to_numpy(), want[c].to_numpy())


# --- the binary study on multi-method pairs -------------------------------------------------------

def test_annotate_build_simulate_export_on_method_pairs(clip, tmp_path):
    study = tmp_path / "study"
    assert annotate_main(["build", str(study), "--pairs", str(clip / "pairs.csv"), "--tracks", "3",
                          "--frames-per-track", "1", "--repeats", "2"]) == 0
    items = pd.read_csv(study / "items.csv")
    assert items.loc[items["kind"] != "repeat", "item_id"].is_unique
    test = items[items["kind"] == "test"]
    assert set(test["method"]) == set(METHODS)  # each method's render is an ordinary item
    # every chosen object and view is there once per method
    assert (test.groupby(["track_id", "timestamp_us", "y_offset_m"])["method"].nunique() == 3).all()
    st = load_study(study)
    assert st.manifest.method_columns == ["method"] and "method" not in st.manifest.attribute_columns
    sev = item_severity(st).loc[test["key"]].to_numpy()
    wide = test.assign(sev=sev).pivot_table(index=["track_id", "timestamp_us", "y_offset_m"],
                                            columns="method", values="sev")
    assert (wide["good"] <= wide["bad"]).all() and (wide["good"] < wide["bad"]).any()
    assert annotate_main(["simulate", str(study), "--raters", "2"]) == 0
    assert annotate_main(["export", str(study), "--out", str(tmp_path / "ratings.csv")]) == 0
    ratings = pd.read_csv(tmp_path / "ratings.csv")
    assert "method" in ratings.columns and set(ratings.loc[ratings["kind"] == "test", "method"]) == set(METHODS)


# --- bad input: one line, exit 2, nothing written -------------------------------------------------

@pytest.mark.parametrize("spec, says", [
    ("a:-1", "a finite scale >= 0"), ("a:nan", "a finite scale >= 0"), ("a:x", "a finite scale >= 0"),
    ("a:1,a:2", "each method name once"), ("a b:1", "a method name"), ("a:b:1", "a method name"),
    ("1:1", "a method name"), ("none:1", "a method name"), ("a", "NAME:SCALE"), (",", "NAME:SCALE"),
])
def test_bad_methods_option_is_one_line_and_writes_nothing(tmp_path, capsys, spec, says):
    assert nvrq_main(["synth", str(tmp_path / "s"), *CLIP, f"--methods={spec}"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("error: --methods") and says in err, err
    assert not (tmp_path / "s").exists()


def _edit(src: Path, dst: Path, fn) -> Path:
    shutil.copytree(src, dst)
    images = pd.read_csv(dst / "images.csv", keep_default_na=False)
    fn(images).to_csv(dst / "images.csv", index=False)
    return dst


@pytest.mark.parametrize("name, fn, says", [
    ("gt", lambda d: d.assign(method=np.where(d["source"] == "gt", "good", d["method"])),
     "row 2, column method: expected an empty method for a gt image"),
    ("empty", lambda d: d.assign(method=np.where(np.arange(len(d)) == 3, "", d["method"])),
     "row 5, column method: expected a method name for every render"),
    ("colon", lambda d: d.assign(method=d["method"].replace("bad", "b:ad")), "row 4, column method: expected a method name"),
    ("dup", lambda d: pd.concat([d, d.iloc[[1]]]),
     "row 22: expected one image per (camera, timestamp_us, source, perturbation, method)"),
])
def test_bad_method_cells_in_images_csv_are_one_line_errors(clip, tmp_path, capsys, name, fn, says):
    scene = _edit(clip / "scene", tmp_path / name, fn)
    with pytest.raises(InputError, match=r"images\.csv: " + says.replace("(", r"\(").replace(")", r"\)")):
        load_scene(scene)
    assert nvrq_main(["pairs", str(scene), "--out", str(tmp_path / "p.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "images.csv" in err and not (tmp_path / "p.csv").exists()


def test_bad_method_in_a_pairs_table_is_a_one_line_error(clip, tmp_path, capsys):
    pairs = pd.read_csv(clip / "pairs.csv")
    pairs.loc[4, "method"] = "x y"
    pairs.to_csv(tmp_path / "p.csv", index=False)
    assert nvrq_main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr"]) == 2
    err = capsys.readouterr().err.strip()
    assert "p.csv: line 6, column method: expected a method name" in err and err.count("\n") == 0
    assert not (tmp_path / "m.csv").exists()


def test_render_plan_of_a_method_scene_has_a_row_per_view_and_method(clip):
    from nvrq.render_plans import plan_table

    scene = load_scene(clip / "scene")
    plan = plan_table(scene)
    assert plan.columns[-1] == "method" and len(plan) == 18  # 2 frames x 3 views x 3 methods
    renders = scene.images[scene.images["source"] == "render"]
    assert set(zip(plan["path"], plan["method"], strict=True)) == \
        set(zip(renders["path"], renders["method"], strict=True))
    one = plan.groupby(["timestamp_us", "y_offset_m"])["T_world_sensor"]  # one pose for every method
    assert all(all(np.array_equal(m, g.iloc[0]) for m in g) for _, g in one)
    new = plan_table(scene, offsets=[2.0])  # an unlisted view: each method's default path
    assert sorted(new.loc[new["timestamp_us"] == 0, "path"]) == \
        [f"images/front/render_+2.00/{m}/0.png" for m in ("bad", "good", "same")]
