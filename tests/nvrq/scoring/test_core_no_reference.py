"""No-reference metrics everywhere metrics go: the crop-scoring core (render crop alone, raw size,
no GT needed), ``nvrq score`` (columns, timing rows, NaN counts with reasons) and the optional
PyIQA bridge (a stand-in ``pyiqa`` module; the real one where installed)."""

from __future__ import annotations

import sys
import types

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from data_schema.errors import InputError
from nvrq.cli import main
from nvrq.metrics import column_info, direction, pyiqa_bridge
from nvrq.metrics.no_reference import brisque, entropy, niqe, piqe
from nvrq.metrics.pixel import mae
from nvrq.metrics.resolve import reference_columns, resolve_metrics
from nvrq.scoring.core import CropBatch, score_crop_batch
from nvrq.scoring.driver import score_pairs
from nvrq.scoring.plan import ScorePlan

NR = ["brisque", "niqe", "piqe", "entropy"]


def _render_crops(root, pairs):
    """Raw render crops read with Pillow and sliced with the inclusive boxes (no resize)."""
    out = []
    for r in pairs.itertuples():
        img = np.asarray(Image.open(root / r.render_path).convert("RGB"))
        out.append(img[r.r_y0:r.r_y1 + 1, r.r_x0:r.r_x1 + 1])
    return out


def test_core_scores_the_raw_render_crop_without_gt():
    rng = np.random.default_rng(3)
    crops = [rng.integers(0, 256, (h, w, 3), dtype=np.uint8) for h, w in ((40, 70), (120, 100), (97, 210))]
    batch = CropBatch(np.arange(3), [], None, crops)
    cols = score_crop_batch(batch, ScorePlan.for_columns(NR))
    for name, fn in zip(NR, (brisque, niqe, piqe, entropy), strict=True):
        np.testing.assert_array_equal(cols[name], [fn(c) for c in crops])
    assert np.isnan(cols["niqe"][0]) and np.isfinite(cols["niqe"][1:]).all()  # 40 px < one 96 px patch
    with pytest.raises(InputError, match="gt_crops: expected GT crops for the reference metrics psnr"):
        score_crop_batch(batch, ScorePlan.for_columns(["entropy", "psnr"]))
    assert reference_columns(["psnr", "niqe", "nvrq:x"]) == ["psnr", "nvrq:x"]


def test_score_pairs_nr_columns_timing_and_nan_reasons(tiny_scene):
    root, pairs = tiny_scene
    res = score_pairs(pairs, ScorePlan.for_columns(["psnr", *NR]), progress=False)
    renders = _render_crops(root, pairs)
    for name, fn in zip(NR, (brisque, niqe, piqe, entropy), strict=True):
        want = [fn(c) for c in renders]  # the raw render crop (its own size, not the GT's)
        np.testing.assert_array_equal(res.table[name].to_numpy(), want)
    assert res.timing["metric"].tolist() == ["psnr", *NR]
    # every crop of the tiny scene is under 96 px: all NIQE values NaN, counted with the reason
    assert res.undefined.values.tolist() == [["niqe", "shorter crop side < 96 px", 18]]


def test_cli_prints_nan_counts(tiny_scene, tmp_path, capsys):
    root, pairs = tiny_scene
    pairs.to_csv(tmp_path / "pairs.csv", index=False)
    assert main(["score", str(tmp_path / "pairs.csv"), "--out", str(tmp_path / "m.csv"),
                 "--metrics", "piqe,niqe", "--quiet"]) == 0
    assert "niqe: 18 of 18 pairs NaN (shorter crop side < 96 px)" in capsys.readouterr().err
    table = pd.read_csv(tmp_path / "m.csv")
    assert table.columns.tolist() == ["pair_id", "piqe", "niqe"] and table.piqe.notna().all()


def test_directions_and_registry_flags():
    assert [direction(m) for m in NR] == [False, False, False, True]
    assert all(not column_info(m).reference for m in NR) and column_info("ssim").reference


# --- the PyIQA bridge --------------------------------------------------------------------------

class _FakeMetric:
    """PyIQA's metric protocol: ``metric(dist[, ref])`` on (1, 3, H, W) float tensors in [0, 1]."""

    def __init__(self, name):
        self.metric_mode = "FR" if name == "fr_mae" else "NR"
        self.lower_better = name == "fr_mae"

    def __call__(self, dist, ref=None):
        return (dist - ref).abs().mean() if ref is not None else dist.mean()


