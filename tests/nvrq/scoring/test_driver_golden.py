"""The golden metrics table: ``nvrq score`` gives the table kept in
``tests/nvrq/scoring/data/golden/metrics.csv`` on a small synthetic scene, and the Python API and the
Ray engine give, byte for byte, the table ``nvrq score`` gives on the same machine.

The stored table is met byte for byte on a machine that computes as its writer's did. The CPU's
vector units can move a few values a little: OpenCV's cubic resampling and torch's float sums
take other code paths with AVX-512 (seen: 3 of 44 render crops one level apart in a pixel, the
pixel metrics moved by at most 1.6e-5 of their value, NVRQ by 6e-5, NVRQ-CA by 6.3e-4). Against
the stored table every value must then be within :data:`CPU_RTOL` of it, every NaN where it is.

The scene is not stored: ``nvrq synth`` regenerates it (byte-deterministic for a seed; the image
hashes in ``scene.sha256`` tell a changed scene from a changed scorer). The golden table was
written by ``nvrq score`` (command in ``golden.json``) before issue 26 moved the scoring modules;
it pins every encoder-free metric and NVRQ / NVRQ-CA on the offline ``efficientnet-lite0``
(torch runtime, 2 torch threads: the encoder's float sums depend on the thread count and on the
pass sizes, so the three paths run the same passes with the same threads). A deliberate change
of a metric regenerates its column (``python tests/nvrq/scoring/test_driver_golden.py --write``).

The scene's pixels also depend on the libraries that draw and resample it (OpenCV above all):
``environment.json`` records the versions the golden was written with, and a changed scene names
them. After such a change, check that the scorer still gives the pre-change commit's table on the
new scene before regenerating.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from data_schema.tables import write_table
from nvrq.cli import main

DATA = Path(__file__).parent / "data" / "golden"
#: How far a value may move from the stored golden on a CPU with other vector units (see above).
CPU_RTOL = 2e-3
SPEC = json.loads((DATA / "golden.json").read_text(encoding="utf-8"))
ENCODER = SPEC["encoder"]
THREADS = SPEC["threads"]


def _scene_files(scene: Path) -> str:
    """``sha256  path`` lines of every file of the scene folder (sorted)."""
    return "".join(f"{hashlib.sha256(p.read_bytes()).hexdigest()}  {p.relative_to(scene).as_posix()}\n"
                   for p in sorted(scene.rglob("*")) if p.is_file())


def _versions() -> dict[str, str]:
    """Versions of the libraries the scene's pixels and the table's floats depend on."""
    from importlib.metadata import version

    return {name: version(name) for name in
            ("numpy", "scipy", "opencv-contrib-python-headless", "pillow", "torch")}


def _make_scene(root: Path) -> tuple[Path, Path]:
    scene, pairs = root / "scene", root / "pairs.csv"
    assert main(["synth", str(scene), *SPEC["synth"], "--quiet"]) == 0
    assert main(["pairs", str(scene), "--out", str(pairs), *SPEC["pairs"], "--quiet"]) == 0
    return scene, pairs


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """The regenerated scene folder and its pairs table; the scene's bytes are the recorded ones."""
    scene, pairs = _make_scene(tmp_path_factory.mktemp("golden"))
    recorded = json.loads((DATA / "environment.json").read_text(encoding="utf-8"))
    assert _scene_files(scene) == (DATA / "scene.sha256").read_text(encoding="utf-8"), (
        f"the regenerated scene differs from scene.sha256: written with {recorded}, now {_versions()}")
    return scene, pairs


@pytest.fixture
def torch_threads(monkeypatch, tmp_path):
    """The golden's torch thread count, restored afterwards; no user tau config (the registry's tau)."""
    torch = pytest.importorskip("torch")
    monkeypatch.setenv("NVRQ_CONFIG", str(tmp_path / "no-tau-config.json"))
    old = torch.get_num_threads()
    torch.set_num_threads(THREADS)
    yield
    torch.set_num_threads(old)


def _csv_bytes(table: pd.DataFrame, path: Path) -> bytes:
    """``table`` written as ``nvrq score`` writes a CSV (:func:`data_schema.tables.write_table`)."""
    write_table(table, path)
    return path.read_bytes()


def _golden() -> bytes:
    return (DATA / "metrics.csv").read_bytes()


def _score_args(pairs: Path, out: Path) -> list[str]:
    return ["score", str(pairs), "--out", str(out), "--metrics", ",".join(SPEC["metrics"]),
            "--encoder", ENCODER, "--runtime", SPEC["runtime"], "--threads", str(THREADS), "--quiet"]


def test_golden_scene_defines_every_metric_somewhere():
    table = pd.read_csv(DATA / "metrics.csv")
    columns = [c for c in table.columns if c != "pair_id"]
    assert len(table) >= 30 and len(columns) == len(SPEC["metrics"])
    assert all(table[c].notna().any() for c in columns), table.notna().sum()


