"""The live admin page (annotate/admin.py) under Streamlit's AppTest.

It must render on a plain install (krippendorff is a runtime dependency), show every
rater's progress with the screening numbers of annotate.screening, and pick up a vote cast
elsewhere on its next run (the browser test checks the run happens by itself).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from streamlit.testing.v1 import AppTest

import annotate
from annotate.admin import REFRESH_S
from annotate.results import ratings_table
from annotate.screening import rater_table, screen
from annotate.simulate import simulate

APP = str(Path(annotate.__file__).with_name("app.py"))


@pytest.fixture
def study(make_study, monkeypatch):
    s = make_study(tracks=4, frames_per_track=6, votes_per_item=6, n_gold=2)
    monkeypatch.setenv("ANNOTATE_STUDY", str(s.root))
    simulate(s, raters=4, seed=3, progress=False)
    return s


def _admin(study) -> AppTest:
    at = AppTest.from_file(APP, default_timeout=30)
    at.query_params["admin"] = study.admin_token()
    return at.run()


def _raters(at: AppTest):
    return next(df.value for df in at.dataframe if "flags" in df.value.columns)


def test_admin_page_shows_live_screening_and_new_votes(study):
    at = _admin(study)
    assert not at.exception
    assert f"refreshes every {REFRESH_S:g} s" in at.caption[0].value
    table = _raters(at).set_index("rater_id")
    # the page shows the same numbers and flags as the screening rule computes directly
    want = screen(rater_table(ratings_table(study)), use_rule=False).set_index("rater_id")
    assert table.loc[want.index, "flags"].tolist() == want["flags"].tolist()
    assert table.loc[want.index, "youden_j"].tolist() == pytest.approx(want["youden_j"].tolist())
    assert "no skill shown" in table.loc["sim-careless", "flags"]
    assert at.metric[0].value != "undefined"  # Krippendorff's alpha from the package
    before = int(table.loc["sim-1", "test"])
    # a vote arrives from another session: the next run of the page shows it
    study.store.add_rater("zoe", plan=study.new_plan("zoe"))
    key = study.next_item("zoe")
    study.store.record_vote("zoe", key, 1, response_ms=900)
    import annotate.admin

    annotate.admin._TABLES.clear()  # issue 38: tables are kept TABLES_S seconds; that time passes
    at.run()
    table = _raters(at).set_index("rater_id")
    assert "zoe" in table.index and int(table.loc["sim-1", "test"]) == before
    assert int(table.loc["zoe", ["training", "test", "gold", "repeat"]].sum()) == 1


def test_live_raters_reads_the_ratings_once(study, monkeypatch):
    from annotate import admin, results
    ratings = ratings_table(study)
    want = admin.live_raters(study, ratings)
    assert want.drop(columns=admin._LIVE_COLS[1:]).equals(results.rater_progress(study))
    calls = []
    monkeypatch.setattr(results, "ratings_table", lambda s: calls.append(s) or ratings)
    assert admin.live_raters(study, ratings).equals(want) and calls == []
