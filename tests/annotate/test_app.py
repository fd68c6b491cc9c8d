"""Streamlit AppTest of the rater app: sign-in, training, vote, undo, resume, gold, admin.

Widgets are found by key (annotate/app.py lists them). Expected values come from the
study's own files (manifest training order, items.csv kinds) and the vote store.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from streamlit.testing.v1 import AppTest

import annotate

APP = str(Path(annotate.__file__).with_name("app.py"))


@pytest.fixture
def study(make_study, monkeypatch):
    s = make_study()
    monkeypatch.setenv("ANNOTATE_STUDY", str(s.root))
    return s


@pytest.fixture(autouse=True)
def _instant_presses(monkeypatch):
    """AppTest presses a moment after drawing; the double-press guard would drop them."""
    monkeypatch.setenv("ANNOTATE_MIN_RESPONSE_MS", "0")


def _app(**query) -> AppTest:
    at = AppTest.from_file(APP, default_timeout=20)
    at.query_params.update(query)
    return at.run()


def _btn(at: AppTest, name: str):
    """The voting-panel button ``name`` (keys are ``name-<token of the item on screen>``)."""
    found = [b for b in at.button if b.key and b.key.startswith(name + "-")]
    assert len(found) == 1, [b.key for b in at.button]
    return found[0]


def _has(at: AppTest, name: str) -> bool:
    return any(b.key and b.key.startswith(name + "-") for b in at.button)


def _current(at: AppTest) -> str:
    return at.session_state["shown"][0]


def _page_text(at: AppTest) -> str:
    parts = []
    for kind in ("title", "subheader", "markdown", "caption", "info", "success", "error", "text"):
        parts += [str(e.value) for e in at.get(kind)]
    parts += [e.proto.text for e in at.get("progress")]
    parts += [b.label for b in at.button]
    return "\n".join(parts)


def test_sign_in_by_name_then_instructions(study):
    at = _app()
    # the sign-in page: a name field and its button, nobody signed in, no rating buttons yet
    assert at.button(key="sign_in").label == "Sign in"
    assert at.text_input(key="name_input").value == ""
    assert "rater" not in at.session_state
    assert {b.key for b in at.button} == {"sign_in"}
    at.text_input(key="name_input").input("sim-cheat")  # reserved prefix is refused
    at.button(key="sign_in").click().run()
    assert at.error and "sim-" in at.error[0].value
    at.text_input(key="name_input").input("ann")
    at.button(key="sign_in").click().run()
    assert at.session_state["rater"] == "ann"
    assert at.query_params["rater"] == "ann"  # a reload keeps the rater signed in
    assert "Reference" in at.markdown[0].value and at.button(key="start").label == "Start"


def test_query_param_sign_in_and_training_first(study):
    at = _app(rater="bob")
    at.button(key="start").click().run()
    training = study.manifest.training_order
    assert len(training) == 2
    for i, key in enumerate(training):  # training items first, in study order
        assert _current(at) == key
        assert at.get("progress")[0].proto.text == f"Training {i} / {len(training)}"
        _btn(at, "vote_good").click().run()
    assert study.items.loc[_current(at), "kind"] != "training"
    votes = study.store.votes("bob")
    assert votes["item"].tolist() == training
    assert (votes["response_ms"] >= 0).all()


def test_vote_undo_and_resume_on_a_new_session(study):
    at = _app(rater="cat")
    at.button(key="start").click().run()
    seen = []
    for vote_key in ("vote_good", "vote_bad", "vote_bad", "vote_good"):
        seen.append(_current(at))
        _btn(at, vote_key).click().run()
    assert len(set(seen)) == 4
    after = _current(at)
    _btn(at, "undo").click().run()  # undo the 4th vote: its item comes back
    assert _current(at) == seen[3]
    assert seen[3] not in set(study.store.votes("cat")["item"])
    hist = study.store.history()
    assert hist["action"].tolist() == ["vote"] * 4 + ["undo"]
    _btn(at, "vote_bad").click().run()  # changed answer
    assert _current(at) == after
    # a fresh browser session resumes at exactly the next unrated item, no instructions
    at2 = _app(rater="cat")
    assert not [b for b in at2.button if b.key == "start"]
    assert _current(at2) == after
    v = study.store.votes("cat").set_index("item")["vote"]
    assert v[seen[3]] == 0 and v[seen[0]] == 1 and len(v) == 4


def test_full_run_gold_failures_and_nothing_revealed(study):
    at = _app(rater="dan")
    at.button(key="start").click().run()
    n = 0
    while _has(at, "vote_good"):
        text = _page_text(at)
        for secret in ("toy", "trk-", "+1.00", "-1.00", "offset", "front", "gold", "repeat"):
            assert secret not in text, (secret, text)
        _btn(at, "vote_good").click().run()  # always "good": the gold-bad item fails
        n += 1
    assert "All done" in at.success[0].value
    kinds = study.items["kind"].value_counts()
    # one rater < quota: sees every item once, and its share of the gold pool (issue 38 item 31)
    assert n == len(study.items) - kinds["gold"] + study.gold_per_rater
    from annotate.results import gold_failures, ratings_table

    fails = gold_failures(ratings_table(study))
    assert fails["item_id"].str.startswith("gold-bad:").all()
    assert len(fails) == study.gold_per_rater // 2  # the rater's gold-bad items
    adm = _app(admin=study.admin_token())
    assert [b.key for b in adm.get("download_button")] == ["download_ratings"]
    assert any("gold-bad:" in str(df.value) for df in adm.dataframe)


def test_token_study_refuses_bad_token_and_admin_token(make_study, monkeypatch):
    s = make_study(access="token")
    monkeypatch.setenv("ANNOTATE_STUDY", str(s.root))
    at = _app()
    assert not [b for b in at.button if b.key == "sign_in"]  # no sign-in by name
    at = _app(token="not-a-token")
    assert at.error and "not valid" in at.error[0].value and "rater" not in at.session_state
    s.store.add_rater("eve", plan=s.new_plan("eve"), token="tok-eve-123")
    at = _app(token="tok-eve-123")
    assert at.session_state["rater"] == "eve"
    adm = _app(admin="wrong")
    assert adm.error and not adm.dataframe


def test_break_reminder_every_n_items(make_study, monkeypatch):
    s = make_study(break_every=2, n_training=1)
    monkeypatch.setenv("ANNOTATE_STUDY", str(s.root))
    at = _app(rater="fay")
    at.button(key="start").click().run()
    _btn(at, "vote_good").click().run()  # the training item: not counted
    reminders = []
    for _ in range(4):
        reminders.append(any("break" in i.value for i in at.info))
        _btn(at, "vote_bad").click().run()
    # reminder shown after 2 and 4 rated (non-training) items, i.e. before votes 3 and 5
    assert reminders == [False, False, True, False]
    assert any("break" in i.value for i in at.info)


def test_token_study_ignores_rater_name_link(make_study, monkeypatch):
    s = make_study(access="token")
    monkeypatch.setenv("ANNOTATE_STUDY", str(s.root))
    at = _app(rater="mallory")
    assert "rater" not in at.session_state and "mallory" not in s.store.raters()


def test_second_tab_is_told_the_item_was_rated_elsewhere(study):
    a = _app(rater="gus")
    a.button(key="start").click().run()
    _btn(a, "vote_good").click().run()  # training item 1
    b = _app(rater="gus")  # second tab: same item on screen as the first
    assert _current(b) == _current(a)
    item = _current(a)
    _btn(a, "vote_good").click().run()
    _btn(b, "vote_bad").click().run()  # the other tab's press on the same item
    assert any("another tab" in i.value for i in b.info)
    assert _current(b) == _current(a) != item
    assert study.store.votes("gus").set_index("item").loc[item, "vote"] == 1  # first vote stands


def test_press_for_an_item_no_longer_on_screen_is_dropped(study):
    at = _app(rater="hal")
    at.button(key="start").click().run()
    stale = _btn(at, "vote_good")
    stale.click().run()
    first = study.store.votes("hal")["item"].tolist()
    assert len(first) == 1
    # the same (old) button pressed again, after the next item was chosen: no second vote
    at.session_state["shown"] = (_current(at), 0.0, "not-the-token-on-screen")
    _btn(at, "vote_good").click().run()
    assert study.store.votes("hal")["item"].tolist() == first


def test_user_text_is_plain_in_the_sign_in_error(study):
    at = _app(rater="[Click](http://example.invalid/x) ![i](http://example.invalid/i.png)")
    assert at.error and "http" not in at.error[0].value  # the markdown element never holds it
    assert at.text and "[Click](http://example.invalid/x)" in at.text[0].value  # st.text: plain


def test_unshowable_crop_is_skipped_with_a_short_message(study, caplog):
    import pandas as pd

    items = pd.read_csv(study.root / "items.csv")
    first = study.manifest.training_order[0]
    items.loc[items["key"] == first, "ref_file"] = "../secrets.json"  # tampered crop name
    items.to_csv(study.root / "items.csv", index=False)
    at = _app(rater="ida")
    at.button(key="start").click().run()
    text = _page_text(at)
    assert "skipped" in text and "secrets" not in text and "Traceback" not in text
    assert _current(at) != first and _has(at, "vote_good")
    assert "cannot be shown" in caplog.text  # the details go to the server log


def test_votes_refused_once_the_study_is_rebuilt_under_the_server(study):
    import json

    at = _app(rater="jo")
    at.button(key="start").click().run()
    manifest = json.loads((study.root / "manifest.json").read_text())
    manifest["study_id"] = "rebuilt-1234"
    (study.root / "manifest.json").write_text(json.dumps(manifest))
    _btn(at, "vote_good").click().run()
    assert any("changed on the server" in e.value for e in at.error)
    assert study.store.votes().empty


def test_press_a_moment_after_drawing_is_dropped(study, monkeypatch):
    """The tail of a double press that reached the next item before the rater saw it."""
    monkeypatch.setenv("ANNOTATE_MIN_RESPONSE_MS", "60000")  # any press is "too soon"
    at = _app(rater="kit")
    at.button(key="start").click().run()
    shown = _current(at)
    _btn(at, "vote_good").click().run()
    assert study.store.votes("kit").empty and _current(at) == shown


def _html(at: AppTest) -> str:
    return "\n".join(str(e.proto.body) for e in at.get("html"))


def test_scale_line_names_the_crops_camera_side_and_old_studies_show_none(study, make_study,
                                                                          monkeypatch):
    import pandas as pd

    at = _app(rater="lee")
    at.button(key="start").click().run()
    side = int(study.items.at[_current(at), "crop_side"])
    assert side == 41  # the toy boxes are 31x41 px (inclusive) in both views
    # stored crops are 64 px: 64 / 41 = 1.56 -> "×1.6" until the browser reports its width
    assert f'data-side="{side}"' in _html(at) and "<b>×1.6</b>" in _html(at)
    old = make_study()
    items = pd.read_csv(old.root / "items.csv").drop(columns=["crop_side"])  # an older study
    items.to_csv(old.root / "items.csv", index=False)
    monkeypatch.setenv("ANNOTATE_STUDY", str(old.root))
    at = _app(rater="lee")
    at.button(key="start").click().run()
    assert _has(at, "vote_good") and "data-side" not in _html(at)