def _check_golden(got: bytes) -> None:
    """``got`` (a metrics CSV) is the stored golden: byte for byte, or, on a CPU that computes
    differently, the same rows, columns and NaNs with every value within :data:`CPU_RTOL`."""
    if got == _golden():
        return
    import io

    want, have = pd.read_csv(DATA / "metrics.csv"), pd.read_csv(io.BytesIO(got))
    assert list(have.columns) == list(want.columns) and have["pair_id"].equals(want["pair_id"])
    for col in want.columns[1:]:
        np.testing.assert_allclose(have[col].to_numpy(), want[col].to_numpy(), rtol=CPU_RTOL,
                                   atol=0, err_msg=f"column {col} moved from the golden table")


@pytest.fixture(scope="module")
def cli_table(scene, tmp_path_factory):
    """The bytes ``nvrq score`` writes on this machine (the golden's threads, the registry's tau)."""
    torch = pytest.importorskip("torch")
    out = tmp_path_factory.mktemp("cli") / "metrics.csv"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("NVRQ_CONFIG", str(out.parent / "no-tau-config.json"))
        old = torch.get_num_threads()
        try:
            assert main(_score_args(scene[1], out)) == 0
        finally:
            torch.set_num_threads(old)
    return out.read_bytes()


def test_nvrq_score_gives_the_golden_table(cli_table):
    _check_golden(cli_table)


def _rgb(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"))  # PNG: Pillow decodes the same pixels as OpenCV


def test_python_api_gives_the_golden_table(scene, cli_table, torch_threads, tmp_path):
    import nvrq

    root, pairs_path = scene
    pairs = pd.read_csv(pairs_path)
    images: dict[str, np.ndarray] = {}
    gt_crops: dict[tuple, np.ndarray] = {}  # one array per GT crop: the API embeds it once, as nvrq score
    gts, renders = [], []
    for row in pairs.itertuples(index=False):
        for rel in (row.gt_path, row.render_path):
            if rel not in images:
                images[rel] = _rgb(root / rel)
        key = (row.gt_path, row.gt_x0, row.gt_y0, row.gt_x1, row.gt_y1)
        if key not in gt_crops:
            gt_crops[key] = images[row.gt_path][row.gt_y0:row.gt_y1 + 1, row.gt_x0:row.gt_x1 + 1]
        gts.append(gt_crops[key])
        renders.append(images[row.render_path][row.r_y0:row.r_y1 + 1, row.r_x0:row.r_x1 + 1])
    # the same encoder passes as nvrq score: its crop batches are the first GT image's pairs, then
    # the other images' pairs, grouped by image in first-appearance order (nvrq.scoring.batches),
    # each batch run as its GT crops then its render crops, 32 crops per pass
    codes = pd.factorize(pairs["gt_path"])[0]
    order = np.argsort(codes, kind="stable")
    batches = [order[codes[order] == 0], order[codes[order] > 0]]
    ev = nvrq.Evaluator(metrics=SPEC["metrics"], encoder=ENCODER, runtime=SPEC["runtime"])
    parts = [ev.score_crops([gts[i] for i in idx], [renders[i] for i in idx]) for idx in batches]
    table = pd.concat(parts, ignore_index=True).set_axis(np.concatenate(batches)).sort_index()
    table.insert(0, "pair_id", pairs["pair_id"].to_numpy())
    assert _csv_bytes(table, tmp_path / "api.csv") == cli_table


@pytest.mark.slow  # starts a local Ray instance
def test_ray_engine_gives_the_golden_table(scene, cli_table, torch_threads, tmp_path):
    ray = pytest.importorskip("ray")
    import os

    from data_schema import datasets as ds

    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    # 2 CPUs: one encoder actor with 2 torch threads (nvrq.engines.ray_engine), as the golden
    ray.init(num_cpus=THREADS, include_dashboard=False, log_to_driver=False)
    try:
        _, pairs = scene
        args = _score_args(pairs, tmp_path / "ray")
        assert main([*args[:args.index("--threads")], "--quiet", "--engine", "ray"]) == 0
    finally:
        ray.shutdown()
    table = ds.read_dataset(tmp_path / "ray").drop(columns="clip_id")
    assert _csv_bytes(table, tmp_path / "ray.csv") == cli_table


def write_golden(root: Path) -> None:
    """Regenerate the scene hashes and the golden table (after a deliberate change of a metric)."""
    import os

    import torch

    os.environ["NVRQ_CONFIG"] = str(root / "no-tau-config.json")  # the registry's tau
    scene, pairs = _make_scene(root)
    (DATA / "scene.sha256").write_text(_scene_files(scene), encoding="utf-8")
    (DATA / "environment.json").write_text(json.dumps(_versions(), indent=2) + "\n", encoding="utf-8")
    torch.set_num_threads(THREADS)
    assert main(_score_args(pairs, DATA / "metrics.csv")) == 0
    (DATA / "metrics.timing.csv").unlink()


if __name__ == "__main__":
    import tempfile

    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python tests/nvrq/scoring/test_driver_golden.py --write")
    with tempfile.TemporaryDirectory() as tmp:
        write_golden(Path(tmp))
