"""Shared pieces of the learned-metric tests: the LPIPS authors' example images, the skip
(naming the install command) where a metric's weights are absent, and the cache reset
(tests/nvrq/metrics/conftest.py's ``no_weights`` hides every installed weight file)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

#: ../shared beside the repository, as tests/conftest.py finds it
SHARED_IMGS = Path(__file__).resolve().parents[3].parent / "shared" / "ref" / "lpips" / "imgs"
#: the LPIPS authors' example pairs (../shared/ref/lpips/README.md)
PAIRS = (("ex_ref.png", "ex_p0.png"), ("ex_ref.png", "ex_p1.png"),
         ("ex_dir0/0.png", "ex_dir1/0.png"), ("ex_dir0/1.png", "ex_dir1/1.png"))


def image(name: str) -> np.ndarray:
    """One example image, (64, 64, 3) uint8 RGB."""
    from PIL import Image

    if not SHARED_IMGS.is_dir():
        pytest.skip("../shared/ref/lpips is absent")
    return np.asarray(Image.open(SHARED_IMGS / name).convert("RGB"))


def clear_caches() -> None:
    """Forget every loaded weight (the weights module's, the networks' and the metrics')."""
    from nvrq.metrics.learned import dists, lpips, nets, weights

    for fn in (weights._component, nets.tensors, lpips._model, dists._model):
        fn.cache_clear()


def require(*metrics: str) -> None:
    """Skip, with the install command as the reason, unless the metrics' weights load."""
    from data_schema.errors import InputError
    from nvrq.metrics import column_info

    for m in metrics:
        try:
            column_info(m).prepare()
        except InputError as e:  # its message names the install command
            pytest.skip(f"weights of {m} not installed: {e}")
