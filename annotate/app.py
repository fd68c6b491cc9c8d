"""The rater web app (Streamlit; thin: all logic lives in annotate.study/store/results).

Run with ``annotate serve STUDY`` (which sets ``ANNOTATE_STUDY``). Pages:

- sign-in: by name on an open study, ``/?rater=NAME`` directly; ``/?token=TOKEN`` on a
  token study (tokens compared in constant time, a bad one is refused);
- instructions, then the training items, then the rater's own items: "Reference" left,
  "Rendered" right, Good (G) / Bad (B) / Undo (U), a ``done / total`` progress bar and a
  break reminder every ``break_every`` items. Nothing on the page names the offset, clip,
  method, metrics or other votes; images are served by content hash, never by file name;
- ``/?admin=TOKEN``: progress per rater, GVF histogram, Krippendorff's alpha, gold
  failures and a ``ratings.csv`` download.

Widget keys (for tests): ``name_input``, ``sign_in``, ``start``, ``vote_good``,
``vote_bad``, ``undo``, ``download_ratings``.
"""

from __future__ import annotations

import hmac
import os
import time

import numpy as np
import pandas as pd
import streamlit as st

from annotate.results import gold_failures, gvf_table, nominal_alpha, rater_progress, ratings_table
from annotate.study import Study, crop_path, load_study
from data_schema.errors import InputError
from data_schema.raters import check_rater_name

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


@st.cache_resource(show_spinner=False)
def _study(root: str) -> Study:
    return load_study(root)


def _sign_in(study: Study, name: str) -> None:
    st.session_state["rater"] = name
    study.plan_for(name)


def signed_in_rater(study: Study) -> str | None:
    """The rater of this session, signing in from the URL when it says who (else None)."""
    if "rater" in st.session_state:
        return st.session_state["rater"]
    qp = st.query_params
    if study.manifest["access"] == "token":
        token = qp.get("token")
        if token:
            rater = study.store.rater_for_token(token)
            if rater is None:
                st.error("This sign-in link is not valid. Please ask for a new one.")
                return None
            _sign_in(study, rater)
            return rater
    elif qp.get("rater"):
        try:
            name = check_rater_name(qp["rater"])
        except InputError as err:
            st.error(f"Cannot sign in: {err}")
            return None
        _sign_in(study, name)
        return name
    return None


def _on_sign_in(study: Study) -> None:
    try:
        name = check_rater_name(st.session_state.get("name_input", ""))
    except InputError as err:
        st.session_state["sign_in_error"] = str(err)
        return
    _sign_in(study, name)
    st.query_params["rater"] = name


def sign_in_page(study: Study) -> None:
    st.title("Image quality study")
    if study.manifest["access"] == "token":
        if not st.query_params.get("token"):
            st.info("Please open the personal link you received to take part.")
        return
    st.text_input("Your name (letters, digits, '.', '_', '-')", key="name_input")
    st.button("Sign in", key="sign_in", on_click=_on_sign_in, args=(study,))
    if "sign_in_error" in st.session_state:
        st.error(st.session_state.pop("sign_in_error"))


def _on_vote(study: Study, rater: str, key: str, vote: int) -> None:
    if study.next_item(rater) != key:  # a stale click (double press, other tab): ignore it
        return
    shown_key, shown_at = st.session_state.get("shown", (None, None))
    rt = int(round((time.time() - shown_at) * 1000)) if shown_key == key else None
    study.store.record_vote(rater, key, vote, response_ms=rt)
    st.session_state["started"] = True


def _on_undo(study: Study, rater: str) -> None:
    study.store.undo_last(rater)
    st.session_state["started"] = True


def rater_page(study: Study, rater: str) -> None:
    if not st.session_state.get("started"):
        if study.store.votes(rater).empty:
            st.title("Image quality study")
            st.markdown(INSTRUCTIONS)
            st.button("Start", key="start", type="primary",
                      on_click=lambda: st.session_state.update(started=True))
            return
        st.session_state["started"] = True
    key = study.next_item(rater)
    prog = study.progress(rater)
    if key is None:
        st.success(f"All done, thank you, {rater}! ({prog['done']} / {prog['total']})")
        st.button("Undo last vote (U)", key="undo", shortcut="u", on_click=_on_undo,
                  args=(study, rater))
        return
    item = study.items.loc[key]
    if item["kind"] == "training":
        n, i = prog["training_total"], prog["training_done"]
        st.progress(i / max(n, 1), text=f"Training {i} / {n}")
    else:
        done, total = prog["done"], max(prog["total"], 1)
        st.progress(min(done / total, 1.0), text=f"{done} / {total}")
        every = int(study.manifest.get("break_every", 50))
        if done and done % every == 0:
            st.info(f"You have rated {done} pairs. Consider a short break; your progress is saved.")
    if st.session_state.get("shown", (None,))[0] != key:
        st.session_state["shown"] = (key, time.time())
    left, right = st.columns(2)
    size = int(study.manifest.get("display_size", 320))
    with left:
        st.subheader("Reference")
        st.image(str(crop_path(study.root, item["ref_file"])), width=size)
    with right:
        st.subheader("Rendered")
        st.image(str(crop_path(study.root, item["ren_file"])), width=size)
    b1, b2, b3 = st.columns(3)
    with b1:
        st.button("Good (G)", key="vote_good", shortcut="g", type="primary", on_click=_on_vote,
                  args=(study, rater, key, 1))
    with b2:
        st.button("Bad (B)", key="vote_bad", shortcut="b", type="primary", on_click=_on_vote,
                  args=(study, rater, key, 0))
    with b3:
        st.button("Undo (U)", key="undo", shortcut="u", on_click=_on_undo, args=(study, rater))


def admin_page(study: Study, token: str) -> None:
    if not hmac.compare_digest(str(token).encode(), study.admin_token().encode()):
        st.error("Admin token not valid.")
        return
    st.title("Study admin")
    ratings = ratings_table(study)
    st.subheader("Progress per rater")
    st.dataframe(rater_progress(study), hide_index=True)
    gvf = gvf_table(ratings)
    st.subheader(f"GVF so far ({len(gvf)} test items with votes)")
    if len(gvf):
        counts, edges = np.histogram(gvf["gvf"], bins=10, range=(0, 1))
        st.bar_chart(pd.DataFrame({"items": counts},
                                  index=[f"{a:.1f}-{b:.1f}" for a, b in zip(edges[:-1], edges[1:], strict=True)]))
    alpha, note = nominal_alpha(ratings)
    st.metric("Krippendorff's alpha (nominal)", "undefined" if alpha is None else f"{alpha:.3f}",
              help=note)
    st.caption(note)
    st.subheader("Gold failures")
    st.dataframe(gold_failures(ratings), hide_index=True)
    st.download_button("Download ratings.csv", ratings.to_csv(index=False).encode(),
                       file_name="ratings.csv", mime="text/csv", key="download_ratings")


def main() -> None:
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
