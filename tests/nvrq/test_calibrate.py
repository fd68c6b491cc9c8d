"""tau calibration: unrelated-pair selection, the median rule, the user config."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from data_schema.errors import InputError
from nvrq.calibrate import (
    calibrate_tau,
    config_path,
    read_tau_config,
    require_tau,
    unrelated_pairs,
    write_tau,
)
from nvrq.cli import main
from nvrq.crops import cut_box, encoder_input, read_rgb
from nvrq.encoders import load_encoder


def test_unrelated_pairs_matches_brute_force():
    rng = np.random.default_rng(0)
    tracks = rng.choice(list("abcdef"), 30)
    classes = np.array([{"a": "car", "b": "car", "c": "ped", "d": "truck", "e": "ped", "f": "car"}[t]
                        for t in tracks])
    i, j = unrelated_pairs(tracks, classes, max_pairs=10**6)
    brute = [(a, b) for a, b in itertools.combinations(range(30), 2)
             if tracks[a] != tracks[b] and classes[a] != classes[b]]
    assert list(zip(i.tolist(), j.tolist(), strict=True)) == brute
    i2, _ = unrelated_pairs(tracks, classes, max_pairs=7, seed=1)
    assert len(i2) == 7
    i3, j3 = unrelated_pairs(tracks, classes, max_pairs=10**6, allow_same_class=True)
    assert len(i3) == sum(tracks[a] != tracks[b] for a, b in itertools.combinations(range(30), 2))


def test_config_roundtrip_and_tau_priority(tmp_path, monkeypatch):
    cfg = tmp_path / "tau.json"
    monkeypatch.setenv("NVRQ_CONFIG", str(cfg))
    assert config_path() == cfg
    assert require_tau("dinov2-small", registry_tau=0.65) == (0.65, "registry")
    write_tau(cfg, "dinov2-small", 0.6, rule="median")
    write_tau(cfg, "clip-b16", 0.72)
    assert read_tau_config(cfg)["dinov2-small"] == {"tau": 0.6, "rule": "median"}
    assert require_tau("dinov2-small", registry_tau=0.65) == (0.6, str(cfg))
    assert require_tau("dinov2-small", tau=0.5) == (0.5, "argument")  # the library names no flag
    cfg.write_text(json.dumps({"clip-b16": {"tau": 3}}))
    with pytest.raises(InputError, match="clip-b16.tau"):
        require_tau("clip-b16")
    cfg.write_text("{not json")
    with pytest.raises(InputError, match="JSON"):
        read_tau_config(cfg)


def test_calibrate_is_median_of_unrelated_gt_similarities(tiny_scene):
    root, pairs = tiny_scene
    enc = load_encoder("efficientnet-lite0")
    cal = calibrate_tau(pairs, enc, progress=False)
    # reference: 6 GT crops (2 frames x 3 objects of 3 classes); unrelated pairs are those of
    # different objects: 2*2 per object pair x 3 object pairs = 12; embed each by hand.
    crops = pairs.drop_duplicates(["track_id", "timestamp_us"]).reset_index(drop=True)
    feats = enc.embed(np.stack([encoder_input(cut_box(read_rgb(root / r.gt_path),
                                                      (r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1)), 224)
                                for r in crops.itertuples()])).astype(np.float64)
    s = [(feats[a] @ feats[b] / np.linalg.norm(feats[a]) / np.linalg.norm(feats[b]) + 1) / 2
         for a, b in itertools.combinations(range(6), 2) if crops.track_id[a] != crops.track_id[b]]
    assert len(cal.s) == len(s) == 12
    np.testing.assert_allclose(np.sort(cal.s), np.sort(s), atol=2e-5)
    assert cal.tau == pytest.approx(np.median(s), abs=2e-5)
    assert "median" in cal.summary()


def test_calibrate_cli_writes_config(tiny_scene, tmp_path, capsys):
    root, pairs = tiny_scene
    pairs.to_csv(tmp_path / "pairs.csv", index=False)
    cfg = tmp_path / "cfg" / "tau.json"
    assert main(["calibrate-tau", str(tmp_path / "pairs.csv"), "--write-config", "--config", str(cfg),
                 "--quiet"]) == 0
    tau = json.loads(cfg.read_text())["efficientnet-lite0"]["tau"]
    assert 0 < tau < 1 and "recommended tau" in capsys.readouterr().out
    one_class = pairs.assign(label_class="automobile")
    one_class.to_csv(tmp_path / "one.csv", index=False)
    assert main(["calibrate-tau", str(tmp_path / "one.csv"), "--quiet"]) == 2
    assert "--allow-same-class" in capsys.readouterr().err
