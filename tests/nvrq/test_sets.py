"""FD and KID per set (issue 35): against straightforward NumPy / SciPy / scikit-learn
computations, KID's unbiasedness, FD of a set with itself, and ``nvrq score-sets`` end to end."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from nvrq.sets import SetOptions, frechet_distance, kid, set_table


def _fd_eig(a, b):
    # tr((S1 S2)^(1/2)) as the sum of the square roots of the eigenvalues of S1 S2 (real and
    # non-negative for two covariance matrices): no matrix square root involved
    s1, s2 = np.cov(a, rowvar=False), np.cov(b, rowvar=False)
    mu = a.mean(0) - b.mean(0)
    ev = np.linalg.eigvals(s1 @ s2)
    return float(mu @ mu + np.trace(s1) + np.trace(s2) - 2 * np.sqrt(np.clip(ev.real, 0, None)).sum())


def _kid_sklearn(a, b, *, subsets, size, seed):
    # torch-fidelity's recipe written out with scikit-learn's polynomial kernel:
    # MMD^2_u = mean_{i != j} k(x_i, x_j) + mean_{i != j} k(y_i, y_j) - 2 mean k(x_i, y_j)
    from sklearn.metrics.pairwise import polynomial_kernel

    rng = np.random.RandomState(seed)
    out = []
    for _ in range(subsets):
        x = a[rng.choice(len(a), size, replace=False)]
        y = b[rng.choice(len(b), size, replace=False)]
        kw = dict(degree=3, gamma=1.0 / a.shape[1], coef0=1)
        kxx, kyy, kxy = polynomial_kernel(x, x, **kw), polynomial_kernel(y, y, **kw), polynomial_kernel(x, y, **kw)
        off = ~np.eye(size, dtype=bool)
        out.append(kxx[off].mean() + kyy[off].mean() - 2 * kxy.mean())
    return float(np.mean(out)), float(np.std(out))


def test_fd_and_kid_equal_straightforward_computation(tmp_path):
    rng = np.random.default_rng(1)
    a = rng.normal(size=(300, 12))
    b = rng.normal(size=(260, 12)) @ np.diag(np.linspace(0.5, 1.5, 12)) + 0.3
    # through the saved-features route: set_table on a features file, as `--save-features` writes it
    groups = pd.DataFrame({"set_id": "objects:m:y=+1.00", "kind": "objects", "method": "m", "x_offset_m": 0.0,
                           "y_offset_m": 1.0, "z_offset_m": 0.0, "roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0,
                           "perturbation": "y=+1.00", "side": ["render"] * 300 + ["gt"] * 260})
    np.savez(tmp_path / "f.npz", features=np.concatenate([a, b]), set_id=groups.set_id.to_numpy(str),
             side=groups.side.to_numpy(str))
    z = np.load(tmp_path / "f.npz")
    t = set_table(groups, z["features"], SetOptions(kid_subsets=20, kid_subset_size=100, seed=7), encoder="toy")
    r, g = z["features"][z["side"] == "render"], z["features"][z["side"] == "gt"]
    assert t.loc[0, "fd:toy"] == pytest.approx(_fd_eig(r, g), abs=1e-9)
    mean, std = _kid_sklearn(r, g, subsets=20, size=100, seed=7)
    assert t.loc[0, "kid:toy"] == pytest.approx(mean, abs=1e-9)
    assert t.loc[0, "kid_std:toy"] == pytest.approx(std, abs=1e-9)
    assert (t.loc[0, "n_render"], t.loc[0, "n_gt"], t.loc[0, "reason"]) == (300, 260, "")


def test_kid_fast_paths_equal_the_subset_by_subset_computation(monkeypatch):
    # kid() reads each subset's block of kernels computed once (or, when the subset is the whole
    # of both sets, gives their one value): the same numbers as scikit-learn's kernels per subset
    import nvrq.sets as sets

    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(40, 6)), rng.normal(0.2, 1.1, size=(40, 6))
    mean, std = _kid_sklearn(a, b, subsets=5, size=40, seed=9)  # every subset: the whole sets
    got = kid(a, b, subsets=5, subset_size=1000, seed=9)
    # no spread to give where every subset is the whole of both sets (the reason says so)
    assert got["kid"] == pytest.approx(mean, rel=1e-12) and np.isnan(got["kid_std"]) and std < 1e-15
    assert got["kid_subset_size"] == 40 and "no spread" in got["reason"]
    c = rng.normal(size=(55, 6))  # unequal sides: random subsets of 40 from the 55
    mean, std = _kid_sklearn(c, b, subsets=7, size=40, seed=9)
    got = kid(c, b, subsets=7, seed=9)
    assert got["kid"] == pytest.approx(mean, rel=1e-12) and got["kid_std"] == pytest.approx(std, rel=1e-9)
    monkeypatch.setattr(sets, "_KERNEL_CELLS", 10)  # too large to keep: kernels per subset
    assert kid(c, b, subsets=7, seed=9)["kid"] == pytest.approx(mean, rel=1e-12)


def test_fd_of_a_set_with_itself_is_zero():
    x = np.random.default_rng(2).normal(size=(500, 64))
    res = frechet_distance(x, x)
    assert abs(res["fd"]) < 1e-6 and res["fd_residue"] < 1e-6


def test_kid_mean_is_unbiased():
    # 200 independent pairs of sets drawn from one distribution: the mean of their KID means is
    # within 3 standard errors of 0 (the biased MMD^2 would sit clearly above 0 at n = 30)
    rng = np.random.default_rng(3)
    means = np.array([kid(rng.normal(size=(30, 8)), rng.normal(size=(30, 8)), subsets=5)["kid"]
                      for _ in range(200)])
    se = means.std(ddof=1) / np.sqrt(len(means))
    assert abs(means.mean()) < 3 * se, (means.mean(), se)


def test_kid_of_subsets_that_are_the_whole_sets_has_no_spread_and_says_why():
    rng = np.random.default_rng(6)
    r, g = rng.normal(size=(40, 8)), rng.normal(size=(40, 8)) + 0.2
    k = kid(r, g)  # m = min(1000, 40, 40) = 40: every subset is both whole sets
    mean, _ = _kid_sklearn(r, g, subsets=1, size=40, seed=2020)
    assert k["kid"] == pytest.approx(mean, abs=1e-12) and k["kid_subset_size"] == 40
    assert np.isnan(k["kid_std"]) and k["reason"] == "KID has no spread: every subset is the whole of both sets"
    part = kid(r, g, subset_size=20, subsets=30, seed=1)  # smaller subsets vary: a real spread
    assert part["kid_std"] > 0 and part["reason"] == ""


def test_too_small_for_fd():
    rng = np.random.default_rng(4)
    groups = pd.DataFrame({"set_id": "frames:m:none", "kind": "frames", "method": "m", "x_offset_m": 0.0,
                           "y_offset_m": 0.0, "z_offset_m": 0.0, "roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0,
                           "perturbation": "none", "side": ["render"] * 10 + ["gt"] * 10})
    f = rng.normal(size=(20, 16))
    t = set_table(groups, f, SetOptions(), encoder="toy")
    assert np.isnan(t.loc[0, "fd:toy"]) and "more than 16 images" in t.loc[0, "reason"]
    assert np.isfinite(t.loc[0, "kid:toy"]) and np.isnan(t.loc[0, "kid_std:toy"])
    assert t.loc[0, "reason"].split("; ")[1].startswith("KID has no spread")
    with pytest.raises(InputError, match="more than 16 images per side for FD"):
        set_table(groups, f, SetOptions(metrics=("fd",)), encoder="toy")


def test_score_sets_cli_frames(tmp_path):
    from nvrq.cli import main

    scene = tmp_path / "scene"
    assert main(["synth", str(scene), "--seconds", "0.3", "--size", "160x96", "--methods", "sharp:0.5,blurry:1.5",
                 "--offsets", "0,2", "--quiet"]) == 0
    out = tmp_path / "sets.csv"
    assert main(["score-sets", str(scene), "--out", str(out), "--sets", "frames", "--save-features",
                 str(tmp_path / "f.npz"), "--quiet", "--runtime", "torch"]) == 0
    t = pd.read_csv(out)
    assert set(t.set_id) == {f"frames:{m}:{v}" for m in ("sharp", "blurry") for v in ("none", "y=+2.00")}
    assert (t.n_render == 3).all() and (t.n_gt == 3).all() and t["fd:efficientnet-lite0"].isna().all()
    assert list(t.columns[:3]) == ["set_id", "clip_id", "kind"] and (t.clip_id == "synth-000000").all()
    z = np.load(tmp_path / "f.npz")
    for _, row in t.iterrows():  # every row recomputed from the features file
        sel = z["set_id"] == row.set_id
        r, g = z["features"][sel & (z["side"] == "render")], z["features"][sel & (z["side"] == "gt")]
        assert row["kid:efficientnet-lite0"] == pytest.approx(kid(r, g)["kid"], abs=1e-9)


def test_embed_matches_the_encoder_on_its_inputs():
    import nvrq
    from nvrq.crops import encoder_input, resize_to
    from nvrq.encoders import load_encoder

    rng = np.random.default_rng(5)
    ims = [rng.integers(0, 256, (40, 90, 3), dtype=np.uint8), rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)]
    enc = load_encoder("efficientnet-lite0", runtime="torch")
    want_pad = enc.embed(np.stack([encoder_input(x, 224) for x in ims]))
    want_stretch = enc.embed(np.stack([resize_to(x, 224, 224) for x in ims]))
    np.testing.assert_allclose(nvrq.embed(ims, encoder=enc), want_pad, atol=1e-6)
    np.testing.assert_allclose(nvrq.embed(ims, encoder=enc, square="stretch"), want_stretch, atol=1e-6)
    assert nvrq.embed(ims, encoder="efficientnet-lite0").shape == (2, 1280)  # by name, from the cache


def test_score_sets_of_a_one_frame_scene_keeps_every_set(tmp_path, capsys):
    # One frame: every frames set has 1 render and 1 GT image, too few for KID (its unbiased
    # estimator averages over distinct pairs, n >= 2) -- the set keeps its row with the reason,
    # and the object sets (several crops of that frame) still get KID.
    from nvrq.cli import main

    scene = tmp_path / "scene"
    assert main(["synth", str(scene), "--seconds", "0.1", "--fps", "10", "--size", "320x180",
                 "--offsets", "0,2", "--quiet"]) == 0
    out = tmp_path / "sets.csv"
    assert main(["score-sets", str(scene), "--out", str(out), "--save-features", str(tmp_path / "f.npz"),
                 "--quiet", "--runtime", "torch", "--min-visible", "0"]) == 0  # every object of the frame
    assert "without a value for some metric" in capsys.readouterr().out
    t = pd.read_csv(out, keep_default_na=False, na_values=[""])
    frames, objects = t[t.kind == "frames"], t[t.kind == "objects"]
    assert len(frames) == 2 and (frames.n_render == 1).all() and (frames.n_gt == 1).all()
    assert frames["kid:efficientnet-lite0"].isna().all() and frames["kid_subset_size"].isna().all()
    assert frames.reason.str.contains("KID needs at least 2 images per side: 1 render, 1 gt").all()
    assert len(objects) == 2 and (objects.n_render >= 2).all()
    z = np.load(tmp_path / "f.npz")
    for _, row in objects.iterrows():  # the object sets: KID from the features, as ever
        sel = z["set_id"] == row.set_id
        r, g = z["features"][sel & (z["side"] == "render")], z["features"][sel & (z["side"] == "gt")]
        assert row["kid:efficientnet-lite0"] == pytest.approx(kid(r, g)["kid"], abs=1e-9)
        assert row["kid_subset_size"] == min(len(r), len(g)) and "KID needs" not in row.reason
    # FD alone cannot be given for such a set: that stays an error naming the set
    assert main(["score-sets", str(scene), "--out", str(tmp_path / "fd.csv"), "--metrics", "fd",
                 "--quiet", "--runtime", "torch"]) == 2
    assert "set frames::none" in capsys.readouterr().err and not (tmp_path / "fd.csv").exists()


class _Terminal:
    """A stand-in standard error that says it is a terminal, keeping what is written."""

    def __init__(self):
        self.text = ""

    def write(self, s):
        self.text += s
        return len(s)

    def flush(self):
        pass

    def isatty(self):
        return True


def test_score_sets_draws_its_progress_bars_on_a_terminal_only(tmp_path, monkeypatch, capsys):
    import sys

    from nvrq.cli import main

    scene = tmp_path / "scene"
    assert main(["synth", str(scene), "--seconds", "0.3", "--size", "160x96", "--offsets", "0,2", "--quiet"]) == 0
    for extra, bars in (([], True), (["--quiet"], False)):
        term = _Terminal()
        monkeypatch.setattr(sys, "stderr", term)
        out = tmp_path / f"sets{len(extra)}.csv"
        assert main(["score-sets", str(scene), "--out", str(out), "--runtime", "torch", *extra]) == 0
        monkeypatch.undo()
        # both phases: the images embedded, then FD and KID per set, each with its count and ETA
        for desc in ("sets: embed", "sets: FD and KID"):
            assert (desc in term.text) == bars, term.text
        if bars:
            assert "image/s" in term.text or "s/image" in term.text
            assert "<" in term.text  # tqdm's "elapsed<remaining"
    # not a terminal (a log file or a pipe): no bar
    assert main(["score-sets", str(scene), "--out", str(tmp_path / "log.csv"), "--runtime", "torch"]) == 0
    assert "sets: embed" not in capsys.readouterr().err


def test_score_sets_takes_the_crop_features_of_score_and_gets_the_same_numbers(tmp_path, monkeypatch):
    # nvrq score --save-crop-features keeps each crop's embedding; score-sets --crop-features
    # embeds only what the file lacks (the whole frames), --pairs takes the pairs nvrq pairs made,
    # and its features and sets equal the ones it computes alone (same pairs, same crop, same
    # square pad, same encoder)
    import nvrq.sets as sets
    from nvrq.cli import main

    scene = tmp_path / "scene"
    assert main(["synth", str(scene), "--seconds", "0.4", "--size", "320x180", "--methods", "sharp:0.5,blurry:1.5",
                 "--offsets", "0,2", "--quiet"]) == 0
    pairs, crops = tmp_path / "pairs.csv", tmp_path / "crops.npz"
    assert main(["pairs", str(scene), "--out", str(pairs), "--quiet"]) == 0
    assert main(["score", str(pairs), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr,nvrq", "--runtime",
                 "torch", "--save-crop-features", str(crops), "--quiet"]) == 0
    embedded = []
    real = sets.embed
    monkeypatch.setattr(sets, "embed", lambda ims, **kw: embedded.append((len(ims), kw["square"])) or real(ims, **kw))
    runs = {}
    for name, extra in (("alone", []), ("reused", ["--pairs", str(pairs), "--crop-features", str(crops)])):
        embedded.clear()
        out = tmp_path / f"{name}.csv"
        assert main(["score-sets", str(scene), "--out", str(out), "--save-features", str(tmp_path / f"{name}.npz"),
                     "--runtime", "torch", "--quiet", *extra]) == 0
        runs[name] = pd.read_csv(out), np.load(tmp_path / f"{name}.npz"), list(embedded)
    (t_a, z_a, e_a), (t_r, z_r, e_r) = runs["alone"], runs["reused"]
    n_pairs = len(pd.read_csv(pairs))
    assert n_pairs > 0 and {m for _, m in e_a} == {"stretch", "pad"}
    assert {m for _, m in e_r} == {"stretch"}  # every crop came from the file
    frames = np.char.startswith(z_a["set_id"].astype(str), "frames:")
    assert sum(n for n, _ in e_r) == len(set(z_a["path"][frames]))  # one pass per whole frame, no crop
    # float32 forward passes batched otherwise (crops alone in nvrq score) differ in the last digits
    np.testing.assert_allclose(z_r["features"], z_a["features"], rtol=1e-4, atol=1e-4)
    pd.testing.assert_frame_equal(t_r, t_a, rtol=1e-4)


def test_crop_features_of_another_encoder_are_refused(tmp_path):
    from data_schema.tables import pairs_table
    from nvrq.encoders import load_encoder
    from nvrq.sets import crop_features, save_crop_features

    img = tmp_path / "a.png"
    import cv2

    cv2.imwrite(str(img), np.zeros((8, 8, 3), np.uint8))
    frame = pd.DataFrame({"pair_id": ["p0"], "gt_path": ["a.png"], "render_path": ["a.png"],
                          **{c: [1] for c in ("gt_x0", "gt_y0", "r_x0", "r_y0")},
                          **{c: [4] for c in ("gt_x1", "gt_y1", "r_x1", "r_y1")}})
    table = pairs_table(frame, scene_root=tmp_path, where="pairs")
    enc = load_encoder("efficientnet-lite0", runtime="torch")
    f = tmp_path / "c.npz"
    feats = np.arange(2 * 1280, dtype=np.float32).reshape(2, 1280)
    save_crop_features(f, table, (feats[:1], feats[1:]), enc)
    known = crop_features(f, enc)
    assert len(known) == 1  # one crop: GT and render are the same file and box
    np.testing.assert_array_equal(next(iter(known.values())), feats[1])

    class Other:  # the same encoder on another runtime
        spec, runtime, precision, device, weights_hash = enc.spec, "onnxruntime", "fp32", "cpu", "x"

        def embed(self, images):  # never called: the identity differs first
            raise AssertionError

    with pytest.raises(InputError, match="c.npz.*runtime onnxruntime"):
        crop_features(f, Other())
    (tmp_path / "bad.npz").write_bytes(b"no")
    with pytest.raises(InputError, match="bad.npz"):
        crop_features(tmp_path / "bad.npz", enc)


def test_score_save_crop_features_needs_an_encoder_metric(tmp_path, capsys):
    from nvrq.cli import main

    pairs = tmp_path / "pairs.csv"
    pairs.write_text("pair_id\n")
    assert main(["score", str(pairs), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr",
                 "--save-crop-features", str(tmp_path / "c.npz")]) == 2
    assert "--save-crop-features" in capsys.readouterr().err and not (tmp_path / "c.npz").exists()
