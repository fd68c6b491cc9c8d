"""Simulated rating panels for the screening tests (issue 14 acceptance).

A panel: ``n_items`` test items with a latent good/bad truth (good with ``good_rate``);
five honest raters who vote the truth with accuracies ``HONEST_ACCURACY`` (a flip with
probability ``1 - accuracy``, independently per vote), then a random rater (good with
probability 0.5), an inverted rater (the opposite of an accuracy-0.9 vote) and a
straight-lining rater (the same button on every item; which button is drawn per panel).
"""

from __future__ import annotations

import numpy as np

HONEST_ACCURACY = (0.95, 0.92, 0.89, 0.86, 0.83)
BAD = ("random", "inverted", "straight")
N_RATERS = len(HONEST_ACCURACY) + len(BAD)


def panels(seeds, good_rate: float, n_items: int):
    """(len(seeds), 8, n_items) float 0/1 votes and (len(seeds), n_items) truth."""
    out, truth = [], []
    for seed in seeds:
        rng = np.random.default_rng([seed, int(good_rate * 100), n_items])
        z = (rng.random(n_items) < good_rate).astype(float)
        rows = [np.where(rng.random(n_items) < a, z, 1 - z) for a in HONEST_ACCURACY]
        rows.append((rng.random(n_items) < 0.5).astype(float))
        rows.append(1 - np.where(rng.random(n_items) < 0.9, z, 1 - z))
        rows.append(np.full(n_items, float(rng.random() < 0.5)))
        out.append(np.stack(rows))
        truth.append(z)
    return np.stack(out), np.stack(truth)
