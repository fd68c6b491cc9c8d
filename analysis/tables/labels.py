"""Votes to per-item labels (docs/FORMATS.md §6) and the join of metric tables onto the items.

Layer: analysis (statistics of votes and metrics).

Only ``kind == 'test'`` votes count. Per item: ``n_votes``, ``n_good``,
``gvf = n_good / n_votes`` (the good-vote fraction), ``majority_good = gvf >= 0.5``
(a tie counts as good) and the Wilson 95% interval ``gvf_ci_lo, gvf_ci_hi`` — all from
:func:`annotate.results.good_vote_fraction`, the one definition. Other columns of the ratings (pair metadata, attributes, metric
values) are taken from the item's first test vote row.

>>> import pandas as pd
>>> v = pd.DataFrame({"item_id": ["a", "a", "b", "a"], "rater_id": ["r1", "r2", "r1", "r3"],
...                   "vote": [1, 0, 0, 1], "kind": ["test"] * 4})
>>> item_table(v)[["item_id", "n_votes", "n_good", "gvf", "majority_good"]].to_dict("list")
{'item_id': ['a', 'b'], 'n_votes': [3, 1], 'n_good': [2, 0], 'gvf': [0.6666666666666666, 0.0], 'majority_good': [True, False]}
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from annotate.results import good_vote_fraction
from data_schema.errors import InputError
from data_schema.vocab import ItemKind

__all__ = ["item_table", "join_metrics"]

_VOTE_ONLY = ("rater_id", "vote", "voted_at", "response_ms", "kind", "gold_expected")


def item_table(votes: pd.DataFrame) -> pd.DataFrame:
    """Per-item labels from one-row-per-vote ``votes``; one row per item, in first-seen order.

    Parameters
    ----------
    votes : pandas.DataFrame
        One row per vote (the ratings table); only ``kind == 'test'`` rows make labels.

    Returns
    -------
    pandas.DataFrame
        One row per test item: its columns without the per-vote ones, and its labels.
    """
    test = votes[votes["kind"] == ItemKind.TEST]
    labels = good_vote_fraction(test["item_id"], test["vote"])
    codes = pd.factorize(test["item_id"])[0]
    _, first = np.unique(codes, return_index=True)
    keep = [c for c in test.columns if c not in _VOTE_ONLY and c != "item_id"]
    meta = test.iloc[first][keep].reset_index(drop=True)
    return pd.concat([labels, meta], axis=1)


def join_metrics(items: pd.DataFrame, tables: list[tuple[str, pd.DataFrame]]):
    """Left-join metric tables (``pair_id`` + columns) onto ``items`` by ``item_id``.

    A column given by two metric files is an error; a metric-file column that the ratings
    already carry replaces it (noted). Returns ``(items, unknown_ids, notes)`` where
    ``unknown_ids[path]`` counts pair ids of the file that are not rated items.

    Parameters
    ----------
    items : pandas.DataFrame
        :func:`item_table`.
    tables : list of (str, pandas.DataFrame)
        ``(path, metrics table)``.

    Returns
    -------
    items : pandas.DataFrame
        With the metric columns.
    unknown_ids : dict
        Path -> count of pair ids not among the items.
    notes : list of str

    Raises
    ------
    InputError
        A column given by two metric files.
    """
    unknown, notes, seen = {}, [], {}
    index = pd.Index(items["item_id"])
    for path, table in tables:
        cols = [c for c in table.columns if c != "pair_id"]
        for c in cols:
            if c in seen:
                raise InputError(
                    path,
                    f"column {c!r}",
                    "each metric column in one metrics table",
                    f"also in {seen[c]}",
                )
            seen[c] = path
        pos = index.get_indexer(table["pair_id"])
        unknown[str(path)] = int((pos < 0).sum())
        hit = pos >= 0
        new = {}
        for c in cols:
            col = np.full(len(items), np.nan)
            col[pos[hit]] = table[c].to_numpy(np.float64)[hit]
            if c in items.columns:
                notes.append(f"column {c!r} of {path} replaces the one in the ratings")
                items[c] = col  # in its place
            else:
                new[c] = col
        if new:  # all at once: one column at a time fragments the frame (and warns)
            items = pd.concat([items, pd.DataFrame(new, index=items.index)], axis=1)
    return items, unknown, notes