@pytest.fixture
def fake_pyiqa(monkeypatch):
    mod = types.ModuleType("pyiqa")
    mod.list_models = lambda: ["fr_mae", "nr_mean"]
    mod.created = []
    mod.create_metric = lambda name, device="cpu": mod.created.append(name) or _FakeMetric(name)
    monkeypatch.setitem(sys.modules, "pyiqa", mod)
    monkeypatch.setitem(sys.modules, "pyiqa.default_model_configs", None)  # none: ask the metric
    pyiqa_bridge.metric_entry.cache_clear()
    pyiqa_bridge._metric.cache_clear()
    yield mod
    pyiqa_bridge.metric_entry.cache_clear()
    pyiqa_bridge._metric.cache_clear()


def test_pyiqa_bridge_with_a_stand_in_module(fake_pyiqa):
    cols = resolve_metrics(["pyiqa:fr_mae", "pyiqa:nr_mean", "psnr"], "efficientnet-lite0")
    assert cols == ["pyiqa:fr_mae", "pyiqa:nr_mean", "psnr"]
    assert direction("pyiqa:fr_mae") is False and direction("pyiqa:nr_mean") is True
    assert column_info("pyiqa:fr_mae").reference and not column_info("pyiqa:nr_mean").reference
    rng = np.random.default_rng(0)
    gt = rng.integers(0, 256, (20, 30, 3), dtype=np.uint8)
    render = rng.integers(0, 256, (20, 30, 3), dtype=np.uint8)  # same size: no resize
    out = score_crop_batch(CropBatch(np.arange(1), [gt], np.zeros(1, np.int64), [render]), ScorePlan.for_columns(cols))
    assert out["pyiqa:fr_mae"][0] == pytest.approx(mae(gt, render) / 255, rel=1e-5)  # float32 tensors
    assert out["pyiqa:nr_mean"][0] == pytest.approx(render.mean() / 255, rel=1e-5)
    # no GT: the no-reference PyIQA metric alone still runs
    nr = score_crop_batch(CropBatch(np.arange(1), [], None, [render]), ScorePlan.for_columns(["pyiqa:nr_mean"]))
    assert nr["pyiqa:nr_mean"][0] == pytest.approx(render.mean() / 255, rel=1e-5)
    assert fake_pyiqa.created.count("fr_mae") == 1  # each metric created once per process


def test_pyiqa_unknown_name_and_missing_package(fake_pyiqa, monkeypatch, capsys, tmp_path):
    with pytest.raises(InputError) as err:
        resolve_metrics(["pyiqa:nope"], "efficientnet-lite0")
    assert "pyiqa.list_models()" in str(err.value) and "\n" not in str(err.value)
    monkeypatch.setitem(sys.modules, "pyiqa", None)  # not installed
    pyiqa_bridge.metric_entry.cache_clear()
    assert main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"),
                 "--metrics", "pyiqa:musiq"]) == 2
    err_line = capsys.readouterr().err.strip()
    assert err_line.count("\n") == 0 and "pip install pyiqa torchvision" in err_line
    assert direction("pyiqa:musiq") is None  # analyze then asks for --lower-better/--higher-better


def test_a_broken_pyiqa_is_not_taken_for_an_unknown_metric(fake_pyiqa):
    # only "unknown name" and "not installed" (InputError) make a column unknown; any other
    # failure of pyiqa reaches the caller (it was swallowed by an `except ValueError` before)
    def broken():
        raise ValueError("pyiqa's own bug")

    fake_pyiqa.list_models = broken
    with pytest.raises(ValueError, match="pyiqa's own bug"):
        direction("pyiqa:nr_mean")


def test_pyiqa_real_package_where_installed():
    pyiqa = pytest.importorskip("pyiqa")
    pyiqa_bridge.metric_entry.cache_clear()
    rng = np.random.default_rng(1)
    gt = rng.integers(0, 256, (32, 32, 3), dtype=np.uint8)
    render = np.clip(gt.astype(int) + rng.integers(-20, 20, gt.shape), 0, 255).astype(np.uint8)
    out = score_crop_batch(CropBatch(np.arange(1), [gt], np.zeros(1, np.int64), [render]), ScorePlan.for_columns(["pyiqa:psnr", "psnr"]))
    assert pyiqa.create_metric("psnr").metric_mode == "FR"
    assert out["pyiqa:psnr"][0] == pytest.approx(out["psnr"][0], rel=1e-3)  # both RGB, range 255/1
