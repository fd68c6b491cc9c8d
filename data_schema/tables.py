"""Tabular formats (SPEC sections 3-5): column names, reading with validation, atomic writing.

Tables are CSV or Parquet, chosen by the file suffix (``.csv`` / ``.parquet``).
Writing is atomic: the table goes to a temporary file beside the target and is renamed
into place, so an interrupted command never leaves a half-written file that looks complete.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path

import pandas as pd

from data_schema.errors import InputError

__all__ = [
    "PAIRS_COLUMNS",
    "RATINGS_COLUMNS",
    "PAIR_META_COLUMNS",
    "IMAGES_COLUMNS",
    "TABLE_SUFFIXES",
    "pair_id",
    "read_table",
    "write_table",
    "atomic_write_text",
    "atomic_path",
]

TABLE_SUFFIXES = (".csv", ".parquet")

#: SPEC section 2, images.csv
IMAGES_COLUMNS = ("camera", "timestamp_us", "source", "y_offset_m", "path")

#: SPEC section 3, fixed columns of a pairs table (scene attributes follow as extra columns).
PAIRS_COLUMNS = (
    "pair_id", "clip_id", "camera", "track_id", "label_class", "timestamp_us", "y_offset_m",
    "gt_path", "render_path", "gt_x0", "gt_y0", "gt_x1", "gt_y1", "r_x0", "r_y0", "r_x1", "r_y1",
)

#: SPEC section 5, the pair metadata carried into ratings.csv (attributes follow).
PAIR_META_COLUMNS = ("clip_id", "camera", "track_id", "label_class", "timestamp_us", "y_offset_m")

#: SPEC section 5, fixed leading columns of ratings.csv.
RATINGS_COLUMNS = ("item_id", "rater_id", "vote", "voted_at", "response_ms", "kind")


def pair_id(clip_id: str, camera: str, track_id: str, timestamp_us: int, y_offset_m: float) -> str:
    """SPEC section 3 pair id.

    >>> pair_id("clip", "front", "car-1", 100000, 1.0)
    'clip:front:car-1:100000:+1.00'
    >>> pair_id("clip", "front", "car-1", 0, -0.5)
    'clip:front:car-1:0:-0.50'
    """
    return f"{clip_id}:{camera}:{track_id}:{int(timestamp_us)}:{float(y_offset_m):+.2f}"


def _check_suffix(path: Path, what: str) -> str:
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise InputError(path, None, f"a {what} file ending in .csv or .parquet", suffix or "no suffix")
    return suffix


def read_table(
    path: str | os.PathLike,
    *,
    required: Sequence[str] = (),
    what: str = "table",
    dtype: dict | None = None,
) -> pd.DataFrame:
    """Read a CSV/Parquet table and check that ``required`` columns are present.

    Raises :class:`InputError` naming the file and the first missing column.
    """
    path = Path(path)
    suffix = _check_suffix(path, what)
    if not path.is_file():
        raise InputError(path, None, f"an existing {what} file", "no such file")
    try:
        if suffix == ".csv":
            df = pd.read_csv(path, dtype=dtype, keep_default_na=True)
        else:
            df = pd.read_parquet(path)
    except pd.errors.EmptyDataError:
        raise InputError(path, None, f"a {what} with a header row", "an empty file") from None
    except Exception as exc:  # parser errors of either format
        raise InputError(path, None, f"a readable {what}", f"{type(exc).__name__}: {exc}") from None
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise InputError(path, f"column {missing[0]!r}", f"the columns {', '.join(required)}",
                         f"columns {', '.join(map(str, df.columns))}")
    return df


class atomic_path:
    """Context manager yielding a temporary path beside ``target``; renamed onto it on success.

    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_path(d / "x.txt") as tmp:
    ...     _ = tmp.write_text("hi")
    >>> (d / "x.txt").read_text()
    'hi'
    """

    def __init__(self, target: str | os.PathLike):
        self.target = Path(target)

    def __enter__(self) -> Path:
        self.target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.target.name}.", suffix=".part" + self.target.suffix,
                                   dir=self.target.parent)
        os.close(fd)
        self.tmp = Path(tmp)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            os.replace(self.tmp, self.target)
        else:
            self.tmp.unlink(missing_ok=True)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_table(df: pd.DataFrame, path: str | os.PathLike, *, columns: Iterable[str] | None = None) -> Path:
    """Write ``df`` as CSV or Parquet (by suffix) atomically; returns the path."""
    path = Path(path)
    suffix = _check_suffix(path, "output table")
    if columns is not None:
        df = df.loc[:, list(columns)]
    with atomic_path(path) as tmp:
        if suffix == ".csv":
            df.to_csv(tmp, index=False)
        else:
            df.to_parquet(tmp, index=False)
    return path
