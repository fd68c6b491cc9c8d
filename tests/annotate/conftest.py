"""Fixtures for annotate tests: a toy scene/pairs table and studies built from it."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_spec = importlib.util.spec_from_file_location("annotate_toy", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(toy)


@pytest.fixture
def toy_inputs(tmp_path):
    """(scene folder, pairs.csv) of a 4-track, 6-frame, 3-offset toy clip."""
    return toy.make_toy(tmp_path)


@pytest.fixture
def make_study(toy_inputs, tmp_path):
    """Factory: build a study from the toy inputs with the given options."""
    scene, pairs = toy_inputs
    counter = iter(range(1000))

    def _make(**kw):
        from annotate.study import build_study, load_study

        opts = dict(scene=str(scene), tracks=2, frames_per_track=2, n_training=2, n_gold=1,
                    n_repeats=1, size=64, progress=False)
        opts.update(kw)
        return load_study(build_study(tmp_path / f"study{next(counter)}", pairs, **opts))

    return _make
