"""``analyze VOTES.csv`` on pairwise votes: which method do people prefer, and which metric
agrees with them (docs/FORMATS.md §11).

Layer: analysis (pairwise study statistics).

A pairwise vote (``annotate export`` of a ``--design pairwise`` study, one row per vote) has
the columns :data:`PAIRWISE_COLUMNS`: the rater saw the GT crop and the renders of methods
``method_a`` and ``method_b`` of one object and view (``side_a``: where ``a`` was drawn) and
chose ``choice``: ``'a'``, ``'b'`` or ``'tie'`` (can't tell). The object's columns
(``clip_id, camera, track_id, label_class, timestamp_us``, the view, attributes) follow.
A file is read as pairwise when it has these columns (:func:`is_pairwise`).

- **Bradley-Terry** (:func:`bt_table`, the model in :mod:`analysis.stats.bradley_terry`): per view,
  each method's strength (sum 1) and ``win_prob``, the mean probability of being preferred to
  another method (two methods: the probability that it is preferred); a tie counts half a
  win for each side. Without a strongly connected comparison graph (every method won and
  lost something, directly or through others) the fit has no finite maximum: its limit is
  reported with that reason.
- **JOD scale** (:func:`analysis.stats.jod.jod_views`, jod.csv): the same votes on a Thurstone
  Case V scale (1 JOD: 75% prefer the better method), pwcmp's prior for unanimous pairs,
  bootstrap over raters, and the probability that each method beats the next.
- **2AFC agreement** of a metric (as in the BAPPS evaluation of LPIPS): per test vote, the
  metric prefers the side with the better value (by its direction); the vote scores 1 when the
  rater chose that side, 0 for the other and 0.5 when the rater or the metric ties; the
  agreement is the mean over votes. Each side's value is the metric of that method's pair
  (``pair_id_a``/``pair_id_b`` of the export, else the object's id + ``:METHOD``,
  docs/FORMATS.md §3) in ``--metrics-table``, else the export's ``METRIC_a``/``METRIC_b``.
  Its ceiling is the agreement between raters: the mean over items with two votes or more of
  the expected agreement of two different raters of the item (the same scoring of one
  rater's choice against another's), weighted by the item's votes.
- Intervals: 95% percentile intervals of a bootstrap that resamples raters and items
  independently (a vote weighs the product of its rater's and its item's draw counts); the
  ceiling resamples items only (a rater drawn twice would agree with itself).
- **Screening** (:func:`rater_table`): gold votes (``kind == 'gold'``: A is the GT crop
  itself, so ``a`` must be chosen; a tie fails), repeats (``kind == 'repeat'``, the test item
  shown again with the sides swapped: the same choice is consistent), response speed, and
  agreement with the other raters' modal choice, with the tests and thresholds of
  :class:`annotate.screening.ScreenRule`, and the binary design's agreement tests on sides
  (:func:`_side_agreement`); flagged raters are excluded unless ``screen_raters`` is off
  (``--no-screen``), so the fits, the agreement and the ceiling use the raters kept.

Only ``kind == 'test'`` votes enter the fits and the agreement.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats as _st

from analysis.common.method_cells import view_cells
from analysis.common.text import no_votes_left
from analysis.methods import METHOD_COLUMN
from analysis.stats import bootstrap as bs
from analysis.stats.bradley_terry import (  # CHOICES: the share of a win each ``choice`` gives to side a
    CHOICES,
    Draws,
    bradley_terry,
    coded_votes,
    strongly_connected,
    win_matrix,
    win_prob,
)
from analysis.stats.jod import jod_views
from analysis.tables.inputs import classify_columns, drop_empty_columns
from annotate.results import pairwise_raters
from annotate.screening import ScreenRule, agreement_tests, screen
from data_schema.csv_safe import unquote_frame
from data_schema.datasets import table_columns
from data_schema.errors import InputError
from data_schema.raters import SIM_PREFIX
from data_schema.tables import (
    ITEM_KINDS,
    PAIRWISE_VOTES_COLUMNS,
    pair_ids,
    read_metrics,
    read_table,
)
from data_schema.tables import csv_line as _line
from data_schema.vocab import Answer, ItemKind, Side

__all__ = [
    "PAIRWISE_COLUMNS",
    "CHOICES",
    "BT_COLUMNS",
    "AGREEMENT_COLUMNS",
    "PairwiseAnalysis",
    "is_pairwise",
    "read_pairwise_votes",
    "bt_table",
    "agreement_table",
    "rater_table",
    "side_pair_ids",
    "run_pairwise_analysis",
]

#: docs/FORMATS.md §11: the leading columns of a pairwise vote (the object's columns follow);
#: defined once, with the export that writes them.
PAIRWISE_COLUMNS = PAIRWISE_VOTES_COLUMNS
BT_COLUMNS = ["axis", "offset", "method", "n_votes", "wins", "ties", "losses", "score",
              "score_ci_lo", "score_ci_hi", "win_prob", "win_prob_ci_lo", "win_prob_ci_hi", "reason"]
AGREEMENT_COLUMNS = ["metric", "higher_better", "n_votes", "agreement", "ci_lo", "ci_hi", "reason"]
#: The row of the agreement table that holds the agreement between raters (the ceiling).
CEILING_ROW = "raters (ceiling)"


def is_pairwise(path) -> bool:
    """True when the table at ``path`` has the pairwise vote columns (:data:`PAIRWISE_COLUMNS`).

    Parameters
    ----------
    path : str or Path
        A votes table.

    Returns
    -------
    bool
    """
    return set(PAIRWISE_COLUMNS) <= set(_header(path))


def _header(path) -> list[str]:
    """The column names of the table at ``path``; none when it cannot be read (an empty or broken
    file: the table's reader then says what is wrong, in one line)."""
    p = Path(path)
    if p.suffix.lower() not in (".csv", ".parquet") or not p.is_file():
        return []
    try:
        return table_columns(p)
    except (ValueError, OSError):  # pandas' EmptyDataError/ParserError, pyarrow's ArrowInvalid
        return []


def read_pairwise_votes(path) -> pd.DataFrame:
    """Read and check pairwise votes (one row per vote, module docstring).

    Checks: the columns exist, at least one row; ``choice`` in ``{'a', 'b', 'tie'}``; ``kind``
    one of :data:`~data_schema.tables.ITEM_KINDS`; ids and methods non-empty, and the two
    methods of a test or repeat vote differ; one row per (rater, item, kind).

    Parameters
    ----------
    path : str or Path
        A pairwise votes table (docs/FORMATS.md §12).

    Returns
    -------
    pandas.DataFrame
        One row per vote.

    Raises
    ------
    InputError
        A check fails.
    """
    df = read_table(path, required=PAIRWISE_COLUMNS, what="pairwise votes",
                    dtype={c: str for c in ("item_id", "rater_id", "kind", "method_a", "method_b",
                                            "side_a", "choice", "clip_id", "camera", "track_id",
                                            "label_class")})
    if len(df) == 0:
        raise InputError(path, None, "at least one vote row", "no rows")
    df = unquote_frame(df)  # cells annotate export quoted against spreadsheet formulas
    for col, allowed in (("choice", tuple(CHOICES)), ("kind", ITEM_KINDS)):
        bad = ~df[col].isin(allowed)
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputError(path, f"{_line(i)}: {col}", "one of " + ", ".join(allowed), df[col].iloc[i])
    for col in ("item_id", "rater_id", "method_a", "method_b", "side_a"):
        bad = df[col].isna() | (df[col].astype(str).str.strip() == "")
        if bad.any():
            raise InputError(path, f"{_line(int(np.flatnonzero(bad.to_numpy())[0]))}: {col}",
                             "a value", "empty")
    same = df["kind"].isin((ItemKind.TEST, ItemKind.REPEAT)) & (df["method_a"] == df["method_b"])
    if same.any():
        i = int(np.flatnonzero(same.to_numpy())[0])
        raise InputError(path, f"{_line(i)}: method_b", "a method other than method_a",
                         df["method_b"].iloc[i])
    dup = df.duplicated(["rater_id", "item_id", "kind"])
    if dup.any():
        i = int(np.flatnonzero(dup.to_numpy())[0])
        raise InputError(path, _line(i), "one row per (rater_id, item_id, kind)",
                         f"a second row for rater {df['rater_id'].iloc[i]!r}, item {df['item_id'].iloc[i]!r}")
    df["response_ms"] = pd.to_numeric(df["response_ms"], errors="coerce") if "response_ms" in df.columns \
        else np.nan
    return df


def _ci(estimate: float, reps: np.ndarray, few: str | None = None) -> tuple[float, float, str | None]:
    """The interval of ``estimate`` from its replicates (:func:`analysis.stats.bootstrap.interval_around`);
    none, with the reason, without replicates or from too few raters (``few``)."""
    if few:
        return np.nan, np.nan, few
    return bs.interval_around(estimate, reps) if reps.size else (np.nan, np.nan, "no bootstrap")


def bt_table(votes: pd.DataFrame, methods: list[str], *, draws: Draws | None, r_codes, i_codes) -> pd.DataFrame:
    """bradley_terry.csv (:data:`BT_COLUMNS`): per view (``axis = 'all'`` and each axis value)
    and method, the vote counts, strength ``score`` and ``win_prob`` with 95% intervals.

    Parameters
    ----------
    votes : pandas.DataFrame
        Test votes of the raters kept.
    methods : list of str
        The methods compared.
    draws : Draws or None
        Shared bootstrap draws (``None``: no intervals).
    r_codes, i_codes : (V,) int
        Rater and item code of each vote (columns of ``draws``).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`BT_COLUMNS`.
    """
    m = len(methods)
    a, b, s = coded_votes(votes, methods)
    known = (a >= 0) & (b >= 0)
    rows = []
    for axis, value, in_view in view_cells(votes):
        sel = in_view & known
        w = win_matrix(a[sel], b[sel], s[sel], m)
        p = bradley_terry(w)
        wp = win_prob(p)
        reps_p = reps_w = np.empty((0, m))
        if draws is not None and sel.any():
            reps_p = bradley_terry(draws.win_matrices(a[sel], b[sel], s[sel], m,
                                                      r_codes[sel], i_codes[sel]))
            reps_w = win_prob(reps_p)
        ties = np.bincount(np.r_[a[sel], b[sel]], weights=np.r_[s[sel] == 0.5, s[sel] == 0.5], minlength=m)
        n = np.bincount(np.r_[a[sel], b[sel]], minlength=m)
        won = np.bincount(np.r_[a[sel], b[sel]], weights=np.r_[s[sel] == 1.0, s[sel] == 0.0], minlength=m)
        connected = bool(strongly_connected(w))
        few = bs.too_few_raters(len(np.unique(r_codes[sel]))) if draws is not None else None
        for k, name in enumerate(methods):
            reason = None
            if n[k] == 0:
                reason = "no votes"
            elif not connected:
                reason = ("comparison graph not strongly connected (a method won or lost every "
                          "comparison): the fit is at its limit")
            lo, hi, why = _ci(p[k], reps_p[:, k], few) if n[k] else (np.nan, np.nan, None)
            wlo, whi, wwhy = _ci(wp[k], reps_w[:, k], few) if n[k] else (np.nan, np.nan, None)
            if wwhy and wwhy != why:
                why = f"{why}; win_prob: {wwhy}" if why else f"win_prob: {wwhy}"
            rows.append({"axis": axis, "offset": value, "method": name, "n_votes": int(n[k]),
                         "wins": int(won[k]), "ties": int(ties[k]), "losses": int(n[k] - won[k] - ties[k]),
                         "score": p[k], "score_ci_lo": lo, "score_ci_hi": hi, "win_prob": wp[k],
                         "win_prob_ci_lo": wlo, "win_prob_ci_hi": whi,
                         "reason": "; ".join(r for r in (reason, why) if r) or None})
    return pd.DataFrame(rows, columns=BT_COLUMNS)


# --- 2AFC agreement with people --------------------------------------------------------------

def side_pair_ids(votes: pd.DataFrame, side: str) -> list[str]:
    """The pair id of each vote's ``side`` (``'a'`` or ``'b'``) render: the export's column
    ``pair_id_a``/``pair_id_b`` where it has one, else the object's pair id (docs/FORMATS.md §3)
    followed by ``:METHOD``.

    Parameters
    ----------
    votes : pandas.DataFrame
        Pairwise votes.
    side : str
        ``{'a', 'b'}``.

    Returns
    -------
    list of str
        One pair id per vote.
    """
    ids = pair_ids(votes, votes[f"method_{side}"].astype(str))
    given = votes.get(f"pair_id_{side}")
    if given is None:
        return ids
    return [g if isinstance(g, str) and g else i for g, i in zip(given, ids, strict=True)]


def _side_values(votes: pd.DataFrame, tables, side: str, ids: list[str]) -> dict[str, np.ndarray]:
    """metric -> (V,) value of each vote's ``side`` render (NaN where unknown): the export's
    ``METRIC_a``/``METRIC_b`` columns, then (replacing them) the ``--metrics-table`` values of
    the side's pair (``ids``: :func:`side_pair_ids`)."""
    other = "b" if side == "a" else "a"
    out = {}
    for c in votes.columns:
        base = c[:-2]
        if c.endswith(f"_{side}") and f"{base}_{other}" in votes.columns and base not in (
                "pair_id", "method", "side"):
            out[base] = pd.to_numeric(votes[c], errors="coerce").to_numpy(np.float64)
    ids = pd.Index(ids)
    for _, t in tables:
        pos = pd.Index(t["pair_id"].astype(str)).get_indexer(ids)
        for c in t.columns:
            if c in ("pair_id", METHOD_COLUMN, "clip_id"):
                continue
            v = pd.to_numeric(t[c], errors="coerce").to_numpy(np.float64)
            out[c] = np.where(pos >= 0, v[np.maximum(pos, 0)], np.nan)
    return out


def agreement_table(votes, sides: dict, directions: dict[str, bool], *, draws: Draws | None,
                    r_codes, i_codes) -> pd.DataFrame:
    """The 2AFC agreement of each metric with the test votes, and the raters' ceiling
    (:data:`AGREEMENT_COLUMNS`, module docstring).

    Parameters
    ----------
    votes : pandas.DataFrame
        Test votes of the raters kept.
    sides : dict
        ``{'a': {metric: (V,) float64}, 'b': {...}}``: each vote's metric values of its two
        renders.
    directions : dict
        Metric -> whether higher is better.
    draws : Draws or None
        Shared bootstrap draws (``None``: no intervals).
    r_codes, i_codes : (V,) int
        Rater and item code of each vote.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`AGREEMENT_COLUMNS`.
    """
    h = votes["choice"].map(CHOICES).to_numpy(np.float64)
    rows = []
    for metric, hb in directions.items():
        va, vb = sides["a"][metric], sides["b"][metric]
        ok = np.isfinite(va) & np.isfinite(vb)
        pref = np.where(va == vb, 0.5, ((va > vb) if hb else (va < vb)).astype(np.float64))
        score = h * pref + (1 - h) * (1 - pref)
        row = {"metric": metric, "higher_better": hb, "n_votes": int(ok.sum()), "agreement": np.nan,
               "ci_lo": np.nan, "ci_hi": np.nan, "reason": None}
        if not ok.any():
            row["reason"] = "no vote with both sides' values in the metrics tables"
        else:
            row["agreement"] = float(score[ok].mean())
            few = bs.too_few_raters(len(np.unique(r_codes[ok])))
            if draws is None:
                row["reason"] = "no bootstrap"
            elif few:
                row["reason"] = few
            else:
                with np.errstate(invalid="ignore", divide="ignore"):
                    reps = draws.total(r_codes[ok], i_codes[ok], score[ok]) / \
                        draws.total(r_codes[ok], i_codes[ok], np.ones(ok.sum()))
                row["ci_lo"], row["ci_hi"], row["reason"] = bs.interval_around(row["agreement"], reps)
        rows.append(row)
    rows.append(_ceiling_row(h, i_codes, draws))
    return pd.DataFrame(rows, columns=AGREEMENT_COLUMNS)


def _ceiling_row(h, i_codes, draws) -> dict:
    n_items = int(i_codes.max()) + 1 if len(i_codes) else 0
    k = np.bincount(i_codes, minlength=n_items).astype(np.float64)
    s1 = np.bincount(i_codes, weights=h, minlength=n_items)
    s2 = np.bincount(i_codes, weights=h * h, minlength=n_items)
    q2 = np.bincount(i_codes, weights=(1 - h) ** 2, minlength=n_items)
    with np.errstate(invalid="ignore", divide="ignore"):
        agree = (s1 * s1 - s2 + (k - s1) ** 2 - q2) / (k * (k - 1))  # two different raters
    use = k >= 2
    row = {"metric": CEILING_ROW, "higher_better": None, "n_votes": int(k[use].sum()),
           "agreement": np.nan, "ci_lo": np.nan, "ci_hi": np.nan, "reason": None}
    if not use.any():
        row["reason"] = "no item with two votes or more"
        return row
    wk = np.where(use, k, 0.0)
    row["agreement"] = float((wk * np.nan_to_num(agree)).sum() / wk.sum())
    if draws is None:
        row["reason"] = "no bootstrap"
    else:
        c = draws.items.astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            reps = (c @ (wk * np.nan_to_num(agree))) / (c @ wk)
        row["ci_lo"], row["ci_hi"], row["reason"] = bs.interval_around(row["agreement"], reps)
    return row


# --- rater screening ---------------------------------------------------------------------------

def rater_table(votes: pd.DataFrame, *, rule: ScreenRule | None = None) -> pd.DataFrame:
    """Per-rater screening of pairwise votes: the per-rater answers of
    :func:`annotate.results.pairwise_raters` (votes per kind, answer shares, side bias,
    ``gold_failures``, ``repeat_agreement`` over ``n_repeat_pairs``) with the tests the
    screening rule reads (:func:`annotate.screening.screen`): ``gold_p`` (exact binomial,
    H0: failure rate <= ``rule.max_gold_failure_rate``), ``repeat_p`` (H0: consistency >=
    ``rule.min_repeat_consistency``), ``speed_p`` (sign test of the test votes' response
    times against ``rule.min_response_ms``), and the agreement tests of the binary design
    on sides (:func:`_side_agreement`): ``youden_j``, ``j_p`` and ``skill_p``. ``agreement``:
    the share of the rater's test votes equal to the other raters' unique modal choice, over
    ``n_compared``.

    Parameters
    ----------
    votes : pandas.DataFrame
        Pairwise votes, all kinds.
    rule : ScreenRule, optional
        The screening rule (default: the default rule).

    Returns
    -------
    pandas.DataFrame
        One row per rater.
    """
    rule = rule or ScreenRule()
    raters = sorted(votes["rater_id"].astype(str).unique())
    out = pairwise_raters(votes, raters)
    out.insert(1, "simulated", out["rater_id"].str.startswith(SIM_PREFIX))
    t = votes[votes["kind"] == ItemKind.TEST]
    tr = pd.Index(raters).get_indexer(t["rater_id"])
    n_r = len(raters)
    counts = pd.crosstab(t["item_id"], t["choice"]).reindex(columns=list(CHOICES), fill_value=0)
    own = pd.get_dummies(t["choice"]).reindex(columns=list(CHOICES), fill_value=0).to_numpy(np.int64)
    others = counts.loc[t["item_id"]].to_numpy(np.int64) - own
    top = others.max(axis=1)
    compared = ((others == top[:, None]).sum(axis=1) == 1) & (top > 0)  # a unique modal choice
    mode = np.array(list(CHOICES), dtype=object)[others.argmax(axis=1)]
    agree = compared & (mode == t["choice"].to_numpy(dtype=object))
    comp = np.bincount(tr, weights=compared, minlength=n_r)
    with np.errstate(invalid="ignore", divide="ignore"):
        out["agreement"] = np.bincount(tr, weights=agree, minlength=n_r) / comp
        out["gold_failure_rate"] = out["gold_failures"] / out["gold"]
    out["n_compared"] = comp.astype(np.int64)
    sided = compared & (mode != Answer.TIE) & (t["choice"].to_numpy(dtype=object) != Answer.TIE)
    a_left = t["side_a"].to_numpy(dtype=object) == Side.LEFT
    res = _side_agreement(tr, n_r, sided, mode_left=(mode == Answer.A) == a_left,
                          pressed_left=(t["choice"].to_numpy(dtype=object) == Answer.A) == a_left)
    out["youden_j"] = res["youden_j"]
    _, out["j_p"], out["skill_p"], _ = agreement_tests(res, rule)
    n_gold, fails = out["gold"].to_numpy(), out["gold_failures"].to_numpy()
    out["gold_p"] = np.where(n_gold > 0, _st.binom.sf(fails - 1, n_gold, rule.max_gold_failure_rate), np.nan)
    n_rep = out["n_repeat_pairs"].to_numpy()
    same = np.round(np.nan_to_num(out["repeat_agreement"].to_numpy(np.float64)) * n_rep)
    out["repeat_p"] = np.where(n_rep > 0, _st.binom.cdf(same, n_rep, rule.min_repeat_consistency), np.nan)
    rt = pd.to_numeric(t["response_ms"], errors="coerce").to_numpy(np.float64)
    known = np.isfinite(rt)
    fast = np.bincount(tr[known], weights=rt[known] < rule.min_response_ms, minlength=n_r)
    nk = np.bincount(tr[known], minlength=n_r)
    out["speed_p"] = np.where(nk > 0, _st.binom.sf(fast - 1, nk, 0.5), np.nan)
    return out


def _side_agreement(codes, n_r: int, sided, *, mode_left, pressed_left) -> dict:
    """The binary design's agreement statistics on sides, per rater (``codes``: (V,) rater
    codes of the test votes).

    Over the test votes where the other raters' unique modal choice is ``a`` or ``b`` and the
    rater chose a side (``sided``), the consensus label is the side the modal choice was
    shown on (``mode_left``, "good" = left) and the vote the side pressed (``pressed_left``).
    As A's side is counterbalanced per rater (:func:`annotate.assign.pairwise_sides`), a rater
    who presses without looking, with any side bias, has ``J = 0`` and no association,
    whatever the methods' base rates; an attentive rater presses where the others' choice
    is. Returns :func:`annotate.screening.consensus_stats`' keys ``n_compared, n_cons_good,
    n_cons_bad, sensitivity, specificity, youden_j`` as (R,) arrays."""
    ml, pl = sided & mode_left, sided & ~mode_left
    n1 = np.bincount(codes, weights=ml, minlength=n_r)
    n0 = np.bincount(codes, weights=pl, minlength=n_r)
    with np.errstate(invalid="ignore", divide="ignore"):
        sens = np.bincount(codes, weights=ml & pressed_left, minlength=n_r) / n1
        spec = np.bincount(codes, weights=pl & ~pressed_left, minlength=n_r) / n0
    return {"n_compared": (n1 + n0).astype(np.int64), "n_cons_good": n1.astype(np.int64),
            "n_cons_bad": n0.astype(np.int64), "sensitivity": sens, "specificity": spec,
            "youden_j": sens + spec - 1.0}


# --- the whole analysis ----------------------------------------------------------------------

@dataclass
class PairwiseAnalysis:
    """Everything the pairwise report shows (tables: see each function).

    Attributes
    ----------
    votes_path : str
        The votes table read.
    methods : list of str
        The methods compared.
    bradley_terry : pandas.DataFrame
        :func:`bt_table`.
    agreement : pandas.DataFrame
        :func:`agreement_table`.
    raters : pandas.DataFrame
        :func:`rater_table`.
    counts : dict
        Vote and rater counts.
    n_boot : int
        Bootstrap replicates.
    seed : int
        Their seed.
    screen : bool
        Whether screening excluded raters.
    notes : list of str
        Notes for the report.
    jod : pandas.DataFrame or None
        :func:`analysis.stats.jod.jod_views` (Thurstone Case V scale in JOD), beside Bradley-Terry.
    """

    votes_path: str
    methods: list[str]
    bradley_terry: pd.DataFrame
    agreement: pd.DataFrame
    raters: pd.DataFrame
    counts: dict
    n_boot: int = 0
    seed: int = 0
    screen: bool = True
    notes: list[str] = field(default_factory=list)
    jod: pd.DataFrame | None = None


def run_pairwise_analysis(votes_path, *, metrics_paths=(), lower=(), higher=(), exclude_raters=(),
                          screen_raters: bool = True, n_boot: int = 1000, seed: int = 0) -> PairwiseAnalysis:
    """The pairwise analysis (module docstring); raises ``InputError`` on bad input.

    ``screen_raters`` (default True) excludes the raters the screening rule flags, as
    ``exclude_raters`` does by name; the fits, the agreement and its ceiling use the test
    votes of the raters kept.

    Parameters
    ----------
    votes_path : str or Path
        A pairwise votes table.
    metrics_paths : sequence of str, optional
        Metrics tables joined on the renders' pair ids.
    lower, higher : sequence of str, optional
        Metrics declared lower- or higher-is-better.
    exclude_raters : sequence of str, optional
        Raters left out by name.
    screen_raters : bool, optional
        Exclude the raters the screening rule flags.
    n_boot : int, optional
        Bootstrap replicates (0: no intervals).
    seed : int, optional
        Seed of the bootstrap.

    Returns
    -------
    PairwiseAnalysis
    """
    votes = read_pairwise_votes(votes_path)
    raters = screen(rater_table(votes), use_rule=screen_raters, exclude=list(exclude_raters))
    excluded = set(raters.loc[raters["excluded"], "rater_id"])
    test = votes[(votes["kind"] == ItemKind.TEST) & ~votes["rater_id"].isin(excluded)].reset_index(drop=True)
    if test.empty:
        raise InputError(votes_path, "kind", no_votes_left(screen_raters), "none")
    methods = sorted(set(test["method_a"]) | set(test["method_b"]))
    if len(methods) < 2:
        raise InputError(votes_path, "method_a/method_b", "votes between at least two methods", methods[0])
    tables = [(str(p), read_metrics(p)) for p in metrics_paths]
    ids = {s: side_pair_ids(test, s) for s in ("a", "b")}
    for path, t in tables:
        if not pd.Index(t["pair_id"].astype(str)).isin(ids["a"] + ids["b"]).any():
            raise InputError(path, "pair_id", "the pairs of the voted methods' renders (object id + "
                             "':METHOD', docs/FORMATS.md §3)", "none matches a vote")
    sides = {s: _side_values(test, tables, s, ids[s]) for s in ("a", "b")}
    # a metric with no value on any voted render is undefined for these crops: a note, no row
    kept, notes = drop_empty_columns(pd.concat([pd.DataFrame(sides[s]) for s in ("a", "b")]), unit="voted render")
    columns = pd.DataFrame({c: sides["a"][c] for c in kept.columns})
    metrics, directions, _, _ = classify_columns(columns, lower=set(lower), higher=set(higher),
                                                 target=None, where=metrics_paths[0] if tables else votes_path)
    for m in metrics:
        miss = int((~np.isfinite(sides["a"][m]) | ~np.isfinite(sides["b"][m])).sum())
        if miss:
            notes.append(f"{m}: {miss} of {len(test)} test votes lack a side's value (left out of its agreement)")
    r_codes = pd.factorize(test["rater_id"], sort=True)[0]
    i_codes = pd.factorize(test["item_id"], sort=True)[0]
    draws = Draws.make(int(r_codes.max()) + 1, int(i_codes.max()) + 1, n_boot, seed)
    bt = bt_table(test, methods, draws=draws, r_codes=r_codes, i_codes=i_codes)
    agreement = agreement_table(test, sides, {m: directions[m] for m in metrics}, draws=draws,
                                r_codes=r_codes, i_codes=i_codes)
    counts = {"votes": len(votes), "test_votes": int((votes["kind"] == ItemKind.TEST).sum()),
              "test_votes_kept": len(test), "items": int(test["item_id"].nunique()),
              "raters": len(raters), "raters_excluded": int(raters["excluded"].sum()),
              "raters_simulated": int(raters["simulated"].sum()),
              "gold_votes": int((votes["kind"] == ItemKind.GOLD).sum()),
              "repeat_votes": int((votes["kind"] == ItemKind.REPEAT).sum()),
              "ties": int((test["choice"] == Answer.TIE).sum())}
    jod = jod_views(test, methods, n_boot=n_boot if draws is not None else 0, seed=seed)
    return PairwiseAnalysis(votes_path=str(votes_path), methods=methods, bradley_terry=bt,
                            agreement=agreement, raters=raters, counts=counts,
                            n_boot=n_boot if draws is not None else 0, seed=seed,
                            screen=screen_raters, notes=notes, jod=jod)
