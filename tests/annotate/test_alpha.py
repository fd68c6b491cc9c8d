"""Krippendorff's alpha (nominal) against the krippendorff package and crowd-kit's toy data."""

import krippendorff
import numpy as np
import pytest

from annotate.results import alpha_nominal

# Krippendorff (2011) reliability data, the example in the krippendorff package docstring
# (3 coders x 15 units); the package gives 0.691 for nominal data.
KRIPP = np.array(
    [
        [np.nan, np.nan, np.nan, np.nan, np.nan, 3, 4, 1, 2, 1, 1, 3, 3, np.nan, 3],
        [1, np.nan, 2, 1, 3, 3, 4, 3, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan],
        [np.nan, np.nan, 2, 1, 3, 4, 4, np.nan, 2, 1, 1, 3, 3, np.nan, 4],
    ]
)

# crowd-kit's toy YSDA dataset (Toloka/crowd-kit tests/conftest.py, fixture toy_answers_df:
# 5 workers x 5 tasks, w3 did not answer t1); crowd-kit's test_alpha_krippendorff expects
# 0.14219114219114215 for it.
TOY = [
    ("w1", "t1", "no"),
    ("w1", "t2", "yes"),
    ("w1", "t3", "yes"),
    ("w1", "t4", "yes"),
    ("w1", "t5", "yes"),
    ("w2", "t1", "yes"),
    ("w2", "t2", "yes"),
    ("w2", "t3", "no"),
    ("w2", "t4", "yes"),
    ("w2", "t5", "no"),
    ("w3", "t2", "yes"),
    ("w3", "t3", "no"),
    ("w3", "t4", "yes"),
    ("w3", "t5", "no"),
    ("w4", "t1", "yes"),
    ("w4", "t2", "no"),
    ("w4", "t3", "yes"),
    ("w4", "t4", "yes"),
    ("w4", "t5", "no"),
    ("w5", "t1", "no"),
    ("w5", "t2", "no"),
    ("w5", "t3", "no"),
    ("w5", "t4", "yes"),
    ("w5", "t5", "no"),
]


def test_canonical_example_matches_krippendorff_package():
    units = np.tile(np.arange(KRIPP.shape[1]), KRIPP.shape[0])
    a, why = alpha_nominal(units, KRIPP.ravel())
    assert why is None
    assert a == pytest.approx(0.691358024691358, abs=1e-12)
    assert a == pytest.approx(
        krippendorff.alpha(reliability_data=KRIPP, level_of_measurement="nominal")
    )


def test_crowd_kit_toy_data():
    a, why = alpha_nominal([t for _, t, _ in TOY], [lab for _, _, lab in TOY])
    assert a == pytest.approx(0.14219114219114215, rel=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_random_binary_votes_match_package(seed):
    rng = np.random.default_rng(seed)
    data = rng.integers(0, 2, (6, 40)).astype(float)
    data[rng.random(data.shape) < 0.3] = np.nan
    units = np.tile(np.arange(40), 6)
    a, _ = alpha_nominal(units, data.ravel())
    assert a == pytest.approx(
        krippendorff.alpha(reliability_data=data, level_of_measurement="nominal")
    )


def test_undefined_alpha_has_reason():
    assert alpha_nominal(["a", "b"], [1, 0])[1] == "no unit has two values"
    a, why = alpha_nominal(["a", "a", "b", "b"], [1, 1, 1, 1])
    assert np.isnan(a) and why == "only one value occurs"
