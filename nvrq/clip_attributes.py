"""A clip attributes table: ``clip_id`` plus one column per scene attribute (e.g. ``lighting``,
``road_type``), so a fleet's breakdowns (paper Table 2) need no hand edits of ``scene.json``.

Layer: nvrq core, sources (clip attributes of a fleet).

Rule: every non-empty cell of the clip's row sets that attribute, replacing a value from
``scene.json``; an empty cell leaves the scene's value (if any). Values are strings.
``nvrq import nurec --clip-attributes FILE`` writes them into ``scene.json``;
``nvrq pairs --clip-attributes FILE`` applies them to the pairs table.

>>> import pandas as pd
>>> t = ClipAttributes.from_frame(pd.DataFrame({"clip_id": ["a", "b"], "lighting": ["night", None]}), where="t.csv")
>>> t.for_clip("a", {"road_type": "urban"})
{'road_type': 'urban', 'lighting': 'night'}
>>> t.for_clip("b", {"lighting": "dusk"})
{'lighting': 'dusk'}
>>> t.columns
['lighting']
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from data_schema.errors import InputError
from data_schema.tables import PAIRS_COLUMNS, read_table

__all__ = ["ClipAttributes", "read_clip_attributes"]

#: Attribute names that would clash with the pairs table's own columns.
_RESERVED = frozenset(PAIRS_COLUMNS) | {"scene_root"}


@dataclass(frozen=True)
class ClipAttributes:
    """Attributes per clip id: ``rows[clip_id] = {name: value}`` (empty cells left out).

    Attributes
    ----------
    rows : dict
        ``{clip_id: {name: value}}``.
    columns : list of str
        The attribute columns, in file order.
    where : str
        The file, named in errors.
    """

    rows: dict
    columns: list
    where: str

    @classmethod
    def from_frame(cls, df: pd.DataFrame, *, where: str) -> ClipAttributes:
        if "clip_id" not in df.columns:
            raise InputError(where, "column 'clip_id'", "a clip_id column and attribute columns",
                             f"columns {', '.join(map(str, df.columns))}")
        cols = [str(c) for c in df.columns if c != "clip_id"]
        bad = [c for c in cols if c in _RESERVED]
        if bad:
            raise InputError(where, f"column {bad[0]!r}", "attribute names that are not pairs columns",
                             "a pairs column")
        ids = df["clip_id"].astype(str)
        dup = ids.duplicated()
        if dup.any():
            i = int(dup.to_numpy().nonzero()[0][0])
            raise InputError(where, f"line {i + 2}: clip_id", "each clip once", f"{ids.iloc[i]!r} again")
        rows = {}
        for clip, rec in zip(ids, df[cols].to_dict("records"), strict=True):
            rows[clip] = {k: str(v) for k, v in rec.items() if not pd.isna(v) and str(v) != ""}
        return cls(rows, cols, where)

    def for_clip(self, clip_id: str, scene_attributes: dict) -> dict:
        """The scene's attributes with this table's non-empty values applied."""
        return {**scene_attributes, **self.rows.get(str(clip_id), {})}

    def require(self, clip_id: str) -> dict:
        """The clip's row; an error naming the table when the clip is not in it."""
        if str(clip_id) not in self.rows:
            raise InputError(self.where, "clip_id", f"a row for clip {clip_id!r}", "none")
        return self.rows[str(clip_id)]


def read_clip_attributes(path) -> ClipAttributes:
    """Read a clip attributes table (.csv or .parquet); all cells are read as strings.

    Parameters
    ----------
    path : str or Path
        A ``.csv`` or ``.parquet`` table with a ``clip_id`` column.

    Returns
    -------
    ClipAttributes

    Raises
    ------
    InputError
        No ``clip_id`` column or no attribute column, an attribute named like a pairs
        column, or a repeated clip id.
    """
    df = read_table(path, required=("clip_id",), what="clip attributes table", dtype=str)
    return ClipAttributes.from_frame(df, where=str(path))
