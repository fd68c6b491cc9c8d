"""The rater web app (Streamlit; thin: all logic lives in annotate.study/store/results).

Run with ``annotate serve STUDY`` (which sets ``ANNOTATE_STUDY``). Pages:

- sign-in (:mod:`annotate.access`): by name on an open study, ``/?rater=NAME`` directly;
  ``/?token=TOKEN`` on a token study (tokens compared in constant time, a bad one is
  refused); on a crowd study an arrival without a token gets a fresh identity (one per
  participant with the study's participant parameter) and the address becomes
  ``/?token=TOKEN`` (plus the participant parameter), so a reload resumes; the identity is
  stored at its first vote, new identities are rate-limited per client address, an arrival
  at a full study is told so; a finished crowd rater is shown the completion URL, unless it
  rated no test item (the study was full: no link);
- the name field signs in on Enter; the first item after the training says "Training done";
- instructions, then the training items, then the rater's own items: "Reference" left,
  "Rendered" right, drawn as large as the window allows at one scale (shown, e.g. "×3.2";
  :mod:`annotate.layout`), Good (G, blue) / Bad (B, vermillion) / Undo (U) in one row under
  them (each key shown once: Streamlit draws a button's shortcut beside its label), a ``done / total`` progress bar and a break reminder every ``break_every`` items.
  A pairwise study (docs/FORMATS.md §12) shows "Left", "Reference" (middle) and "Right":
  left closer (1 or left arrow), can't tell (0), right closer (2 or right arrow), Undo (U).
  Nothing on the page names the offset, clip, method, metrics or other votes; images are
  served by content hash, never by file name;
- ``/?admin=TOKEN``: the live admin page (:mod:`annotate.admin`, refreshes by itself).

Widget keys (for tests): ``name_input``, ``sign_in``, ``start``, ``download_ratings``,
``completion`` (the completion link of a crowd study); the
voting buttons are ``vote_good-N``, ``vote_bad-N`` and ``undo-N`` (pairwise: ``vote_left-N``,
``vote_tie-N``, ``vote_right-N``, ``undo-N``; the arrow keys press ``vote_left-N`` and
``vote_right-N`` through the page's script, :mod:`annotate.layout`) where ``N`` is an opaque
token of the item on screen (a new one for every displayed item); ``undo-done`` and
``retry`` when no item is on screen.

Robustness rules of the voting panel (a ``st.fragment``: a vote reruns only the panel):

- a press counts only for the item on screen: each button carries the token of the item it
  was drawn for, and a press whose token is not the displayed one (a double press arriving
  after the next item was chosen) is dropped; so is a press less than
  ``ANNOTATE_MIN_RESPONSE_MS`` (environment, default 250) after the item was drawn: no one
  judges a new pair that fast, it is the tail of a double press that a busy browser
  delivered after drawing the next item. The rater is told ("too fast") and the history
  logs it (action ``too_fast``);
- Undo (U) takes back only this browser session's own votes, the last
  :data:`annotate.store.UNDO_DEPTH` at most (each session has a random id); a new session
  of the same rater has nothing to undo;
- an item on screen is claimed for :data:`annotate.store.CLAIM_LEASE_S` seconds (renewed on
  every redraw); when the rater's remaining items are all claimed by others, the page says
  no item is free right now and offers to retry, never "All done";
- a vote is recorded only while the item is the rater's and unvoted (one transaction), so a
  second tab of the same rater is told the item was already rated elsewhere and moves on;
- every displayed image has its own URL: the crop's bytes get a comment keyed by the item
  and side (an HMAC, so it reveals nothing), hence a gold-good item's two sides and a repeat
  and its original never share a URL;
- user-supplied text is shown as plain text (never markdown or HTML);
- storage failures and unreadable crops show a short message (details go to the server
  log) and the panel keeps its buttons; a crop that cannot be shown skips its item;
- a study rebuilt under the server is refused (:meth:`Study.check_current`).
"""

from __future__ import annotations

import logging
import os
import re
import secrets
import sqlite3
import time

import streamlit as st

