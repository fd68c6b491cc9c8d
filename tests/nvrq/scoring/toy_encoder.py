"""A toy encoder for the plan tests: fast, deterministic, and with the :class:`nvrq.encoders.Encoder`
protocol (``spec``, ``runtime``, ``precision``, ``threads``, ``device``, ``embed``), so the tests
can run ``nvrq score`` on hundreds of pairs without a model's seconds per pass."""

from __future__ import annotations

import numpy as np

from nvrq.encoders import get_spec


class ToyEncoder:
    """Embeds an (B, S, S, 3) uint8 input as its 4x4 block means per channel, centred: (B, 48)."""

    def __init__(self, name: str = "efficientnet-lite0"):
        self.spec = get_spec(name)
        self.runtime, self.precision, self.threads, self.device = "torch", "fp32", 1, "cpu"
        self.calls = 0

    def embed(self, images: np.ndarray) -> np.ndarray:
        self.calls += 1
        x = np.asarray(images, np.float64) / 255.0
        b, s = x.shape[0], x.shape[1]
        k = s // 4
        blocks = x[:, :4 * k, :4 * k].reshape(b, 4, k, 4, k, 3).mean(axis=(2, 4)).reshape(b, -1)
        return (blocks - 0.5).astype(np.float32)
