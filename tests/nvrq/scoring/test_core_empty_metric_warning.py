"""Issue 29: a metric that is NaN on every pair (NIQE on crops below its 96 px block) gets a
``warning:`` line wherever a run's summary is printed (``nvrq score`` on a table and on a
dataset, the Evaluator's summary), and ``analyze`` says the metric is undefined for these
crops; before, the run exited 0 with an empty column and said only the NaN counts."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.cli import main as analyze_main
from data_schema import datasets as ds
from nvrq.cli import main

sys.path.insert(0, str(Path(__file__).parents[1] / "engines"))
from fleet_data import BOXES, write_fleet  # noqa: E402

SMALL = [f"o{j}" for j, (x0, y0, x1, y1) in enumerate(BOXES) if min(x1 - x0, y1 - y0) + 1 < 96]


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """The fleet's pairs whose boxes are all below NIQE's 96 px: a table and a dataset."""
    root, pairs_ds = write_fleet(tmp_path_factory.mktemp("small"), n_clips=2, n_frames=1)
    flat = ds.read_dataset(pairs_ds)
    flat = flat[flat["track_id"].isin(SMALL)].reset_index(drop=True)
    flat.to_csv(root / "small.csv", index=False)
    with ds.DatasetWriter(root / "small_ds") as w:
        for clip, g in flat.groupby("clip_id"):
            w.write(clip, g)
    return root, flat


def _warnings(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith("warning:")]


def test_score_warns_of_a_metric_nan_on_every_pair(small, capsys):
    root, flat = small
    assert main(["score", str(root / "small.csv"), "--out", str(root / "m.csv"), "--metrics", "psnr,niqe",
                 "--quiet"]) == 0
    got = pd.read_csv(root / "m.csv")
    assert got["niqe"].isna().all() and got["psnr"].notna().all()  # the case, checked directly
    lines = _warnings(capsys.readouterr().err)
    assert lines == [f"warning: niqe is NaN on all {len(flat)} pairs: undefined for these crops, its "
                     f"column is empty (shorter crop side < 96 px: {len(flat)})"]
    # analyze says so in its report: the metric is undefined for these crops, not a silent gap
    assert analyze_main(["--pairs", str(root / "small.csv"), "--metrics-table", str(root / "m.csv"),
                         "--target", "psnr", "--bootstrap", "0", "--quiet", "--out", str(root / "rep")]) == 0
    html = (root / "rep" / "report.html").read_text()
    assert f"niqe: undefined for every one of these {len(flat)} pairs" in html


def test_sharded_score_warns_too(small, capsys):
    root, flat = small
    assert main(["score", str(root / "small_ds"), "--out", str(root / "m_ds"), "--metrics", "psnr,niqe",
                 "--shard-pairs", "2", "--quiet"]) == 0
    assert ds.read_dataset(root / "m_ds")["niqe"].isna().all()
    assert _warnings(capsys.readouterr().err) == [
        f"warning: niqe is NaN on all {len(flat)} pairs: undefined for these crops, its column is empty"]


def test_evaluator_summary_warns():
    from nvrq.api import Evaluator

    rng = np.random.default_rng(0)
    gt = rng.integers(0, 256, (3, 40, 40, 3), dtype=np.uint8)  # 40 px crops: below NIQE's 96
    ev = Evaluator(metrics="psnr,niqe")
    ev.update(gt, gt // 2 + 10)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        summary = ev.compute()
    assert np.isnan(summary.loc[0, "niqe"]) and np.isfinite(summary.loc[0, "psnr"])
    assert [str(w.message) for w in caught] == [
        "niqe is NaN on all 3 pairs: undefined for these crops, its column is empty"]