from annotate.access import (
    ArrivalLimiter,
    CrowdRefused,
    arrival_limiter,
    check_participant,
    client_address,
    crowd_arrival,
    crowd_identity,
    crowd_rater_for_token,
    register_crowd_rater,
)
from annotate.admin import admin_page
from annotate.display import item_display, salted_image
from annotate.layout import page_style, pair_view
from annotate.load import plural
from annotate.store import UNDO_DEPTH
from annotate.study import Study, StudyChanged, load_study
from data_schema.errors import InputError
from data_schema.raters import check_rater_name
from data_schema.vocab import Access, ItemKind, Side, StudyDesign

INSTRUCTIONS = """
You will see pairs of images of the same object. **Reference** (left) is a real camera
photo; **Rendered** (right) is the object as a 3D reconstruction draws it from a nearby
viewpoint, so the angle may differ slightly.

Answer one question: **is the rendered object of good quality?** Rate it *good* when it
looks like a faithful image of the object, *bad* when it is blurred, distorted, broken or
hard to recognise. Do not think too long; your first impression is what we need.

Keys: **G** good, **B** bad, **U** undo the last vote. The first few pairs are training.
Your progress is saved after every vote; you can close the page and come back any time.
"""

#: The titles of a pairwise item's crops, in page order: the two choices around the reference.
PAIRWISE_TITLES = ("Left choice", "Reference (real photo)", "Right choice")

PAIRWISE_INSTRUCTIONS = """
You will see three images of the same object. **Reference** is a real camera photo (in the
middle; on a phone, on top); the **left** and **right choices** are the object as two 3D
reconstructions draw it from a nearby viewpoint, so the angle may differ slightly from the
photo.

Answer one question: **which of the two looks more like the reference?** Judge the quality
of the object: sharpness, shape, colours, missing or broken parts. If you really cannot see a
difference, say so. Do not think too long; your first impression is what we need.

Keys: **1** or **←** left is closer, **2** or **→** right is closer, **0** can't tell,
**U** undo the last answer. The first few are training. Your progress is saved after every
answer; you can close the page and come back any time.
"""


__all__ = ["main", "refuse_uploads", "rater_page", "voting_panel", "sign_in_page", "signed_in_rater",
           "plain", "salted_image"]

log = logging.getLogger("annotate.app")

MSG_STORAGE = ("Your vote could not be saved because of a problem on the server. "
               "Nothing was lost; please press again in a moment.")
MSG_CHANGED = ("This study was changed on the server, so votes cannot be recorded any more. "
               "Please tell the study organiser.")
MSG_ELSEWHERE = "You already rated this pair in another tab or window. Here is your next one."
MSG_SKIPPED = "One pair could not be shown and was skipped. Please go on with the next one."
MSG_UNAVAILABLE = "The study is not available right now. Please try again in a moment."
MSG_TOO_FAST = ("Too fast: that press came before you could look at the images, so it did not "
                "count. Please look at the images, then answer.")
MSG_NO_UNDO = (f"Nothing to undo: Undo takes back only your last {UNDO_DEPTH} answers given "
               "since this page was opened or reloaded.")
MSG_NONE_FREE = ("No item is free right now: other raters are working on the ones left for "
                 "you. Please retry in a minute.")
#: New crowd identities a minute per client address (``annotate serve --arrivals-per-minute``).
ARRIVALS_PER_MINUTE = 20
#: New crowd identities one address may take at once (colleagues behind one router).
ARRIVAL_BURST = 10
MSG_TRAINING_DONE = "Training done — the study starts now. Your answers from here on count."
MSG_STUDY_FULL = ("This study is full: every image pair got all the answers it needs before "
                  "you arrived, so there is nothing left for you to rate. Thank you. (No "
                  "completion code is given; please return the study on your panel's page.)")
_MD_SPECIAL = re.compile(r"([\\`*_{}\[\]()<>#+\-.!|~:/&=])")


def plain(text: object) -> str:
    r"""``text`` with every markdown/HTML character escaped, for use inside ``st.*`` markdown.

    Parameters
    ----------
    text : object
        Any value; converted with ``str``.

    Returns
    -------
    str
        The text with each markdown/HTML special character backslash-escaped.

    >>> print(plain("[Click](http://x.y/) _a_"))
    \[Click\]\(http\:\/\/x\.y\/\) \_a\_
    """
    return _MD_SPECIAL.sub(r"\\\1", str(text))


@st.cache_resource(show_spinner=False)
def _study(root: str) -> Study:
    return load_study(root)


def _sign_in(study: Study, name: str, *, register: bool = True) -> None:
    st.session_state["rater"] = name
    study.plan_for(name, register=register)


