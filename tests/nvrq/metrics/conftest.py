"""Fixtures of the metric tests."""

from __future__ import annotations

import pytest

from tests.nvrq.metrics.learned_helpers import clear_caches


@pytest.fixture
def no_weights(monkeypatch, tmp_path):
    """No installed package, torchvision cache or user folder holds any weight file."""
    from nvrq.metrics.learned import weights

    monkeypatch.setattr(weights, "_dist_file", lambda dist, rel: None)
    monkeypatch.setenv("TORCH_HOME", str(tmp_path / "torch"))
    monkeypatch.delenv(weights.WEIGHTS_ENV, raising=False)
    clear_caches()
    yield
    clear_caches()
