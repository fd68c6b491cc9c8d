"""``nvrq score DATASET --out DIR`` on the local engine (no Ray): the rows of clip-by-clip runs,
one shard of one clip in memory at a time, and resumable after a real SIGKILL."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from data_schema import datasets as ds
from nvrq.cli import main
from nvrq.engines import local

sys.path.insert(0, str(Path(__file__).parent))
from fleet_data import METRICS, write_fleet  # noqa: E402

ENCODER = [c for c in METRICS if ":" in c]  # nvrq:E, nvrq_ca:E
PIXEL = [c for c in METRICS if c not in ENCODER]  # full- and no-reference pixel metrics
#: `nvrq score` without Ray: the module is made unimportable before the CLI runs
NO_RAY = "import sys; sys.modules['ray'] = None; from nvrq.cli import main; sys.exit(main(sys.argv[1:]))"


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    return write_fleet(tmp_path_factory.mktemp("localfleet"))  # 2 clips x 4 GT images x 9 pairs


def _args(pairs, out, *extra):
    return ["score", str(pairs), "--out", str(out), "--metrics", ",".join(METRICS), "--tau", "0.6",
            "--shard-pairs", "9", "--quiet", *extra]


def _shards(out: Path) -> list[Path]:
    return sorted(out.glob("clip_id=*/shard-*.parquet"))


@pytest.mark.slow
def test_dataset_gives_the_rows_of_clip_by_clip_runs(fleet, tmp_path, monkeypatch):
    _, pairs_ds = fleet
    calls = []
    driver = local.score_pairs

    def spy(pairs, **kw):  # what the local driver holds at once: one shard of one clip file
        calls.append((kw["where"], len(pairs)))
        return driver(pairs, **kw)

    monkeypatch.setattr(local, "score_pairs", spy)
    assert main(_args(pairs_ds, tmp_path / "m")) == 0
    got = ds.read_dataset(tmp_path / "m")
    assert len(calls) == 8 and max(n for _, n in calls) == 9  # 8 GT images of 9 pairs
    assert len({w for w, _ in calls}) == 2 and all("clip_id=" in w for w, _ in calls)
    monkeypatch.undo()

    # expected: `nvrq score` run separately on each clip's own pairs table
    want = []
    for clip, pairs in ds.iter_clips(pairs_ds):
        pairs.to_parquet(tmp_path / f"{clip}.parquet")
        assert main(_args(tmp_path / f"{clip}.parquet", tmp_path / f"{clip}-m.parquet")) == 0
        one = pd.read_parquet(tmp_path / f"{clip}-m.parquet")
        one.insert(1, "clip_id", clip)
        want.append(one)
    want = pd.concat(want, ignore_index=True)
    assert got.columns.tolist() == want.columns.tolist() == ["pair_id", "clip_id", *METRICS]
    assert got.pair_id.is_unique and sorted(got.pair_id) == sorted(want.pair_id)
    got, want = got.set_index("pair_id").loc[want.pair_id], want.set_index("pair_id")
    assert (got.clip_id == want.clip_id).all()
    for c in PIXEL:  # the same function on the same crops: bit-equal
        np.testing.assert_array_equal(got[c].to_numpy(), want[c].to_numpy())
    for c in ENCODER:
        np.testing.assert_allclose(got[c].to_numpy(), want[c].to_numpy(), atol=1e-6, rtol=0)
    timing = pd.read_csv(tmp_path / "m.timing.csv")
    assert timing.metric.tolist() == METRICS and (timing.pairs == len(got)).all()
    assert (timing.seconds > 0).all()
    plan = json.loads((tmp_path / "m" / ds.PLAN).read_text())
    assert plan["columns"] == METRICS and plan["tau"] == 0.6 and len(plan["shards"]) == 8

    # a finished run started again computes nothing and changes nothing
    before = {p: p.stat().st_mtime_ns for p in _shards(tmp_path / "m")}
    assert main(_args(pairs_ds, tmp_path / "m")) == 0
    assert {p: p.stat().st_mtime_ns for p in _shards(tmp_path / "m")} == before


@pytest.mark.slow
def test_resume_after_sigkill_gives_every_pair_once(fleet, tmp_path):
    _, pairs_ds = fleet
    out = tmp_path / "m"
    proc = subprocess.Popen([sys.executable, "-c", NO_RAY, *_args(pairs_ds, out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not _shards(out) and proc.poll() is None:
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)  # a real kill: no clean-up runs
    _, err = proc.communicate()
    written = _shards(out)
    assert 0 < len(written) < 8, ("the run must die part-way (8 shards planned)", err[-2000:])
    with pytest.raises(ds.InputError, match="unfinished scoring run"):
        ds.read_dataset(out)  # nothing that looks complete
    before = {p: p.stat().st_mtime_ns for p in written}

    rerun = subprocess.run([sys.executable, "-c", NO_RAY, *_args(pairs_ds, out)],
                           capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    assert f"{len(written)} of 8 shards were already written" in rerun.stderr
    assert all(p.stat().st_mtime_ns == t for p, t in before.items())  # only missing shards computed
    resumed = ds.read_dataset(out)
    pairs = ds.read_dataset(pairs_ds)
    assert resumed.pair_id.is_unique and sorted(resumed.pair_id) == sorted(pairs.pair_id)

    assert main(_args(pairs_ds, tmp_path / "full")) == 0
    full = ds.read_dataset(tmp_path / "full")
    pd.testing.assert_frame_equal(resumed, full, check_exact=False, atol=1e-6, rtol=0)


def test_dataset_bad_options_are_one_line_errors(fleet, tmp_path, capsys):
    _, pairs_ds = fleet
    cases = [
        (["--out", str(tmp_path / "m.parquet")], "--out: expected a folder without a suffix for a pairs dataset"),
        (["--out", str(tmp_path / "bad"), "--scene", str(tmp_path)], "--scene: expected the pairs' scene_root"),
        (["--out", str(tmp_path / "bad"), "--shard-pairs", "0"], "--shard-pairs: expected a positive"),
        (["--out", str(tmp_path / "bad"), "--batch-size", "0"], "--batch-size: expected a positive integer"),
    ]
    for args, msg in cases:
        rc = main(["score", str(pairs_ds), "--metrics", "psnr", "--quiet", *args])
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1 and msg in err[0], err
        assert not (tmp_path / "bad").exists()  # nothing planned before the options are checked
    # another run's folder is not silently mixed in
    assert main(["score", str(pairs_ds), "--out", str(tmp_path / "m"), "--metrics", "psnr", "--quiet"]) == 0
    capsys.readouterr()
    rc = main(["score", str(pairs_ds), "--out", str(tmp_path / "m"), "--metrics", "psnr,ssim", "--quiet"])
    assert rc == 2 and "_plan.json: columns: expected the same columns" in capsys.readouterr().err