def _name_error(given: object) -> None:
    """The sign-in error; the given name appears only as plain text."""
    st.error("Cannot sign in: a name is 1-40 letters, digits, '.', '_' or '-', starting with "
             "a letter or digit (names starting with 'sim-' are reserved).")
    st.text(f"Name given: {given}")


def _token_rater(study: Study, token: str) -> str | None:
    """The rater of a sign-in token: a crowd token carries its rater and an HMAC (no store
    lookup; not registered before its first vote), any other token is looked up in the store."""
    if study.manifest.access == Access.CROWD:
        rater = crowd_rater_for_token(study.admin_token(), token)
        if rater is not None:
            if study.store.plan(rater) is None:  # not voted yet: registered at the first vote
                st.session_state["crowd_pending"] = (token, _returning_participant(study, rater))
                _sign_in(study, rater, register=False)
            else:
                _sign_in(study, rater)
            return rater
    rater = study.store.rater_for_token(token)
    if rater is not None:
        _sign_in(study, rater)
    return rater


def _returning_participant(study: Study, rater: str) -> str | None:
    """The participant id a reloaded crowd address still carries, if it is this rater's."""
    param = study.manifest.participant_param
    given = st.query_params.get(param) if param else None
    if not given:
        return None
    try:
        participant = check_participant(given)
    except CrowdRefused:
        return None
    return participant if crowd_identity(study.admin_token(), participant)[0] == rater else None


def signed_in_rater(study: Study) -> str | None:
    """The rater of this session, signing in from the URL when it says who (else None).

    Parameters
    ----------
    study : Study
        The study being served.

    Returns
    -------
    str or None
        The signed-in rater id; None when the URL names no valid rater (an error is shown
        for an invalid token or name) or the store cannot be read.
    """
    if "rater" in st.session_state:
        return st.session_state["rater"]
    qp = st.query_params
    if study.manifest.access in (Access.TOKEN, Access.CROWD):
        token = qp.get("token")
        if token:
            try:
                rater = _token_rater(study, token)
            except (sqlite3.Error, OSError) as err:  # one message, as a crowd arrival's
                _panel_unavailable(err)
                return None
            if rater is None:
                st.error("This sign-in link is not valid. Please ask for a new one.")
            return rater
        if study.manifest.access == Access.CROWD:
            return _crowd_sign_in(study)
    elif qp.get("rater"):
        try:
            name = check_rater_name(qp["rater"])
        except InputError:
            _name_error(qp["rater"])
            return None
        _sign_in(study, name)
        return name
    return None


def _arrival_limiter() -> ArrivalLimiter | None:
    """The process's limit on new crowd identities per client address (environment
    ``ANNOTATE_ARRIVALS_PER_MINUTE``, set by ``annotate serve --arrivals-per-minute``;
    default :data:`ARRIVALS_PER_MINUTE`; 0: no limit)."""
    return arrival_limiter(float(os.environ.get("ANNOTATE_ARRIVALS_PER_MINUTE", ARRIVALS_PER_MINUTE)),
                           burst=ARRIVAL_BURST)


def _crowd_sign_in(study: Study) -> str | None:
    """A crowd arrival: its identity, the address rewritten to carry it (a reload resumes).
    Nothing is stored until the rater's first vote (:func:`_on_vote`)."""
    ctx = st.context
    client = client_address(getattr(ctx, "ip_address", None), ctx.headers.get("X-Forwarded-For"))
    try:
        rater, token, participant = crowd_arrival(study, st.query_params.to_dict(),
                                                  limiter=_arrival_limiter(), client=client)
    except CrowdRefused as why:
        st.session_state["crowd_refused"] = str(why)
        return None
    except (sqlite3.Error, OSError):
        log.exception("annotate app: a crowd arrival could not be admitted")
        st.session_state["crowd_refused"] = MSG_UNAVAILABLE
        return None
    param = study.manifest.participant_param
    st.query_params.from_dict({"token": token, **({param: participant} if participant else {})})
    st.session_state["crowd_pending"] = (token, participant)
    _sign_in(study, rater, register=False)
    return rater


def _register_pending(study: Study, rater: str) -> None:
    """Store a crowd rater at its first vote (plan, token digest, participant id)."""
    pending = st.session_state.pop("crowd_pending", None)
    if pending is not None:
        register_crowd_rater(study, rater, token=pending[0], participant=pending[1])


