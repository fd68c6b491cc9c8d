"""The pairwise study: design balance, counterbalanced sides, swapped repeats, gold, crops,
simulation, export columns, bad input (docs/FORMATS.md §12).

The multi-method toy clip is made by hand (tests/annotate/toy.py ``methods=``): one render
per method, blurred ``SCALE`` times as much as the single-method toy, and degradation.csv
``severity = SCALE * |offset| / 2`` per method.
"""

from __future__ import annotations

import importlib.util
from itertools import combinations
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

from annotate.assign import make_plan, pairwise_sides
from annotate.cli import main
from annotate.study import build_study, load_study
from data_schema.errors import InputError
from data_schema.tables import PAIRWISE_VOTES_COLUMNS

_spec = importlib.util.spec_from_file_location("annotate_toy_pw", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(toy)

METHODS = {"alpha": 0.5, "gamma": 1.0, "beta": 1.5}


@pytest.fixture
def pw_inputs(tmp_path):
    """(scene, pairs.csv) of the toy clip rendered by three methods."""
    return toy.make_toy(tmp_path / "in", methods=METHODS)


def _build(tmp_path, pw_inputs, name="study", **kw):
    scene, pairs = pw_inputs
    opts = dict(scene=str(scene), tracks=2, frames_per_track=2, n_training=2, n_gold=2,
                n_repeats=3, size=64, image_format="png", design="pairwise", progress=False)
    opts.update(kw)
    return load_study(build_study(tmp_path / name, pairs, **opts))


def test_design_one_item_per_object_view_and_pair_of_methods(tmp_path, pw_inputs):
    s = _build(tmp_path, pw_inputs)
    pairs = pd.read_csv(pw_inputs[1]).set_index("pair_id")
    assert s.design == "pairwise" and s.manifest.methods == ["alpha", "beta", "gamma"]
    items = s.items
    tests = items[items["kind"] == "test"]
    # 2 tracks x 2 frames x 3 offsets = 12 object views, x C(3, 2) = 3 pairs of methods
    assert len(tests) == 36 == s.manifest.counts["test"]
    duos = tests.groupby("pair_id").apply(lambda g: sorted(zip(g["method_a"], g["method_b"], strict=True)))
    assert len(duos) == 12 and all(d == [("alpha", "beta"), ("alpha", "gamma"), ("beta", "gamma")]
                                   for d in duos)
    for _, it in tests.iterrows():  # each side's pairs row: same object view, its own method
        for side in ("a", "b"):
            row = pairs.loc[it[f"pair_id_{side}"]]
            assert row["method"] == it[f"method_{side}"]
            assert (row["track_id"], row["timestamp_us"], row["y_offset_m"]) == (
                it["track_id"], it["timestamp_us"], it["y_offset_m"])
        assert it["item_id"] == f"{it['pair_id']}|{it['method_a']}|{it['method_b']}"
    assert "method" not in s.manifest.attribute_columns
    gold = items[items["kind"] == "gold"]
    # issue 38 item 31: the gold pool is GOLD_POOL x the 4 a rater sees, here every one of the 8
    # object views away from the real camera (it was 4, all shown to every rater)
    assert len(gold) == 8 and (gold["method_a"] == "gt").all() and (gold["expected"] == "a").all()
    assert (gold["y_offset_m"] != 0).all()  # away from the real camera: GT and render differ
    assert gold["method_b"].isin(METHODS).all() and gold["pair_id_a"].isna().all()
    reps = items[items["kind"] == "repeat"]
    assert len(reps) == 3 and set(reps["item_id"]) <= set(tests["item_id"])
    assert (reps["key"] == "repeat:" + reps["item_id"]).all()
    training = items[items["kind"] == "training"]
    assert len(training) == 2 and not set(training["pair_id"]) & set(tests["pair_id"])


def _crop(scene: Path, path: str, box, side: int, size: int) -> np.ndarray:
    """The display crop made independently: inclusive box, centred on a black square, bicubic."""
    img = cv2.imread(str(scene / path))
    x0, y0, x1, y1 = (int(v) for v in box)
    c = img[y0:y1 + 1, x0:x1 + 1]
    sq = np.zeros((side, side, 3), np.uint8)
    top, left = (side - c.shape[0]) // 2, (side - c.shape[1]) // 2
    sq[top:top + c.shape[0], left:left + c.shape[1]] = c
    return cv2.resize(sq, (size, size), interpolation=cv2.INTER_CUBIC)


def test_crops_share_one_square_and_gold_shows_a_copy_of_the_gt_image(tmp_path, pw_inputs):
    scene = pw_inputs[0]
    s = _build(tmp_path, pw_inputs)
    pairs = pd.read_csv(pw_inputs[1]).set_index("pair_id")
    read = lambda name: cv2.imread(str(s.root / "crops" / name))  # noqa: E731
    it = s.items[(s.items["kind"] == "test") & (s.items["y_offset_m"] == 1.0)].iloc[0]
    a, b = pairs.loc[it["pair_id_a"]], pairs.loc[it["pair_id_b"]]
    # toy boxes are 31 x 41 px (inclusive) in every view: one square of side 41 for all three
    assert it["crop_side"] == 41
    # each crop dithered: at most one grey level off (annotate.crops.dither)
    near = lambda got, want: np.abs(got.astype(int) - want).max() <= 1  # noqa: E731
    gt = _crop(scene, a["gt_path"], a[["gt_x0", "gt_y0", "gt_x1", "gt_y1"]], 41, 64)
    assert near(read(it["ref_file"]), gt)
    for row, col in ((a, "a_file"), (b, "b_file")):
        want = _crop(scene, row["render_path"], row[["r_x0", "r_y0", "r_x1", "r_y1"]], 41, 64)
        assert near(read(it[col]), want)
    assert not near(read(it["a_file"]), read(it["b_file"]))  # 0.5 vs 1.5 x the blur
    for _, g in s.items[s.items["kind"] == "gold"].iterrows():
        # A: the GT image cut with the box moved (at most 3 px: 8% of 41) and slightly blurred
        p = pairs.loc[g["pair_id_b"]]
        box, image = p[["gt_x0", "gt_y0", "gt_x1", "gt_y1"]], cv2.imread(str(scene / p["gt_path"]))
        assert toy.copy_gap(image, box, read(g["a_file"]), side=41, size=64, max_shift=3) < 2.5
        assert near(read(g["ref_file"]), _crop(scene, p["gt_path"], box, 41, 64))
        assert not near(read(g["b_file"]), read(g["ref_file"]))
    names = [n for col in ("ref_file", "a_file", "b_file") for n in s.items[col]]
    assert len(set(names)) == len(names) and all(len(Path(n).stem) == 16 for n in names)


def test_sides_counterbalanced_per_rater_and_repeats_swapped(tmp_path, pw_inputs):
    s = _build(tmp_path, pw_inputs)
    per_item = {k: 0 for k in s.keys("test")}
    for r in range(40):
        sides = s.plan_for(f"r{r}")["sides"]
        for kind in ("test", "gold", "training"):
            # gold: the rater's own draw from the pool (issue 38 item 31), the only gold it has sides for
            keys = [k for k in s.keys(kind) if kind != "gold" or k in sides]
            assert kind != "gold" or len(keys) == s.gold_per_rater < len(s.keys("gold"))
            left = sum(sides[k] == "left" for k in keys)
            assert abs(2 * left - len(keys)) <= 1, kind  # half on each side (+-1 if odd)
        for k in s.keys("repeat"):
            assert sides[k] != sides[k.split(":", 1)[1]]
        for k in per_item:
            per_item[k] += sides[k] == "left"
    # across raters a fair coin: 40 raters give 5..35 "left" for every item with p > 1 - 1e-6
    assert all(5 <= n <= 35 for n in per_item.values())
    # the plan is stored: the same sides come back for a known rater
    assert load_study(s.root).plan_for("r3")["sides"] == s.plan_for("r3")["sides"]


def test_pairwise_sides_of_a_hand_plan():
    plan = make_plan(training=["t1", "t2", "t3"], tests=list("abcdef"), golds=["g"],
                     repeats={"repeat:a": "a", "repeat:e": "e"}, seed=7)
    sides = pairwise_sides(plan, seed=7)
    assert set(sides) == {"t1", "t2", "t3", *"abcdef", "g", "repeat:a", "repeat:e"}
    assert sum(sides[k] == "left" for k in "abcdef") == 3
    assert sum(sides[k] == "left" for k in ("t1", "t2", "t3")) in (1, 2)
    assert sides["repeat:a"] != sides["a"] and sides["repeat:e"] != sides["e"]
    assert pairwise_sides(plan, seed=7) == sides and make_plan(
        training=["t1", "t2", "t3"], tests=list("abcdef"), golds=["g"],
        repeats={"repeat:a": "a", "repeat:e": "e"}, seed=7) == plan  # plan stream unchanged


def _metrics(pairs_path: Path, out: Path) -> Path:
    """A metrics table with a made-up column whose value names its pair: 100 + row number."""
    p = pd.read_csv(pairs_path)
    pd.DataFrame({"pair_id": p["pair_id"], "psnr": 100.0 + np.arange(len(p))}).to_csv(out, index=False)
    return out


def test_simulate_export_balanced_votes_choices_and_columns(tmp_path, pw_inputs, capsys):
    scene, pairs = pw_inputs
    metrics = _metrics(pairs, tmp_path / "metrics.csv")
    study = tmp_path / "study"
    assert main(["build", str(study), "--pairs", str(pairs), "--scene", str(scene),
                 "--metrics-table", str(metrics), "--design", "pairwise", "--methods",
                 "alpha,beta", "--tracks", "2", "--frames-per-track", "2", "--size", "64x64",
                 "--votes-per-item", "3", "--repeats", "3", "--sampling", "uniform"]) == 0
    assert main(["simulate", str(study), "--raters", "5", "--seed", "1"]) == 0
    out = tmp_path / "votes.csv"
    assert main(["export", str(study), "--out", str(out)]) == 0
    s = load_study(study)
    v = pd.read_csv(out, dtype={"pair_id_a": str, "pair_id_b": str})
    assert list(v.columns[:9]) == [*PAIRWISE_VOTES_COLUMNS, "voted_at", "response_ms"]
    assert PAIRWISE_VOTES_COLUMNS == ("item_id", "rater_id", "kind", "method_a", "method_b",
                                      "side_a", "choice")  # issue 20 item 5's list
    assert {"clip_id", "track_id", "label_class", "y_offset_m", "lighting", "pair_id_a",
            "pair_id_b", "psnr_a", "psnr_b"} <= set(v.columns)
    assert "method" not in v.columns and "vote" not in v.columns
    # balanced: every test item has exactly k = 3 votes; 12 object views x 1 pair of methods
    tests = v[v["kind"] == "test"]
    assert tests.groupby("item_id").size().tolist() == [3] * 12
    assert set(zip(tests["method_a"], tests["method_b"], strict=True)) == {("alpha", "beta")}
    # choice from the stored key and the rater's plan, recomputed by hand
    stored = s.store.votes().set_index(["rater", "item"])["vote"]
    for _, r in v.iterrows():
        key = {"repeat": "repeat:", "training": "training:"}.get(r["kind"], "") + r["item_id"]
        side = s.plan_for(r["rater_id"])["sides"][key]
        assert r["side_a"] == side
        pressed = stored[(r["rater_id"], key)]  # 1 left, 2 right, 0 can't tell
        want = "tie" if pressed == 0 else "a" if (pressed == 1) == (side == "left") else "b"
        assert r["choice"] == want
    # metrics per side: 100 + the line of the side's own pairs row
    line = {pid: 100.0 + i for i, pid in enumerate(pd.read_csv(pairs)["pair_id"])}
    t = v[v["kind"] != "gold"]
    assert np.allclose(t["psnr_a"], t["pair_id_a"].map(line))
    assert np.allclose(t["psnr_b"], t["pair_id_b"].map(line))
    gold = v[v["kind"] == "gold"]
    assert (gold["method_a"] == "gt").all() and gold["psnr_a"].isna().all()
    assert gold["pair_id_a"].isna().all() and gold["psnr_b"].notna().all()
    # a repeat is shown with the sides its original had, swapped, to the same rater
    for _, r in v[v["kind"] == "repeat"].iterrows():
        orig = v[(v["kind"] == "test") & (v["item_id"] == r["item_id"]) & (v["rater_id"] == r["rater_id"])]
        if len(orig):
            assert orig["side_a"].iloc[0] != r["side_a"]


def test_simulated_raters_prefer_the_less_degraded_method(tmp_path, pw_inputs):
    from annotate.results import pairwise_votes_table
    from annotate.simulate import p_choice, pairwise_severity, simulate

    s = _build(tmp_path, pw_inputs, methods="alpha,beta", votes_per_item=4)
    sev = pairwise_severity(s)
    tests = s.items[s.items["kind"] == "test"]
    # severity = SCALE * |offset| / 2: alpha 0.5 -> 0.25, beta 1.5 -> 0.75 at |offset| = 1
    one = tests[tests["y_offset_m"].abs() == 1.0].index
    assert np.allclose(sev.loc[one, "sev_a"], 0.25) and np.allclose(sev.loc[one, "sev_b"], 0.75)
    gold = s.items[s.items["kind"] == "gold"].index
    assert (sev.loc[gold, "sev_a"] == 0).all()
    params = simulate(s, raters=5, seed=0, progress=False)
    v = pairwise_votes_table(s)
    careful = v[v["rater_id"].isin(params.loc[~params["careless"], "rater_id"]) & (v["kind"] == "test")]
    far = careful[careful["y_offset_m"].abs() == 1.0]
    # every drawable rater (tie <= 0.05, width <= 0.12) picks A at delta = 0.5 with p >= 0.964
    # (0.02 / 3 + 0.98 * sigmoid(0.45 / 0.12)); 0.8 is 5 failures above the expected ~1 of ~30
    assert p_choice(0.5, tie=0.05, width=0.12, lapse=0.02)[0] > 0.96
    assert (far["choice"] == "a").mean() > 0.8
    # and the count of "a" answers over all careful test votes is the model's within 4 sigma
    par = params.set_index("rater_id")
    key = careful["item_id"]
    delta = sev.loc[key, "sev_b"].to_numpy() - sev.loc[key, "sev_a"].to_numpy()
    pa = p_choice(delta, tie=par.loc[careful["rater_id"], "tie"].to_numpy(),
                  width=par.loc[careful["rater_id"], "width"].to_numpy(), lapse=0.02)[0]
    got = (careful["choice"] == "a").sum()
    assert abs(got - pa.sum()) <= 4 * np.sqrt((pa * (1 - pa)).sum()) + 1, (got, pa.sum())


def test_bad_input_one_line_exit_2_and_no_output(tmp_path, pw_inputs, toy_inputs, capsys):
    scene, pairs = pw_inputs
    base = ["--pairs", str(pairs), "--scene", str(scene), "--design", "pairwise"]
    cases = [
        (["--methods", "alpha,delta"], "--methods", "delta"),
        (["--methods", "alpha"], "--methods", "at least 2 methods"),
        (["--methods", "alpha,alpha"], "--methods", "each method once"),
    ]
    for extra, field, what in cases:
        out = tmp_path / "s"
        assert main(["build", str(out), *base, *extra]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and field in err and what in err, err
        assert not out.exists()
    old_scene, old_pairs = toy_inputs  # a single-method pairs table: no method column
    out = tmp_path / "s"
    assert main(["build", str(out), "--pairs", str(old_pairs), "--scene", str(old_scene),
                 "--design", "pairwise"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(old_pairs) in err and "'method'" in err, err
    assert not out.exists()
    one = pd.read_csv(pairs)
    one[one["method"] == "alpha"].to_csv(tmp_path / "one.csv", index=False)
    assert main(["build", str(out), "--pairs", str(tmp_path / "one.csv"), "--scene", str(scene),
                 "--design", "pairwise"]) == 2
    err = capsys.readouterr().err.strip()
    assert "at least 2 methods" in err and "one.csv" in err and not out.exists()
    assert main(["build", str(out), "--pairs", str(old_pairs), "--scene", str(old_scene),
                 "--methods", "a,b"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--methods" in err and "--design pairwise" in err and not out.exists()


def test_store_votes_by_design(tmp_path, pw_inputs, make_study):
    s = _build(tmp_path, pw_inputs)
    key = s.keys("test")[0]
    s.plan_for("ann")
    s.store.record_vote("ann", key, 2)  # right
    with pytest.raises(InputError, match=r"1 \(left\), 2 \(right\) or 0 \(can't tell\)"):
        s.store.record_vote("ann", key, 3)
    b = make_study()  # a binary study keeps 1 good / 0 bad only
    assert b.design == "binary" and "design" not in b.manifest.to_dict()
    with pytest.raises(InputError, match=r"1 \(good\) or 0 \(bad\)"):
        b.store.record_vote("ann", b.keys("test")[0], 2)


def test_gvf_refuses_a_pairwise_study(tmp_path, pw_inputs, capsys):
    s = _build(tmp_path, pw_inputs)
    assert main(["gvf", str(s.root)]) == 2
    err = capsys.readouterr().err
    assert "design" in err and "pairwise" in err and len(err.strip().splitlines()) == 1


def test_methods_pairs_of_a_four_method_list_keep_the_given_order(tmp_path):
    scene, pairs = toy.make_toy(tmp_path / "in4", methods={"d": 1.0, "c": 1.1, "b": 1.2, "a": 1.3},
                                n_tracks=2, n_frames=2)
    s = load_study(build_study(tmp_path / "s4", pairs, scene=str(scene), tracks=1, frames_per_track=1,
                               n_training=0, n_gold=0, n_repeats=0, size=32, design="pairwise",
                               methods="d,b,a", progress=False))
    duos = sorted(set(zip(s.items["method_a"], s.items["method_b"], strict=True)))
    assert duos == sorted(combinations(["d", "b", "a"], 2))  # A is the earlier in --methods


@pytest.mark.slow
def test_exported_votes_rank_the_methods_in_analyze(tmp_path, pw_inputs):
    """annotate's export is analyze's pairwise input: the less blurred method ranks first."""
    from analysis.cli import main as analyze

    s = _build(tmp_path, pw_inputs, votes_per_item=4)
    assert main(["simulate", str(s.root), "--raters", "5", "--seed", "0"]) == 0
    votes = tmp_path / "votes.csv"
    assert main(["export", str(s.root), "--out", str(votes)]) == 0
    assert analyze([str(votes), "--bootstrap", "50", "--out", str(tmp_path / "report")]) == 0
    bt = pd.read_csv(tmp_path / "report" / "bradley_terry.csv")
    overall = bt[bt["axis"] == "all"].set_index("method")["score"]
    # toy blur scales: alpha 0.5 < gamma 1.0 < beta 1.5 times the single-method toy's
    assert overall["alpha"] > overall["gamma"] > overall["beta"]


def test_app_pairwise_page_keys_undo_resume_and_no_method_names(tmp_path, pw_inputs, monkeypatch):
    """AppTest smoke test of the pairwise page (widgets by key, annotate/app.py lists them)."""
    from streamlit.testing.v1 import AppTest

    import annotate

    s = _build(tmp_path, pw_inputs, methods="alpha,beta", n_gold=1, n_repeats=1,
               frames_per_track=1, tracks=1)
    monkeypatch.setenv("ANNOTATE_STUDY", str(s.root))
    monkeypatch.setenv("ANNOTATE_MIN_RESPONSE_MS", "0")  # AppTest presses at once
    app = str(Path(annotate.__file__).with_name("app.py"))

    def run():
        at = AppTest.from_file(app, default_timeout=20)
        at.query_params["rater"] = "pia"
        return at.run()

    def btn(at, name):
        found = [b for b in at.button if b.key and b.key.startswith(name + "-")]
        assert len(found) == 1, [b.key for b in at.button]
        return found[0]

    def text(at):
        parts = [str(e.value) for k in ("title", "markdown", "info", "success", "error", "text")
                 for e in at.get(k)]
        return "\n".join([*parts, *(b.label for b in at.button),
                          *(e.proto.text for e in at.get("progress"))])

    at = run()
    assert "Reference" in at.markdown[0].value and "which of the two" in at.markdown[0].value
    at.button(key="start").click().run()
    (images,) = at.get("image")  # one element: the three crops, titled, in page order
    assert images.captions == ["**Left choice**", "**Reference (real photo)**", "**Right choice**"]
    assert len(images.value) == 3 and len(set(images.value)) == 3
    seen, codes = [], {"vote_left": 1, "vote_right": 2, "vote_tie": 0}
    presses = ["vote_left", "vote_right", "vote_tie", "vote_right"]
    for name in presses:
        seen.append(at.session_state["shown"][0])
        btn(at, name).click().run()
    stored = s.store.votes("pia").set_index("item")["vote"]
    assert [stored[k] for k in seen] == [codes[n] for n in presses]
    btn(at, "undo").click().run()  # the last answer is taken back: its item is on screen again
    assert at.session_state["shown"][0] == seen[-1] and seen[-1] not in set(s.store.votes("pia")["item"])
    at2 = run()  # a new session resumes at the same item, no instructions
    assert at2.session_state["shown"][0] == seen[-1]
    while any(b.key and b.key.startswith("vote_left-") for b in at2.button):
        t = text(at2)
        for secret in ("alpha", "beta", "gt|", "toy", "trk-", "+1.00", "gold", "repeat"):
            assert secret not in t, (secret, t)
        btn(at2, "vote_left").click().run()
    assert "All done" in at2.success[0].value
    assert len(s.store.votes("pia")) == len(s.items)  # one rater below quota: every item once
    adm = AppTest.from_file(app, default_timeout=20)
    adm.query_params["admin"] = s.admin_token()
    adm.run()
    assert [b.key for b in adm.get("download_button")] == ["download_ratings"]
    raters = adm.dataframe[0].value
    assert raters.set_index("rater_id").loc["pia", "test"] == len(s.keys("test"))


def test_no_object_view_of_every_method_and_duplicates_are_refused(tmp_path, pw_inputs):
    scene, pairs = pw_inputs
    p = pd.read_csv(pairs)
    # alpha only at offset -1, beta only at +1: no object view has both
    part = p[((p["method"] == "alpha") & (p["y_offset_m"] == -1)) |
             ((p["method"] == "beta") & (p["y_offset_m"] == 1))]
    part.to_csv(tmp_path / "apart.csv", index=False)
    with pytest.raises(InputError, match=r"apart\.csv: column 'method': expected object views "
                                         r"rendered by every method"):
        build_study(tmp_path / "s1", tmp_path / "apart.csv", scene=str(scene), design="pairwise",
                    methods="alpha,beta", progress=False)
    dup = pd.concat([p, p.iloc[[0]].assign(pair_id="extra-id")])  # a second alpha render
    dup.to_csv(tmp_path / "dup.csv", index=False)
    with pytest.raises(InputError, match=r"dup\.csv: line \d+: expected one render per object"):
        build_study(tmp_path / "s2", tmp_path / "dup.csv", scene=str(scene), design="pairwise",
                    progress=False)
    assert not (tmp_path / "s1").exists() and not (tmp_path / "s2").exists()


def test_the_viewpoint_floor_is_never_shown(tmp_path):
    # perfect (the render with no artefact) and floor (two GT views) measure the viewpoint: the
    # study leaves their pairs out, so it is the study of the other methods
    scene, pairs = toy.make_toy(tmp_path / "in", methods={"alpha": 0.5, "beta": 1.5, "perfect": 0.0})
    s = _build(tmp_path, (scene, pairs))
    assert s.manifest.methods == ["alpha", "beta"]
    assert not s.items[["method_a", "method_b"]].isin(["perfect", "floor"]).any().any()
    table = pd.read_csv(pairs)
    only = tmp_path / "only.csv"
    table[table["method"] == "perfect"].to_csv(only, index=False)
    with pytest.raises(InputError, match="only those"):
        build_study(tmp_path / "none", only, scene=str(scene), design="pairwise", progress=False)
