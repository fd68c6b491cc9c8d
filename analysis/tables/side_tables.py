"""The tables of other commands that ``analyze`` joins onto the analysed pairs: the NTA-IoU table
(``--nta``, of ``nvrq proxy nta-iou``) and the sets table (``--sets``, of ``nvrq score-sets``).

Layer: analysis. Each must come from the scene of the analysed pairs: a table of another scene
would join nothing (NTA-IoU) or put another scene's numbers beside these methods (FD, KID).
The checks compare the ``clip_id`` values, then the ``pair_id`` values (NTA-IoU) or the methods
(sets), and name the first mismatch in one line.

>>> import pandas as pd
>>> nta = pd.DataFrame({"pair_id": ["b:1", "b:2"], "clip_id": ["b", "b"]})
>>> check_nta(nta, "nta.csv", clips=["a"], pair_ids=pd.Index(["a:1"]))
Traceback (most recent call last):
data_schema.errors.InputError: nta.csv: nta: column clip_id: expected the clip of the analysed pairs (a): a table of the same scene, got b (no clip of the analysed pairs)
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.text import plural

__all__ = ["analysed_ids", "check_nta", "check_sets"]


def _clip_list(clips) -> str:
    clips = sorted(map(str, clips))
    shown = ", ".join(clips[:3]) + (f" and {len(clips) - 3} more" if len(clips) > 3 else "")
    return ("the clip" if len(clips) == 1 else "the clips") + f" of the analysed pairs ({shown})"


def analysed_ids(ratings=None, pairs=None) -> tuple[list[str], pd.Index]:
    """The ``clip_id`` and ``pair_id`` values of the analysed input (a ratings file or ``--pairs``).

    Parameters
    ----------
    ratings : path, optional
        A ratings table (its ``item_id`` are pair ids).
    pairs : path, optional
        A pairs table or a pairs dataset (a folder partitioned by ``clip_id``).

    Returns
    -------
    clips : list of str
        The distinct clip ids, sorted.
    pair_ids : pandas.Index
        The pair ids (``item_id`` of a ratings table).
    """
    import pyarrow.parquet as pq

    from data_schema import datasets as ds
    from data_schema.tables import TableKind, read_table

    if pairs is not None and ds.is_dataset(pairs):
        files = ds.dataset_files(pairs, what=TableKind.PAIRS.value)
        ids = [pq.read_table(f, columns=["pair_id"]).column("pair_id").cast("string").to_pandas() for _, f in files]
        return sorted({str(c) for c, _ in files}), pd.Index(pd.concat(ids, ignore_index=True) if ids else [])
    path, id_col = (pairs, "pair_id") if pairs is not None else (ratings, "item_id")
    df = read_table(path, required=(id_col, "clip_id"), dtype={id_col: str, "clip_id": str})
    return sorted(df["clip_id"].astype(str).unique()), pd.Index(df[id_col].astype(str).unique())


def check_nta(nta: pd.DataFrame, path, *, clips, pair_ids: pd.Index) -> None:
    """Refuse an NTA-IoU table of another scene, or of none of the analysed pairs.

    Parameters
    ----------
    nta : pandas.DataFrame
        The ``nvrq proxy nta-iou`` per-box table (``pair_id``, ``clip_id``).
    path : path
        Its file, named in the error.
    clips : sequence of str
        The analysed clip ids.
    pair_ids : pandas.Index
        The analysed pair ids.

    Raises
    ------
    InputError
        No clip of the table is analysed, or none of its pair ids is.
    """
    if "clip_id" in nta.columns:
        own = nta["clip_id"].astype(str).unique()
        if not np.isin(own, list(clips)).any():
            raise InputError(path, "column clip_id", f"{_clip_list(clips)}: a table of the same scene",
                             f"{', '.join(sorted(own)[:3])} (no clip of the analysed pairs)", param="nta")
    hit = pair_ids.get_indexer(pd.Index(nta["pair_id"].astype(str))) >= 0
    if len(nta) and not hit.any():
        raise InputError(path, "column pair_id", "pair ids of the analysed pairs (an NTA-IoU table made from "
                         "the same scene and views, with the same methods)",
                         f"none of its {plural(len(nta), 'pair id')}, e.g. {nta['pair_id'].iloc[0]}", param="nta")


def check_sets(sets: pd.DataFrame, path, *, clips, methods) -> None:
    """Refuse a sets table of another scene, or of methods the analysis does not have.

    Parameters
    ----------
    sets : pandas.DataFrame
        The ``nvrq score-sets`` table (``clip_id`` when written by this version, ``method``).
    path : path
        Its file, named in the error.
    clips : sequence of str
        The analysed clip ids.
    methods : sequence of str
        The analysed methods (``''`` for the one unnamed method).

    Raises
    ------
    InputError
        A clip or a method of the table that the analysis does not have.
    """
    if "clip_id" in sets.columns:
        own = sets["clip_id"].astype(str).unique()
        bad = [c for c in own if c not in set(map(str, clips))]
        if bad:
            raise InputError(path, "column clip_id", f"{_clip_list(clips)}: a table of the same scene", bad[0],
                             param="sets")
    if "method" in sets.columns:
        known = {str(m) for m in methods}
        own = sets["method"].fillna("").astype(str)
        bad = [m for m in own.unique() if m not in known]
        if bad:
            names = ", ".join(sorted(m or "(unnamed)" for m in known))
            raise InputError(path, "column method", f"the analysed methods ({names})", bad[0] or "(unnamed)",
                             param="sets")