def _on_sign_in(study: Study) -> None:
    given = st.session_state.get("name_input", "")
    try:
        name = check_rater_name(given)
    except InputError:
        st.session_state["sign_in_error"] = given
        return
    _sign_in(study, name)
    st.query_params["rater"] = name


def sign_in_page(study: Study) -> None:
    """Draw the sign-in page: a crowd refusal, a request for a personal link, or a name form.

    Parameters
    ----------
    study : Study
        The study being served; only an ``"open"`` study shows the name form.
    """
    st.title("Image quality study")
    if "crowd_refused" in st.session_state:
        st.info(st.session_state.pop("crowd_refused"))
        return
    if study.manifest.access != Access.OPEN:
        if not st.query_params.get("token"):
            st.info("Please open the personal link you received to take part.")
        return
    with st.form("sign_in_form", border=False, enter_to_submit=True):  # Enter signs in
        st.text_input("Your name (letters, digits, '.', '_', '-')", key="name_input")
        st.form_submit_button("Sign in", key="sign_in", type="primary", on_click=_on_sign_in,
                              args=(study,))
    if "sign_in_error" in st.session_state:
        _name_error(st.session_state.pop("sign_in_error"))


def _shown() -> tuple:
    """(item key, shown at, token) of the item on screen, or Nones."""
    return st.session_state.get("shown", (None, None, None))


def _session_id() -> str:
    """This browser session's random id (logged with its votes; Undo reaches only these)."""
    return st.session_state.setdefault("session_id", secrets.token_hex(8))


def _min_response_ms() -> int:
    return int(os.environ.get("ANNOTATE_MIN_RESPONSE_MS", "250"))


def _storage_failed(what: str) -> None:
    log.exception("annotate app: %s failed", what)
    st.session_state["notice"] = ("error", MSG_STORAGE)


def _on_vote(study: Study, rater: str, key: str, token: str, vote: int) -> None:
    shown_key, shown_at, shown_token = _shown()
    if token != shown_token or key != shown_key:  # a press for an item no longer on screen
        return
    rt = int(round((time.time() - shown_at) * 1000))
    if rt < _min_response_ms():  # drawn a moment ago: the rater has not seen it yet
        log.info("annotate app: press %d ms after drawing dropped (rater %s)", rt, rater)
        _on_current_study(study, lambda: study.store.record_too_fast(
            rater, key, vote, response_ms=rt, session=_session_id()),
            refused="too-fast log", doing="logging a too-fast press")
        st.session_state.setdefault("notice", ("warning", MSG_TOO_FAST))
        return
    def record() -> str:
        _register_pending(study, rater)  # a crowd rater is stored at its first vote
        return study.store.record_shown_vote(rater, key, vote, response_ms=rt, session=_session_id())

    ok, status = _on_current_study(
        study, record,
        refused="vote", doing="recording a vote",
    )
    if not ok:
        return
    st.session_state["shown"] = (None, None, None)  # a repeated press of this token is dropped
    if status != "recorded":
        st.session_state["notice"] = ("info", MSG_ELSEWHERE)


def _on_undo(study: Study, rater: str, token: str) -> None:
    if token != _shown()[2]:
        return
    ok, item = _on_current_study(
        study, lambda: study.store.undo_last(rater, session=_session_id()), refused="undo",
        doing="undoing a vote")
    if ok:
        st.session_state["shown"] = (None, None, None)
        if item is None:
            st.session_state["notice"] = ("info", MSG_NO_UNDO)


def _on_current_study(study: Study, action, *, refused: str, doing: str) -> tuple[bool, object]:
    """``action()`` if the study on disk is still the one served; (succeeded, its result).

    A changed study or a storage failure leaves a notice for the rater instead.
    """
    try:
        study.check_current()
        return True, action()
    except StudyChanged:
        log.exception("annotate app: %s refused", refused)
        st.session_state["notice"] = ("error", MSG_CHANGED)
    except (sqlite3.Error, OSError):
        _storage_failed(doing)
    return False, None


def _show_notice() -> None:
    kind, text = st.session_state.pop("notice", (None, None))
    if kind == "error":
        st.error(text)
    elif kind == "warning":
        st.warning(text)
    elif kind == "info":
        st.info(text)


