"""NVRQ (paper Eq. 4) and NVRQ-CA (paper Eq. 5) against hand-worked values."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import cosine

from data_schema.errors import InputError
from nvrq.metrics.formulas import W_LOW, nvrq_ca, nvrq_similarity
from nvrq.metrics.resolve import resolve_metrics


def test_nvrq_is_cosine_mapped_to_unit_interval():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(20, 16)), rng.normal(size=(20, 16))
    # scipy's cosine distance is 1 - cos, so S = (2 - d) / 2
    expected = [(2 - cosine(x, y)) / 2 for x, y in zip(a, b, strict=True)]
    np.testing.assert_allclose(nvrq_similarity(a, b), expected, atol=1e-12)
    np.testing.assert_allclose(nvrq_similarity(a, a), 1.0)
    np.testing.assert_allclose(nvrq_similarity(a, -a), 0.0, atol=1e-12)


def test_nvrq_ca_hand_worked_values():
    tau = 0.65
    # Eq. 5 by hand: S=0.325 < tau -> 0.325 / 0.65 * 0.1 = 0.05;
    # S=0.825 -> 0.1 + 0.9 * ((0.825 - 0.65) / 0.35)^2 = 0.1 + 0.9 * 0.25 = 0.325; S=1 -> 1
    got = nvrq_ca(np.array([0.0, 0.325, 0.825, 1.0]), tau=tau)
    np.testing.assert_allclose(got, [0.0, 0.05, 0.325, 1.0], atol=1e-12)


@pytest.mark.parametrize("tau", [0.5, 0.55, 0.65, 0.7])
def test_nvrq_ca_continuous_at_tau(tau):
    eps = 1e-9
    below, at = nvrq_ca(np.array([tau - eps, tau]), tau=tau)
    assert at == pytest.approx(W_LOW) and below == pytest.approx(W_LOW, abs=1e-8)
    assert W_LOW == 0.1  # paper: w_low = 0.1


def test_nvrq_ca_low_band_and_monotone():
    s = np.linspace(0, 0.65, 1000, endpoint=False)
    low = nvrq_ca(s, tau=0.65)
    assert low.min() >= 0 and low.max() < 0.1
    full = nvrq_ca(np.linspace(0, 1, 2001), tau=0.65)
    assert np.all(np.diff(full) >= 0)


def test_nvrq_ca_rejects_bad_tau():
    with pytest.raises(InputError):
        nvrq_ca(np.array([0.5]), tau=1.0)


def test_resolve_metrics_names_and_errors():
    assert resolve_metrics(["nvrq_ca:clip-b16", "gmsd"], "clip-b16") == ["nvrq_ca:clip-b16", "gmsd"]
    with pytest.raises(InputError, match="^metrics: "):  # the library names its parameter
        resolve_metrics(["musiq"], "clip-b16")
    with pytest.raises(InputError):
        resolve_metrics(["s_det"], "clip-b16")  # a proxy, not computed by score
    with pytest.raises(InputError):
        resolve_metrics(["nvrq:dinov2-small"], "clip-b16")
