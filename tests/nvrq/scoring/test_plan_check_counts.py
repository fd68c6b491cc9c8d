"""Issue 34, acceptance: after the plan is made, nothing validates again.

``nvrq score --metrics psnr,ssim,mae,entropy,nvrq,nvrq_ca --tau 0.6`` runs under ``sys.setprofile``
(and ``threading.setprofile``, for the decode threads) on a 36-pair and a 900-pair table made from
one small synthetic scene (the 900 rows repeat the scene's pairs under new pair ids), counting the
calls to functions of ``nvrq/`` and ``data_schema/`` whose names start with ``check``, ``_check``,
``require``, ``validate`` or ``resolve``. Both runs must make the same calls (nothing per batch or
per pair), and tau is checked (``check_tau``) at most twice: once when ``--tau`` is parsed, once
when the plan takes it. Before issue 34 the counts were 231 (36 pairs) with 7 tau checks, growing
with the pairs (the pixel metrics' shape check ran on every pair).

The encoder is a toy (tests/nvrq/scoring/toy_encoder.py): the counts are of the scoring path, not of
a model's loading.
"""

from __future__ import annotations

import collections
import os
import sys
import threading
from pathlib import Path

import pandas as pd
import pytest

from nvrq.cli import main
from tests.nvrq.scoring.toy_encoder import ToyEncoder

REPO = Path(__file__).resolve().parents[3]
PREFIXES = ("check", "_check", "require", "validate", "resolve")
METRICS = "psnr,ssim,mae,entropy,nvrq,nvrq_ca"


@pytest.fixture(scope="module")
def scene_pairs(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("counts")
    scene, pairs = root / "scene", root / "pairs.csv"
    assert main(["synth", str(scene), "--seed", "0", "--seconds", "1", "--fps", "2", "--size", "320x180",
                 "--offsets=-1,1", "--quiet"]) == 0
    assert main(["pairs", str(scene), "--out", str(pairs), "--quiet"]) == 0
    return pairs


def _tiled(pairs: Path, n: int) -> Path:
    """``n`` rows repeating the scene's pairs, each under its own pair id."""
    d = pd.read_csv(pairs)
    rows = d.iloc[[i % len(d) for i in range(n)]].reset_index(drop=True)
    rows["pair_id"] = [f"{p}#{i // len(d)}" for i, p in enumerate(rows["pair_id"])]
    out = pairs.with_name(f"pairs{n}.csv")
    rows.to_csv(out, index=False)
    return out


def _profiled(argv: list[str]) -> collections.Counter:
    """The check calls of ``main(argv)`` by function name (every thread)."""
    roots = (str(REPO / "nvrq") + os.sep, str(REPO / "data_schema") + os.sep)
    counts: collections.Counter = collections.Counter()

    def prof(frame, event, arg):
        if event == "call" and frame.f_code.co_name.startswith(PREFIXES) \
                and frame.f_code.co_filename.startswith(roots):
            counts[frame.f_code.co_name] += 1

    threading.setprofile(prof)
    sys.setprofile(prof)
    try:
        assert main(argv) == 0
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    return counts


def test_checks_do_not_grow_with_the_pairs(scene_pairs, monkeypatch):
    import nvrq.encoders

    monkeypatch.setattr(nvrq.encoders, "load_encoder", lambda *a, **k: ToyEncoder())
    counts = {}
    for n in (36, 900):
        table = _tiled(scene_pairs, n)
        out = table.with_name(f"metrics{n}.csv")
        counts[n] = _profiled(["score", str(table), "--out", str(out), "--metrics", METRICS, "--tau", "0.6",
                               "--quiet"])
        assert len(pd.read_csv(out)) == n
    assert counts[36] == counts[900], (counts[36], counts[900])
    assert counts[36]["check_tau"] <= 2
    # the pixel metrics' per-pair checks and the per-batch re-checks are gone
    assert not {"_check", "check_rgb", "check_metric_args"} & set(counts[900])