def _progress_bar(study: Study, item_kind: str, prog: dict) -> None:
    if item_kind == ItemKind.TRAINING:
        n, i = prog["training_total"], prog["training_done"]
        st.progress(i / max(n, 1), text=f"Training {i} / {n}")
        return
    done, total = prog["done"], max(prog["total"], 1)
    if prog["training_total"] and not done:  # the first item after the training
        st.success(MSG_TRAINING_DONE)
    st.progress(min(done / total, 1.0), text=f"{done} / {total}")
    every = int(study.manifest.break_every)
    if done and done % every == 0:
        st.info(f"You have rated {plural(done, 'pair')}. Consider a short break; your progress "
                "is saved.")


def _slots(study: Study, key: str, rater: str) -> tuple[tuple[str, str], ...]:
    """(position, items.csv file column) of each crop shown, in page order: Reference and
    Rendered; pairwise: left render, Reference, right render (A's side from the rater's plan)."""
    if study.design != StudyDesign.PAIRWISE:
        return (("ref", "ref_file"), ("ren", "ren_file"))
    a_left = study.plan_for(rater)["sides"][key] == Side.LEFT
    left, right = ("a_file", "b_file") if a_left else ("b_file", "a_file")
    return (("left", left), ("ref", "ref_file"), ("right", right))


def _display_images(study: Study, key: str, rater: str) -> tuple[bytes, ...]:
    """The item's crops in page order, each salted with an HMAC of (study, item, position,
    rater) (files read once per process, :func:`annotate.display.item_display`)."""
    return item_display(study).crops(key, _slots(study, key, rater), rater)


def _next_on_screen(study: Study, rater: str) -> tuple[str | None, dict, tuple | None]:
    """(next item, progress, its two images); an item whose crops fail is skipped and logged."""
    while True:
        study.check_current()
        key, prog = study.next_with_progress(rater)
        if key is None:
            return None, prog, None
        try:
            return key, prog, _display_images(study, key, rater)
        except (InputError, OSError, ValueError, KeyError):
            log.exception("annotate app: item %s of rater %s cannot be shown; skipped", key, rater)
            study.store.skip(rater, key, reason="crop cannot be shown")
            st.session_state["notice"] = ("info", MSG_SKIPPED)


def _panel_unavailable(err: Exception) -> None:
    log.error("annotate app: voting panel unavailable", exc_info=err)
    st.error(MSG_CHANGED if isinstance(err, StudyChanged) else MSG_UNAVAILABLE)
    st.button("Try again", key="retry")


@st.fragment
def voting_panel(study: Study, rater: str) -> None:
    """The item on screen, progress and the vote buttons; a press reruns only this panel.

    Parameters
    ----------
    study : Study
        The study being served; its store picks the next item and records the votes.
    rater : str
        Whose plan is followed and whose votes are written.
    """
    try:
        key, prog, images = _next_on_screen(study, rater)
    except (StudyChanged, sqlite3.Error, OSError) as err:
        _show_notice()
        _panel_unavailable(err)
        return
    _show_notice()
    if key is None:
        _no_item(study, rater, prog)
        return
    facts = item_display(study)  # per-item facts as dicts, made once per process
    _progress_bar(study, facts.kind[key], prog)
    if _shown()[0] != key:
        st.session_state["shown"] = (key, time.time(), secrets.token_hex(6))
    token = _shown()[2]
    pairwise = study.design == StudyDesign.PAIRWISE
    pair_view(PAIRWISE_TITLES if pairwise else ("Reference", "Rendered"), images,
              crop_side=facts.crop_side.get(key),
              display_size=int(study.manifest.display_size), token=token)
    if pairwise:
        _pairwise_buttons(study, rater, key, token)
        return
    with st.container(horizontal=True, horizontal_alignment="center", key="vote_row"):
        st.button("Good", key=f"vote_good-{token}", shortcut="g", type="primary",
                  on_click=_on_vote, args=(study, rater, key, token, 1))
        st.button("Bad", key=f"vote_bad-{token}", shortcut="b", type="primary",
                  on_click=_on_vote, args=(study, rater, key, token, 0))
        st.button("Undo", key=f"undo-{token}", shortcut="u", on_click=_on_undo,
                  args=(study, rater, token))


