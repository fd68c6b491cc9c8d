"""``nvrq pairs`` over many clips: one dataset partitioned by clip_id equal to clip-by-clip runs,
``--keep-going`` with failed.csv, clip attributes, and the dataset reader's bad-input errors."""

from __future__ import annotations

import json
import shutil

import pandas as pd
import pytest

from data_schema import datasets as ds
from data_schema.errors import InputError
from data_schema.scene import load_scene
from nvrq.cli import main
from nvrq.pairs import make_pairs
from nvrq.synth.generate import generate_scene


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """Two tiny synthetic clips in FLEET/s1, FLEET/s2."""
    root = tmp_path_factory.mktemp("fleet")
    for seed in (1, 2):
        generate_scene(root / "fleet" / f"s{seed}", seed=seed, seconds=0.5, offsets=(-1, 0, 1),
                       size=(320, 180), progress=False)
    return root


def _clip_by_clip(dirs, attrs=None):
    frames = []
    for d in dirs:
        scene = load_scene(d)
        if attrs:
            scene.attributes.update(attrs.get(scene.clip_id, {}))
        frames.append(make_pairs(scene, progress=False)[0])
    return pd.concat(frames, ignore_index=True)


def test_dataset_equals_clip_by_clip_runs(fleet, tmp_path, capsys):
    table = tmp_path / "attrs.csv"
    pd.DataFrame({"clip_id": ["synth-000001", "synth-000002"], "weather": ["rain", None],
                  "lighting": ["night", "dusk"]}).to_csv(table, index=False)
    out = tmp_path / "pairs"
    assert main(["pairs", str(fleet / "fleet"), "--out", str(out), "--clip-attributes", str(table),
                 "--quiet"]) == 0
    got = ds.read_dataset(out)
    # expected: make_pairs per clip with the table applied by hand (clip 2 has no weather value)
    want = _clip_by_clip(sorted((fleet / "fleet").iterdir()),
                         {"synth-000001": {"weather": "rain", "lighting": "night"},
                          "synth-000002": {"lighting": "dusk"}})
    assert len(got) == len(want) > 0
    assert set(got["lighting"]) == {"night", "dusk"}
    assert got.loc[got.clip_id == "synth-000002", "weather"].isna().all()
    want = want[got.columns]  # the union of attribute columns, missing values empty
    pd.testing.assert_frame_equal(got.astype(str), want.astype(str), check_dtype=False)
    doc = json.loads((out / ds.MANIFEST).read_text())
    assert doc["rows"] == len(want) and len(doc["files"]) == 2


def test_keep_going_writes_good_clips_and_failed_csv(fleet, tmp_path, capsys):
    fl = tmp_path / "fleet"
    shutil.copytree(fleet / "fleet", fl)
    bad = fl / "s0"
    shutil.copytree(fl / "s1", bad)
    doc = json.loads((bad / "scene.json").read_text())
    doc["clip_id"], doc["cameras"]["front"]["T_sensor_rig"] = "broken", [[1, 0, 0]]
    (bad / "scene.json").write_text(json.dumps(doc))
    out = tmp_path / "pairs"
    assert main(["pairs", str(fl), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "s0/scene.json" in err[0] and "T_sensor_rig" in err[0]
    assert not out.exists() and not list(tmp_path.glob(".pairs.*"))  # nothing half-written
    assert main(["pairs", str(fl), "--out", str(out), "--keep-going", "--quiet"]) == 1
    failed = pd.read_csv(out / "failed.csv")
    assert failed["clip"].tolist() == ["broken"] and "T_sensor_rig" in failed["reason"][0]
    assert sorted(ds.read_dataset(out)["clip_id"].unique()) == ["synth-000001", "synth-000002"]


def test_duplicate_clip_ids_and_file_out_are_errors(fleet, tmp_path, capsys):
    s1 = fleet / "fleet" / "s1"
    assert main(["pairs", str(s1), str(s1), "--out", str(tmp_path / "p"), "--quiet"]) == 2
    assert "a clip id unique in the fleet" in capsys.readouterr().err
    assert main(["pairs", str(fleet / "fleet"), "--out", str(tmp_path / "p.csv"), "--quiet"]) == 2
    assert "--out: expected a folder for several clips" in capsys.readouterr().err


def _write(path, df):
    path.parent.mkdir(parents=True, exist_ok=True)
    df.to_parquet(path, index=False)


def test_reader_errors_missing_shard_unfinished_mixed_no_clip_id(tmp_path):
    a = pd.DataFrame({"pair_id": ["a:1", "a:2"], "psnr": [1.0, 2.0]})
    b = pd.DataFrame({"pair_id": ["b:1"], "psnr": [3.0]})
    with ds.DatasetWriter(tmp_path / "m") as w:
        w.write("a", a)
        w.write("b", b)
    got = ds.read_dataset(tmp_path / "m")
    assert got.columns.tolist() == ["pair_id", "clip_id", "psnr"] and got.clip_id.tolist() == ["a", "a", "b"]
    (tmp_path / "m" / "clip_id=b" / "part-0.parquet").unlink()
    with pytest.raises(InputError, match=r"shard clip_id=b/part-0.parquet: expected all 2 files"):
        ds.read_dataset(tmp_path / "m")
    # a scoring run in progress (plan written, manifest not yet)
    _write(tmp_path / "u" / "clip_id=a" / "shard-00000.parquet", a)
    (tmp_path / "u" / ds.PLAN).write_text("{}")
    with pytest.raises(InputError, match="unfinished scoring run"):
        ds.read_dataset(tmp_path / "u")
    # mixed schemas: psnr is a string in clip b
    _write(tmp_path / "x" / "clip_id=a" / "p.parquet", a)
    _write(tmp_path / "x" / "clip_id=b" / "p.parquet", b.astype({"psnr": str}))
    with pytest.raises(InputError, match=r"column 'psnr': expected one schema across clips"):
        ds.read_dataset(tmp_path / "x")
    # no clip_id partitions
    _write(tmp_path / "n" / "p.parquet", a)
    with pytest.raises(InputError, match="partitioned by clip_id"):
        ds.read_dataset(tmp_path / "n")


def test_dataset_writer_swaps_in_whole_or_not_at_all(tmp_path):
    a = pd.DataFrame({"pair_id": ["a:1"], "psnr": [1.0]})
    with ds.DatasetWriter(tmp_path / "new" / "m") as w:  # the parent folder is created
        w.write("a", a)
    out = tmp_path / "new" / "m"
    assert out.stat().st_mode & 0o777 == 0o755
    with pytest.raises(RuntimeError), ds.DatasetWriter(out) as w:
        w.write("b", a)
        raise RuntimeError
    assert ds.read_dataset(out)["clip_id"].tolist() == ["a"]  # the old dataset stays
    with ds.DatasetWriter(out) as w:
        w.write("b", a)
    assert ds.read_dataset(out)["clip_id"].tolist() == ["b"]  # replaced, no clip a left
    assert [p.name for p in out.parent.iterdir()] == ["m"]  # no .part / .old folders behind
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="an existing file"), ds.DatasetWriter(tmp_path / "f"):
        pass
