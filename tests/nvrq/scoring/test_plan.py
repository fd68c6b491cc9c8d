"""Issue 34 (items 1-4) and issue 38 (items 10, 13, 14): the scoring plan made once, metrics that
declare their kind, and the messages of ``nvrq score``.

- no comparison of a column or metric name to a string literal is left in ``nvrq/scoring/``;
- a :class:`~nvrq.scoring.plan.ScorePlan` round-trips through JSON (the shard manifests);
- an encoder metric added by one ``register(...)`` call (the cosine itself, without NVRQ's
  rescaling or NVRQ-CA's curve) scores through the CLI, the Python API and the local engine with
  equal values, and equal to the cosine computed here with numpy from the encoder's embeddings;
- ``nvrq score --help`` lists the registry's metrics (the registered one too);
- an unknown metric names its closest spelling; Ctrl-C says what resumes; every unreadable
  image is reported in one error with a count.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from nvrq.cli import main
from nvrq.metrics.info import MetricInfo, MetricKind
from nvrq.metrics.registry import REGISTRY, register
from nvrq.scoring.plan import ScorePlan, resolve_plan
from tests.nvrq.scoring.toy_encoder import ToyEncoder

REPO = Path(__file__).resolve().parents[3]


def _string_compares(path: Path) -> list[str]:
    """``file:line`` of every ``==``/``!=``/``in`` comparison with a string literal on either side."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(isinstance(s, ast.Constant) and isinstance(s.value, str) for s in sides):
                found.append(f"{path.name}:{node.lineno}")
    return found


def test_scoring_compares_no_name_to_a_string_literal():
    files = sorted((REPO / "nvrq" / "scoring").glob("*.py"))
    assert files
    assert [w for f in files for w in _string_compares(f)] == []
    # and the textual patterns the issue names
    text = "\n".join(f.read_text(encoding="utf-8") for f in files)
    assert not re.search(r'==\s*"nvrq|split_column\([^)]*\)\[0\]\s*==', text)


def test_the_plan_round_trips_through_json():
    plan = resolve_plan("psnr,entropy,nvrq_ca", encoder="efficientnet-lite0", tau=0.6, batch_size=8,
                        max_pairs=64)
    again = ScorePlan.from_json(plan.to_json())
    assert again == plan and again.tau == 0.6 and again.batch_size == 8
    assert [s.kind for s in again.specs] == [MetricKind.PAIR, MetricKind.RENDER, MetricKind.ENCODER]
    assert plan.encoder.name == "efficientnet-lite0" and resolve_plan("psnr").encoder is None


def test_kind_enum_has_room_for_frame_and_set_metrics():
    assert {"frame", "set"} <= {k.value for k in MetricKind}


@pytest.fixture
def cosine():
    """``cosine``: the raw cosine of the two embeddings, ``2 S - 1`` of NVRQ's ``S = (cos + 1) / 2``
    (paper Eq. 4), registered through the registry alone and removed afterwards."""
    info = register(MetricInfo("cosine", True, (-1.0, 1.0), needs_encoder=True, consumes=MetricKind.ENCODER,
                               from_similarity=lambda s, tau: 2.0 * np.asarray(s, np.float64) - 1.0,
                               description="cosine of the GT and render embeddings"))
    yield info
    REGISTRY.pop("cosine")


def _numpy_cosine(pairs: pd.DataFrame, root: Path, enc: ToyEncoder) -> np.ndarray:
    """The cosine of each pair's embeddings, computed here: crops cut with numpy, the encoder
    input made by nvrq.crops.encoder_input (square pad + bicubic resize, docs/FORMATS.md §4)."""
    from nvrq.crops import encoder_input, read_rgb

    out = []
    for r in pairs.itertuples():
        gt = read_rgb(root / r.gt_path)[r.gt_y0:r.gt_y1 + 1, r.gt_x0:r.gt_x1 + 1]
        rd = read_rgb(root / r.render_path)[r.r_y0:r.r_y1 + 1, r.r_x0:r.r_x1 + 1]
        a, b = (enc.embed(encoder_input(c, enc.spec.input_size)[None])[0].astype(np.float64) for c in (gt, rd))
        out.append(a @ b / np.linalg.norm(a) / np.linalg.norm(b))
    return np.asarray(out)


