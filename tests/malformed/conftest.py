"""Fixtures of the malformed-input corpus: the valid ``world`` of inputs, built once per session."""

from __future__ import annotations

import importlib.util
import json
import sqlite3
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

_spec = importlib.util.spec_from_file_location("malformed_world", Path(__file__).with_name("malformed_world.py"))
malformed_world = importlib.util.module_from_spec(_spec)
sys.modules["malformed_world"] = malformed_world  # the corpus modules import it by name
_spec.loader.exec_module(malformed_world)
snapshot, toy, write_scene = malformed_world.snapshot, malformed_world.toy, malformed_world.write_scene


@pytest.fixture(scope="session")
def world(tmp_path_factory) -> Path:
    from annotate.results import ratings_table
    from annotate.simulate import simulate
    from annotate.study import build_study, load_study

    root = tmp_path_factory.mktemp("world")
    write_scene(root / "scene")
    tscene, pairs = toy.make_toy(root / "toy", n_tracks=2, n_frames=3)
    df = pd.read_csv(pairs)
    pd.DataFrame({"pair_id": df["pair_id"], "psnr": np.linspace(20, 30, len(df))}).to_csv(
        root / "metrics.csv", index=False)
    study = build_study(root / "study", pairs, scene=str(tscene), metrics_path=root / "metrics.csv",
                        tracks=2, frames_per_track=2, n_training=1, n_gold=1, n_repeats=1, size=32,
                        progress=False)
    simulate(load_study(study), raters=3, seed=0, progress=False)
    ratings_table(load_study(study)).to_csv(root / "ratings.csv", index=False)
    # a checkpoint of the WAL, so copies of the study are self-contained files
    with sqlite3.connect(study / "votes.sqlite") as con:
        con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    (root.parent / f"{root.name}.hashes.json").write_text(json.dumps(snapshot(root)))
    return root