def _no_item(study: Study, rater: str, prog: dict) -> None:
    """Nothing to show: "All done", or, while others' claims hold the rater's remaining
    items, "no item is free right now" with a retry button."""
    try:
        waiting = study.waiting(rater)
    except (sqlite3.Error, OSError) as err:
        _panel_unavailable(err)
        return
    if waiting:
        st.info(MSG_NONE_FREE)
        st.button("Retry", key="retry")
    elif _rated_no_test(study, rater):  # arrived when every test item had its votes
        st.info(MSG_STUDY_FULL)
    else:
        st.success(f"All done, thank you, {plain(rater)}! ({prog['done']} / {prog['total']})")
        if study.manifest.completion_url:
            st.link_button("Finish and return to the panel", study.manifest.completion_url,
                           type="primary", key="completion")
    token = st.session_state["shown"] = (None, None, "done")
    st.button("Undo last vote", key="undo-done", shortcut="u", on_click=_on_undo,
              args=(study, rater, token[2]))


def _rated_no_test(study: Study, rater: str) -> bool:
    """Whether the rater finished without a single test item (the study was full)."""
    voted = study.store.rater_state(rater)[1]
    kinds = item_display(study).kind
    return not any(kinds.get(k) == ItemKind.TEST for k in voted)


def _pairwise_buttons(study: Study, rater: str, key: str, token: str) -> None:
    """Left closer (1), can't tell (0), right closer (2), undo (U) in one row (the arrow keys
    press the side buttons through the page's script, :data:`annotate.layout._PAGE_JS`)."""
    with st.container(horizontal=True, horizontal_alignment="center", key="vote_row"):
        st.button("◀ Left is closer (or ←)", key=f"vote_left-{token}", shortcut="1",
                  on_click=_on_vote, args=(study, rater, key, token, 1))
        st.button("Can't tell", key=f"vote_tie-{token}", shortcut="0",
                  on_click=_on_vote, args=(study, rater, key, token, 0))
        st.button("Right is closer (or →) ▶", key=f"vote_right-{token}", shortcut="2",
                  on_click=_on_vote, args=(study, rater, key, token, 2))
        st.button("Undo", key=f"undo-{token}", shortcut="u", on_click=_on_undo,
                  args=(study, rater, token))


def rater_page(study: Study, rater: str) -> None:
    """Draw a rater's page: the instructions and a Start button before the first vote, then
    the voting panel.

    Parameters
    ----------
    study : Study
        The study being served.
    rater : str
        The signed-in rater id.
    """
    if not st.session_state.get("started"):
        try:
            fresh = study.store.votes(rater).empty
        except (sqlite3.Error, OSError) as err:
            _panel_unavailable(err)
            return
        if fresh:
            st.title("Image quality study")
            st.markdown(PAIRWISE_INSTRUCTIONS if study.design == StudyDesign.PAIRWISE else INSTRUCTIONS)
            st.button("Start", key="start", type="primary",
                      on_click=lambda: st.session_state.update(started=True))
            return
        st.session_state["started"] = True
    page_style()  # outside the panel: drawn once per page, not again with every vote
    voting_panel(study, rater)


def refuse_uploads() -> bool:
    """Make this server's upload store keep no file (the app has no uploader; see
    :mod:`annotate.serve_app`). Idempotent; False where no Streamlit server runs (tests).

    Returns
    -------
    bool
        Whether a running server's upload store was closed.
    """
    from streamlit.runtime import Runtime

    if not Runtime.exists():
        return False
    mgr = Runtime.instance().uploaded_file_mgr
    if not getattr(mgr, "_annotate_closed", False):
        def refuse(session_id, file):  # noqa: ARG001 (the store's signature)
            log.warning("annotate app: an upload was refused (the app has no uploader)")

        mgr.add_file = refuse
        mgr._annotate_closed = True
    return True


def main() -> None:
    """Run the app for the study named by ``ANNOTATE_STUDY``: the admin page, the sign-in
    page or the rater's page."""
    st.set_page_config(page_title="Image quality study", layout="wide")
    root = os.environ.get("ANNOTATE_STUDY")
    if not root:
        st.error("No study: start the app with 'annotate serve STUDY'.")
        return
    study = _study(root)
    if st.query_params.get("admin"):
        admin_page(study, st.query_params["admin"])
        return
    rater = signed_in_rater(study)
    if rater is None:
        sign_in_page(study)
        return
    rater_page(study, rater)


if __name__ == "__main__":  # streamlit runs the script as __main__; imports do nothing
    main()
