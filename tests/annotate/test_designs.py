"""The two study designs side by side (issue 26 item 6): one Design protocol, one frozen
StudyOptions, and build_study writing through data_schema.tables.atomic_folder."""

from __future__ import annotations

import dataclasses
import importlib.util
import inspect
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from annotate.binary import BinaryDesign
from annotate.design import Design, StudyOptions
from annotate.pairwise import PairwiseDesign
from annotate.study import DESIGNS, VOTES, _read_pairs, build_study, load_study

_spec = importlib.util.spec_from_file_location("annotate_toy_designs", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(toy)

_PROTOCOL = ("choose_items", "needed_images", "cut_crops", "manifest_extras")


def _opts(**kw) -> StudyOptions:
    """Options as build_study checks them: their defaults, then ``kw``."""
    return StudyOptions(**kw)


@pytest.mark.parametrize("design", [BinaryDesign(), PairwiseDesign()], ids=["binary", "pairwise"])
def test_each_design_has_the_protocols_methods_with_its_signature(design):
    for name in _PROTOCOL:
        assert inspect.signature(getattr(design, name)) == inspect.signature(
            getattr(Design, name).__get__(design)), name
    assert isinstance(design.name, str) and isinstance(design.votes, dict)
    assert DESIGNS[design.name] is not None and VOTES[design.name] == design.votes


def test_the_registry_holds_both_designs_with_their_vote_codes():
    # docs/FORMATS.md §5 (1 good, 0 bad) and §12 (1 left, 2 right, 0 can't tell)
    assert sorted(DESIGNS) == ["binary", "pairwise"]
    assert VOTES == {"binary": {1: "good", 0: "bad"}, "pairwise": {1: "left", 2: "right", 0: "can't tell"}}
    assert (DESIGNS["binary"].crops_per_item, DESIGNS["pairwise"].crops_per_item) == (2, 3)


def test_options_are_frozen():
    opts = _opts(tracks=2)
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.tracks = 3  # type: ignore[misc]


@pytest.mark.parametrize("design, methods", [("binary", None), ("pairwise", {"alpha": 0.5, "beta": 1.5})])
def test_choosing_twice_with_one_seed_gives_the_same_items(tmp_path, design, methods):
    # the options are not changed on the way: a second choice from the same options and seed
    # is the first one again
    scene, pairs_path = toy.make_toy(tmp_path, methods=methods)
    pairs = _read_pairs(pairs_path, str(scene))
    opts = _opts(tracks=2, frames_per_track=2, n_training=2, n_gold=1, n_repeats=2, design=design)
    before = dataclasses.asdict(opts)
    first, second = (DESIGNS[design].choose_items(pairs, np.random.default_rng(3), opts, where="pairs.csv")
                     for _ in range(2))
    assert dataclasses.asdict(opts) == before
    assert [r["key"] for r in first.rows] == [r["key"] for r in second.rows]
    assert first.offsets == second.offsets and first.tracks == second.tracks
    kinds = pd.Series([r["kind"] for r in first.rows]).value_counts().to_dict()
    # 2 tracks x 2 frames x 3 offsets = 12 tests (x 1 pair of methods); gold: a pool of
    # GOLD_POOL x 2 x n_gold = 8 (issue 38 item 31; it was 2 x n_gold, each rater drawing 2)
    assert kinds == {"test": 12, "training": 2, "gold": 8, "repeat": 2}
    assert first.methods == ([] if design == "binary" else ["alpha", "beta"])


def test_a_study_builds_into_a_missing_folder_private_to_its_owner(tmp_path):
    scene, pairs = toy.make_toy(tmp_path / "in")
    out = tmp_path / "new" / "deeper" / "study"  # the parents do not exist yet
    build_study(out, pairs, scene=str(scene), tracks=1, frames_per_track=1, size=32, progress=False)
    assert (out / "manifest.json").is_file()
    # the folder holds the admin token and the votes: owner only, as before (and secrets.json 0600)
    assert out.stat().st_mode & 0o777 == 0o700
    assert (out / "secrets.json").stat().st_mode & 0o777 == 0o600
    assert sorted(p.name for p in out.parent.iterdir()) == ["study"]  # no temporary folder left
    assert load_study(out).manifest.counts["test"] == 3


def test_a_failed_build_leaves_the_empty_target_folder_as_it_was(tmp_path, monkeypatch):
    import annotate.crops

    scene, pairs = toy.make_toy(tmp_path / "in")
    out = tmp_path / "study"
    out.mkdir()  # an empty folder may receive the study

    def fail(*a, **kw):
        raise OSError(28, os.strerror(28), "crop")

    monkeypatch.setattr(annotate.crops, "write_image", fail)
    with pytest.raises(OSError):
        build_study(out, pairs, scene=str(scene), tracks=1, frames_per_track=1, size=32, progress=False)
    assert out.is_dir() and list(out.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in", "study"]
