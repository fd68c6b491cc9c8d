"""The study owner's live admin page (``/?admin=TOKEN`` of the rater app).

Layer: annotate (rating study).

The page body is a Streamlit fragment that re-runs by itself every :data:`REFRESH_S`
seconds (no reload): per rater the progress, the agreement with the others so far and the
screening flags as they form (:mod:`annotate.screening`, the rule ``analyze`` applies by
default), the GVF histogram, Krippendorff's alpha, gold failures and a ``ratings.csv``
download; for a pairwise study, per rater the answers, side bias, gold failures and repeat
agreement (:func:`annotate.results.pairwise_raters`) and a ``votes.csv`` download; both
raters tables add the votes each rater undid and the presses dropped as too fast; raters
registered without a vote are listed apart, under the table. The tables are computed at most
once every :data:`TABLES_S` seconds per server process (:func:`admin_tables`), however many
admin tabs are open, so the admin page costs the raters' process little. Widget keys (for
tests): ``download_ratings``; element keys ``admin_raters``.
"""

from __future__ import annotations

import hmac
import threading
import time

import numpy as np
import pandas as pd
import streamlit as st

from annotate import screening
from annotate.load import plural
from annotate.results import (
    gold_failures,
    gvf_table,
    nominal_alpha,
    pairwise_raters,
    pairwise_votes_table,
    rater_progress,
    ratings_table,
)
from data_schema.vocab import Answer, ItemKind, StudyDesign

__all__ = ["REFRESH_S", "TABLES_S", "admin_page", "admin_tables", "live_raters", "shown",
           "with_actions"]

#: Seconds between two refreshes of the admin page.
REFRESH_S = 3.0
#: The admin tables are computed at most once in this many seconds per server process.
TABLES_S = 10.0
_TABLES: dict[tuple[str, str], dict] = {}
_TABLES_LOCK = threading.Lock()

_LIVE_COLS = ["rater_id", "agreement", "kappa", "youden_j", "j_p", "skill_p", "flags"]

#: What a table cell without a value shows (a rater with no test votes yet has no agreement).
MISSING = "—"


def shown(table: pd.DataFrame):
    """``table`` as the page shows it: missing values as :data:`MISSING` (not ``None`` or
    ``nan``), whole numbers without decimals (a median response time is ``1477``, not
    ``1477.000``), other numbers to 3 decimals; the values themselves stay numbers (sortable).

    Parameters
    ----------
    table : pandas.DataFrame

    Returns
    -------
    pandas.io.formats.style.Styler
    """
    table = table.copy()
    formats = {}
    for col in table.columns:
        values = table[col]
        if values.dtype == object:  # text (None where there is none)
            table[col] = values.where(values.notna(), MISSING)
            continue
        if pd.api.types.is_bool_dtype(values) or not pd.api.types.is_numeric_dtype(values):
            continue
        finite = values.dropna()
        whole = bool(len(finite)) and bool(np.all(np.mod(finite.to_numpy(float), 1) == 0))
        formats[col] = "{:.0f}" if whole or pd.api.types.is_integer_dtype(values) else "{:.3f}"
    return table.style.format(formats, na_rep=MISSING)


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


def admin_tables(study) -> dict:
    """The admin page's tables of ``study``, computed at most once every :data:`TABLES_S`
    seconds per server process, whoever asks (measured: each refresh of an open admin tab
    cost the raters' process 0.40 s at 30,600 votes and pushed their p95 from 82 to 397 ms).

    Parameters
    ----------
    study : annotate.study.Study

    Returns
    -------
    dict
        ``at`` (time.time() of the computation), ``votes`` (the ratings or pairwise votes
        table), ``raters`` (per rater, with actions), ``idle`` (raters registered without a
        vote, shown apart).
    """
    ident = (str(study.root), str(study.manifest.study_id))
    with _TABLES_LOCK:
        found = _TABLES.get(ident)
        if found is not None and time.time() - found["at"] < TABLES_S:
            return found
        found = _TABLES[ident] = _compute_tables(study)
    return found


def _compute_tables(study) -> dict:
    if study.design == StudyDesign.PAIRWISE:
        votes = pairwise_votes_table(study)
        raters = with_actions(study, pairwise_raters(votes, study.store.raters()))
    else:
        votes = ratings_table(study)
        raters = with_actions(study, live_raters(study, votes))
    voted = set(votes["rater_id"])
    idle = raters[~raters["rater_id"].isin(voted)]
    return {"at": time.time(), "votes": votes, "raters": raters[raters["rater_id"].isin(voted)],
            "idle": idle}


def _tables_caption(tables: dict) -> None:
    n = len(tables["votes"])
    st.caption(f"Live: refreshes every {REFRESH_S:g} s (tables recomputed at most every "
               f"{TABLES_S:g} s); tables of {time.strftime('%H:%M:%S', time.localtime(tables['at']))}, "
               f"{plural(n, 'vote')}.")


def _idle_raters(tables: dict) -> None:
    """Registered raters without a vote, apart from the others (a count and their names)."""
    idle = tables["idle"]["rater_id"].tolist()
    if idle:
        with st.expander(f"{plural(len(idle), 'rater')} registered without a vote"):
            st.text(", ".join(idle[:200]) + (f" and {len(idle) - 200} more" if len(idle) > 200 else ""))


def _raters_top(study, heading: str) -> dict:
    """The top of a live page: the tables' caption, the raters' table under ``heading`` and the
    raters without a vote; returns :func:`admin_tables` of ``study``."""
    tables = admin_tables(study)
    _tables_caption(tables)
    st.subheader(heading)
    st.dataframe(shown(tables["raters"]), hide_index=True, key="admin_raters")
    _idle_raters(tables)
    return tables


def _live_pairwise(study) -> None:
    """The pairwise study's page: per-rater answers, side bias, gold and repeats; votes.csv."""
    votes = _raters_top(study, "Raters: progress, answers, side bias, gold, repeats")["votes"]
    st.subheader("Gold failures (the GT crop itself not chosen)")
    gold = votes[(votes["kind"] == ItemKind.GOLD) & (votes["choice"] != Answer.A)]
    st.dataframe(shown(gold[["rater_id", "item_id", "choice"]]), hide_index=True)
    st.download_button("Download votes.csv", votes.to_csv(index=False).encode(),
                       file_name="votes.csv", mime="text/csv", key="download_ratings")


def _live_body(study) -> None:
    if study.design == StudyDesign.PAIRWISE:
        _live_pairwise(study)
        return
    ratings = _raters_top(study, "Raters: progress, agreement so far, flags")["votes"]
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
