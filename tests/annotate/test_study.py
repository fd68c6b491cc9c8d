"""annotate build: design choices, crops, gold, repeats, manifest, input errors."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pandas as pd
import pytest

from annotate.design import GOLD_POOL, choose_tracks, spread_frames, usable_frames
from annotate.study import build_study, crop_path
from data_schema.errors import InputError


def test_design_counts_offsets_and_even_frames(make_study, toy_inputs):
    s = make_study(tracks=3, frames_per_track=3)
    m = s.manifest
    tests = s.items[s.items["kind"] == "test"]
    # 3 tracks x 3 frames x 3 offsets (hand count); every offset for each (track, frame)
    assert len(tests) == 27 and m.counts["test"] == 27
    assert m.offsets == [-1.0, 0.0, 1.0]
    per_frame = tests.groupby(["track_id", "timestamp_us"])["y_offset_m"].apply(sorted)
    assert all(v == [-1.0, 0.0, 1.0] for v in per_frame)
    # 6 frames at 0..500000 us, 3 spread evenly -> indices 0, 2(.5 -> 2), 5 (np.linspace rounding)
    for t in m.tracks:
        assert [ts for _, ts in t["frames"]] == [0, 200000, 500000]
    # both label classes represented (toy: even tracks automobile, odd pedestrian)
    assert {t["label_class"] for t in m.tracks} == {"automobile", "pedestrian"}
    assert m.seed == 0 and m.scene_roots["toy"] == str(toy_inputs[0].resolve())
    assert m.pairs == str(toy_inputs[1].resolve())


def test_spread_frames_and_usable_frames_hand_examples():
    assert spread_frames(12, 12) == list(range(12))
    assert spread_frames(5, 3) == [0, 2, 4]  # linspace(0, 4, 3)
    pairs = pd.DataFrame({"clip_id": "c", "track_id": ["a", "a", "a", "b"], "camera": "f",
                          "timestamp_us": [0, 0, 1, 0], "y_offset_m": [0.0, 1.0, 0.0, 0.0],
                          "label_class": "car"})
    # only (a, t=0) holds both offsets 0 and 1
    got = usable_frames(pairs, [0.0, 1.0])
    assert got[["track_id", "timestamp_us"]].values.tolist() == [["a", 0]]
    # at least one of them: every frame
    got = usable_frames(pairs, [0.0, 1.0], min_views=1)
    assert got[["track_id", "timestamp_us"]].values.tolist() == [["a", 0], ["a", 1], ["b", 0]]


def test_tracks_hidden_at_some_views_fill_the_study(toy_inputs, tmp_path):
    from annotate.study import build_study, load_study

    scene, pairs_path = toy_inputs
    pairs = pd.read_csv(pairs_path)
    # a visibility rule dropped trk-1 at +1 m in every frame and trk-2 at -1 and +1 m: trk-1
    # still holds two of the three views in each frame, trk-2 only one
    hidden = ((pairs["track_id"] == "trk-1") & (pairs["y_offset_m"] == 1.0)) | (
        (pairs["track_id"] == "trk-2") & (pairs["y_offset_m"] != 0.0))
    cut = tmp_path / "pairs_rule.csv"
    pairs[~hidden].to_csv(cut, index=False)

    def study(name, tracks):
        return load_study(build_study(tmp_path / name, cut, scene=str(scene), tracks=tracks, frames_per_track=2,
                                      n_training=0, n_gold=0, n_repeats=0, size=64, progress=False))

    # enough tracks seen at every view (trk-0, trk-3): only those, every view of their frames
    two = study("two", 2)
    assert sorted(t["track_id"] for t in two.manifest.tracks) == ["trk-0", "trk-3"]
    # more wanted than that: trk-1 fills in with the views it has (hand count: 2 full tracks x 2
    # frames x 3 views + trk-1 x 2 frames x 2 views); trk-2, seen at one view, never does
    four = study("four", 4)
    tests = four.items[four.items["kind"] == "test"]
    assert sorted(t["track_id"] for t in four.manifest.tracks) == ["trk-0", "trk-1", "trk-3"]
    assert len(tests) == 2 * 2 * 3 + 2 * 2
    assert sorted(set(tests.loc[tests["track_id"] == "trk-1", "y_offset_m"])) == [-1.0, 0.0]


def test_choose_tracks_round_robin_over_strata():
    frames = pd.DataFrame({"clip_id": "c", "track_id": [f"t{i}" for i in range(6)],
                           "camera": "f", "timestamp_us": 0,
                           "label_class": ["car"] * 4 + ["ped"] * 2})
    chosen = choose_tracks(frames, 2, np.random.default_rng(0))
    classes = {frames.set_index("track_id").loc[t, "label_class"] for _, t in chosen}
    assert classes == {"car", "ped"}  # two strata, two tracks: one from each


def test_crops_padded_to_same_square_and_colours_kept(make_study, toy_inputs):
    scene, pairs_path = toy_inputs
    s = make_study(size=64, image_format="png")
    pairs = pd.read_csv(pairs_path).set_index("pair_id")
    item = s.items[s.items["kind"] == "test"].iloc[0]
    p = pairs.loc[item["pair_id"]]
    a = cv2.imread(str(crop_path(s.root, item["ref_file"])))
    b = cv2.imread(str(crop_path(s.root, item["ren_file"])))
    assert a.shape == b.shape == (64, 64, 3)
    # independent reference: crop, pad to the common side (41: 31x41 boxes), resize
    gt = cv2.imread(str(scene / p["gt_path"]))[p["gt_y0"]:p["gt_y1"] + 1, p["gt_x0"]:p["gt_x1"] + 1]
    side = 41
    canvas = np.zeros((side, side, 3), np.uint8)
    canvas[0:41, 5:36] = gt
    ref = cv2.resize(canvas, (64, 64), interpolation=cv2.INTER_CUBIC)
    # PNG is lossless, BGR in, BGR out; each crop is dithered: about a sixteenth of its
    # values moved by one grey level (annotate.crops.DITHER_SHARE), no more
    diff = np.abs(a.astype(int) - ref)
    assert diff.max() == 1 and 0.02 < (diff > 0).mean() < 0.07
    # names are opaque: neither the offset nor the pair id appears
    for name in (item["ref_file"], item["ren_file"]):
        assert len(name) == len("0123456789abcdef.png") and "1.00" not in name


def test_gold_and_repeat_items(make_study, toy_inputs, toy_mod):
    scene, pairs_path = toy_inputs
    pairs = pd.read_csv(pairs_path).set_index("pair_id")
    s = make_study(n_gold=2, n_repeats=3, image_format="png")
    gold = s.items[s.items["kind"] == "gold"]
    # issue 38 item 31: a pool of GOLD_POOL x (2 x n_gold) gold items as far as the 12 test
    # items allow (it was 2 x n_gold = 4, all shown to every rater); a rater is shown 4 of
    # them, 2 good and 2 bad
    assert len(gold) == min(GOLD_POOL * 4, len(s.keys("test"))) == 12 and s.gold_per_rater == 4
    shown = [k for _after, k in s.plan_for("ann")["specials"] if k in set(gold.index)]
    assert sorted(k.split(":")[0] for k in shown) == ["gold-bad"] * 2 + ["gold-good"] * 2
    for it in gold.itertuples():
        p = pairs.loc[it.pair_id]
        box = p[["gt_x0", "gt_y0", "gt_x1", "gt_y1"]]
        gt = cv2.imread(str(scene / p["gt_path"]))
        a = cv2.imread(str(crop_path(s.root, it.ref_file)))
        b = cv2.imread(str(crop_path(s.root, it.ren_file)))
        # the reference is the GT crop (dithered: one grey level); the render a copy of the GT
        # image cut with the box moved by at most 8% of its 41 px (annotate.crops.MAX_SHIFT:
        # 3 px), slightly blurred for a good one, broken for a bad one
        assert toy_mod.copy_gap(gt, box, a, side=41, size=64, max_shift=0) < 0.1
        gap = toy_mod.copy_gap(gt, box, b, side=41, size=64, max_shift=3)
        if it.item_id.startswith("gold-good:"):
            assert gap < 2.5
        else:
            assert it.item_id.startswith("gold-bad:") and gap > 10
    rep = s.items[s.items["kind"] == "repeat"]
    assert len(rep) == 3
    assert set(rep["item_id"]) <= set(s.items.loc[s.items["kind"] == "test", "item_id"])
    assert (rep["key"] == "repeat:" + rep["item_id"]).all()


@pytest.fixture
def toy_mod():
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("annotate_toy2", Path(__file__).with_name("toy.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_scene_root_column_is_used_when_no_scene_option(tmp_path, toy_mod):
    _scene, pairs = toy_mod.make_toy(tmp_path, scene_root_column=True)
    out = build_study(tmp_path / "st", pairs, tracks=1, frames_per_track=1, progress=False)
    assert json.loads((out / "manifest.json").read_text())["scene_roots"]["toy"] == str(
        (tmp_path / "scene").resolve())


def test_input_errors(tmp_path, toy_inputs, make_study):
    scene, pairs = toy_inputs
    with pytest.raises(InputError, match="scene_root"):
        build_study(tmp_path / "a", pairs, progress=False)
    with pytest.raises(InputError, match="offsets"):
        build_study(tmp_path / "b", pairs, scene=str(scene), offsets="0,3", progress=False)
    s = make_study()
    with pytest.raises(InputError, match="new or empty study folder"):
        build_study(s.root, pairs, scene=str(scene), progress=False)
    df = pd.read_csv(pairs)
    df.loc[0, "gt_path"] = "images/missing.png"
    df.to_csv(tmp_path / "bad.csv", index=False)
    with pytest.raises(InputError, match="existing image file"):
        build_study(tmp_path / "c", tmp_path / "bad.csv", scene=str(scene), tracks=4,
                    frames_per_track=6, progress=False)
    assert not (tmp_path / "c").exists()  # nothing half-built left behind