def test_a_registered_encoder_metric_scores_through_cli_api_and_engine(cosine, tiny_scene, tmp_path, monkeypatch):
    import nvrq.encoders
    from nvrq.api import score_crops
    from nvrq.engines.local import score_dataset

    root, pairs = tiny_scene
    enc = ToyEncoder()
    monkeypatch.setattr(nvrq.encoders, "load_encoder", lambda *a, **k: enc)
    table = tmp_path / "pairs.csv"
    pairs.to_csv(table, index=False)
    col = "cosine:efficientnet-lite0"
    # CLI
    assert main(["score", str(table), "--out", str(tmp_path / "m.csv"), "--metrics", "cosine,psnr", "--quiet"]) == 0
    cli = pd.read_csv(tmp_path / "m.csv")
    # Python API, with the same crops
    from nvrq.crops import read_rgb

    gts = [read_rgb(root / r.gt_path)[r.gt_y0:r.gt_y1 + 1, r.gt_x0:r.gt_x1 + 1] for r in pairs.itertuples()]
    rds = [read_rgb(root / r.render_path)[r.r_y0:r.r_y1 + 1, r.r_x0:r.r_x1 + 1] for r in pairs.itertuples()]
    api = score_crops(gts, rds, metrics=["cosine", "psnr"], encoder=enc)
    # the local engine, on the table's one clip
    res = score_dataset(table, tmp_path / "ds", resolve_plan("cosine,psnr"), timing_path=tmp_path / "ds.timing.csv",
                        load_encoder=lambda: enc, progress=False)
    assert res["pairs"] == len(pairs)
    engine = pd.concat([pd.read_parquet(f) for f in sorted((tmp_path / "ds").rglob("shard-*.parquet"))])
    engine = engine.set_index("pair_id").loc[pairs["pair_id"]]
    want = _numpy_cosine(pairs, root, enc)
    np.testing.assert_allclose(cli[col], want, rtol=0, atol=1e-6)  # float32 embeddings
    np.testing.assert_array_equal(api[col].to_numpy(), cli[col].to_numpy())
    np.testing.assert_array_equal(engine[col].to_numpy(), cli[col].to_numpy())
    np.testing.assert_array_equal(api["psnr"].to_numpy(), cli["psnr"].to_numpy())


def test_help_lists_the_registry(cosine, capsys):
    assert main(["score", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for name, info in REGISTRY.items():
        if info.kind == "metric":
            assert (name if info.members is None else f"{name}:NAME") in text, name


@pytest.mark.parametrize("given, hint", [("musiq", "pyiqa:musiq"), ("PSNR", "psnr"), ("nvrq-ca", "nvrq_ca"),
                                         ("LPIPS", "lpips")])
def test_unknown_metric_names_its_closest_spelling(given, hint, tiny_scene, tmp_path, capsys):
    table = tmp_path / "pairs.csv"
    tiny_scene[1].to_csv(table, index=False)
    assert main(["score", str(table), "--out", str(tmp_path / "m.csv"), "--metrics", given]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"(did you mean {hint}?)" in err
    with pytest.raises(InputError, match=re.escape(f"did you mean {hint}?")):
        resolve_plan(given)


def test_ctrl_c_says_what_resumes(tiny_scene, tmp_path, capsys, monkeypatch):
    import nvrq.scoring.driver

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(nvrq.scoring.driver, "score_pairs", interrupted)
    table, out = tmp_path / "pairs.csv", tmp_path / "m.csv"
    tiny_scene[1].to_csv(table, index=False)
    assert main(["score", str(table), "--out", str(out), "--metrics", "psnr"]) == 130
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("interrupted: nothing was written to")
    assert "dataset outputs resume" in err and "nvrq pairs SCENE --out PAIRS_DIR" in err
    assert not out.exists()


def test_every_unreadable_image_is_reported_at_once(tiny_scene, tmp_path, capsys):
    root, pairs = tiny_scene
    bad = sorted(set(pairs["render_path"]))[:3]
    (root / bad[0]).write_bytes(b"not an image")
    (root / bad[1]).write_bytes(b"")
    (root / bad[2]).write_bytes(b"\x89PNG\r\n\x1a\n truncated")
    table, out = tmp_path / "pairs.csv", tmp_path / "m.csv"
    pairs.to_csv(table, index=False)
    assert main(["score", str(table), "--out", str(out), "--metrics", "psnr", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    n_images = len(set(pairs["gt_path"]) | set(pairs["render_path"]))
    assert f"got 3 unreadable images of {n_images}" in err
    for rel in bad:
        assert Path(rel).name in err
    assert not out.exists()
