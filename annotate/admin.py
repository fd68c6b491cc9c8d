"""The study owner's live admin page (``/?admin=TOKEN`` of the rater app).

Layer: annotate (rating study).

The page body is a Streamlit fragment that re-runs by itself every :data:`REFRESH_S`
seconds (no reload): per rater the progress, the agreement with the others so far and the
screening flags as they form (:mod:`annotate.screening`, the rule ``analyze`` applies by
default), the GVF histogram, Krippendorff's alpha, gold failures and a ``ratings.csv``
download; for a pairwise study, per rater the answers, side bias, gold failures and repeat
agreement (:func:`annotate.results.pairwise_raters`) and a ``votes.csv`` download; both
raters tables add the votes each rater undid and the presses dropped as too fast. Widget keys (for tests): ``download_ratings``; element keys ``admin_raters``.
"""

from __future__ import annotations

import hmac
import time

import numpy as np
import pandas as pd
import streamlit as st

from annotate import screening
from annotate.results import (
    gold_failures,
    gvf_table,
    nominal_alpha,
    pairwise_raters,
    pairwise_votes_table,
    rater_progress,
    ratings_table,
)

__all__ = ["REFRESH_S", "admin_page", "live_raters", "shown",  # the page, its tables
           "with_actions"]

#: Seconds between two refreshes of the admin page.
REFRESH_S = 3.0

_LIVE_COLS = ["rater_id", "agreement", "kappa", "youden_j", "j_p", "skill_p", "flags"]

#: What a table cell without a value shows (a rater with no test votes yet has no agreement).
MISSING = "—"


def shown(table: pd.DataFrame):
    """``table`` as the page shows it: missing values as :data:`MISSING` (not ``None`` or
    ``nan``), numbers to 3 decimals; the values themselves stay numbers (sortable).

    Parameters
    ----------
    table : pandas.DataFrame
        A table of the page.

    Returns
    -------
    pandas.io.formats.style.Styler
    """
    return table.style.format(na_rep=MISSING, precision=3)


def live_raters(study, ratings: pd.DataFrame) -> pd.DataFrame:
    """Progress per rater joined with the screening numbers and flags so far.

    Parameters
    ----------
    study : Study
        An open study.
    ratings : pandas.DataFrame
        Its votes so far (:func:`annotate.results.votes_table`).

    Returns
    -------
    pandas.DataFrame
        One row per rater.
    """
    prog = rater_progress(study, ratings)
    if ratings.empty:
        return prog.assign(flags="")
    r = screening.screen(screening.rater_table(ratings), use_rule=False)
    return prog.merge(r[_LIVE_COLS], on="rater_id", how="left").fillna({"flags": ""})


def with_actions(study, raters: pd.DataFrame) -> pd.DataFrame:
    """``raters`` (a ``rater_id`` column) with ``votes_undone`` and ``too_fast`` (presses
    dropped as too fast) per rater, counted in the store's history (0 for none).

    Parameters
    ----------
    study : Study
        An open study.
    raters : pandas.DataFrame
        A table with a ``rater_id`` column.

    Returns
    -------
    pandas.DataFrame
        A copy with ``votes_undone`` and ``too_fast``.
    """
    acts = study.store.action_counts().rename(columns={"rater": "rater_id"})
    out = raters.merge(acts, on="rater_id", how="left")
    cols = ["votes_undone", "too_fast"]
    out[cols] = out[cols].fillna(0).astype(int)
    return out


def _gvf_chart(ratings: pd.DataFrame) -> None:
    gvf = gvf_table(ratings)
    st.subheader(f"GVF so far ({len(gvf)} test items with votes)")
    if len(gvf):
        counts, edges = np.histogram(gvf["gvf"], bins=10, range=(0, 1))
        labels = [f"{a:.1f}-{b:.1f}" for a, b in zip(edges[:-1], edges[1:], strict=True)]
        st.bar_chart(pd.DataFrame({"items": counts}, index=labels))


def _live_pairwise(study) -> None:
    """The pairwise study's page: per-rater answers, side bias, gold and repeats; votes.csv."""
    votes = pairwise_votes_table(study)
    st.caption(f"Live: refreshes every {REFRESH_S:g} s; last update "
               f"{time.strftime('%H:%M:%S')}, {len(votes)} votes.")
    st.subheader("Raters: progress, answers, side bias, gold, repeats")
    st.dataframe(shown(with_actions(study, pairwise_raters(votes, study.store.raters()))),
                 hide_index=True, key="admin_raters")
    st.subheader("Gold failures (the GT crop itself not chosen)")
    gold = votes[(votes["kind"] == "gold") & (votes["choice"] != "a")]
    st.dataframe(shown(gold[["rater_id", "item_id", "choice"]]), hide_index=True)
    st.download_button("Download votes.csv", votes.to_csv(index=False).encode(),
                       file_name="votes.csv", mime="text/csv", key="download_ratings")


def _live_body(study) -> None:
    if study.design == "pairwise":
        _live_pairwise(study)
        return
    ratings = ratings_table(study)
    st.caption(f"Live: refreshes every {REFRESH_S:g} s; last update "
               f"{time.strftime('%H:%M:%S')}, {len(ratings)} votes.")
    st.subheader("Raters: progress, agreement so far, flags")
    st.dataframe(shown(with_actions(study, live_raters(study, ratings))), hide_index=True,
                 key="admin_raters")
    _gvf_chart(ratings)
    alpha, note = nominal_alpha(ratings)
    st.metric("Krippendorff's alpha (nominal)", "undefined" if alpha is None else f"{alpha:.3f}",
              help=note)
    st.caption(note)
    st.subheader("Gold failures")
    st.dataframe(shown(gold_failures(ratings)), hide_index=True)
    st.download_button("Download ratings.csv", ratings.to_csv(index=False).encode(),
                       file_name="ratings.csv", mime="text/csv", key="download_ratings")


_live = st.fragment(run_every=REFRESH_S)(_live_body)


def admin_page(study, token: str) -> None:
    """The admin page of ``study`` when ``token`` is its admin token, else an error.

    Parameters
    ----------
    study : Study
        An open study.
    token : str
        The token given in the page's URL.
    """
    if not hmac.compare_digest(str(token).encode(), study.admin_token().encode()):
        st.error("Admin token not valid.")
        return
    st.title("Study admin")
    _live(study)
