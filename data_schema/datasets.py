"""Parquet datasets partitioned by ``clip_id``: the multi-clip form of pairs and metrics tables.

Layer: data_schema (file formats).

Layout (Hive partitioning, readable by pyarrow, Ray Data, Spark, DuckDB)::

    DATASET/clip_id=<quoted clip id>/<name>.parquet   one or more files per clip
    DATASET/_dataset.json                               written last: the files and row count
    DATASET/failed.csv                                  (``nvrq pairs --keep-going``) clip, reason

The files do not repeat the ``clip_id`` column (the folder name carries it); readers here
put it back as a string column right after ``pair_id``. Clip ids are URL-quoted in folder
names (``urllib.parse.quote(..., safe='')``).

Completeness: ``_dataset.json`` lists every file. A folder with ``_plan.json`` (a scoring run
in progress) but no ``_dataset.json`` is an unfinished run; a listed file that is missing is a
missing shard. Both are errors naming the folder. A plain Hive folder written by another tool
(no ``_dataset.json``) is read as it is. All files must share one schema (column names and
types); the first difference is an error naming both files.

>>> partition_dir("a/b c")
'clip_id=a%2Fb%20c'
>>> clip_from_dir("clip_id=a%2Fb%20c")
'a/b c'
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from pathlib import Path
from urllib.parse import quote, unquote

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from data_schema.errors import InputError
from data_schema.tables import atomic_folder, atomic_write_text

__all__ = [
    "PARTITION",
    "MANIFEST",
    "PLAN",
    "partition_dir",
    "clip_from_dir",
    "is_dataset",
    "dataset_files",
    "check_schemas",
    "read_dataset",
    "iter_clips",
    "write_manifest",
    "DatasetWriter",
    "table_columns",
]

PARTITION = "clip_id"
MANIFEST = "_dataset.json"
PLAN = "_plan.json"


def partition_dir(clip_id: str) -> str:
    """Folder name of one clip's partition.

    Parameters
    ----------
    clip_id : str
        The clip id, any text.

    Returns
    -------
    str
        ``clip_id=<clip id, URL-quoted>``.
    """
    return f"{PARTITION}={quote(str(clip_id), safe='')}"


def clip_from_dir(name: str) -> str:
    """Inverse of :func:`partition_dir`.

    Parameters
    ----------
    name : str
        A partition folder name, ``clip_id=<quoted clip id>``.

    Returns
    -------
    str
        The clip id, unquoted.
    """
    return unquote(name.split("=", 1)[1])


def is_dataset(path) -> bool:
    """True when ``path`` is a folder (a partitioned dataset) rather than a table file.

    Parameters
    ----------
    path : str or Path
        A table file or a dataset folder.

    Returns
    -------
    bool
    """
    return Path(path).is_dir()


def _manifest(root: Path) -> dict | None:
    m = root / MANIFEST
    if not m.is_file():
        if (root / PLAN).is_file():
            raise InputError(root, None, f"a finished dataset ({MANIFEST} is written last)",
                             "an unfinished scoring run; run the same command again to finish it")
        return None
    try:
        doc = json.loads(m.read_text(encoding="utf-8"))
        files = [str(f) for f in doc["files"]]
    except (ValueError, KeyError, TypeError):
        raise InputError(m, "files", "a JSON object with a list of files", "unreadable") from None
    return {**doc, "files": files}


def dataset_files(path, *, what: str = "dataset") -> list[tuple[str, Path]]:
    """``(clip_id, file)`` of every Parquet file of the dataset, sorted by clip then name.

    Raises :class:`InputError` for a folder without ``clip_id=`` partitions, an unfinished run,
    or a file listed in ``_dataset.json`` that is missing.

    Parameters
    ----------
    path : str or Path
        The dataset folder.
    what : str, optional
        What the folder is, named in errors (e.g. ``'pairs dataset'``).

    Returns
    -------
    list of (str, Path)
        ``(clip_id, file)`` per Parquet file.
    """
    root = Path(path)
    if not root.is_dir():
        raise InputError(root, None, f"an existing {what} folder", "no such folder")
    doc = _manifest(root)
    found = sorted(f for f in root.glob(f"{PARTITION}=*/*.parquet") if not f.name.startswith("."))
    if not found:
        stray = next(iter(sorted(root.rglob("*.parquet"))), None)
        got = f"{stray.relative_to(root)} outside clip_id= folders" if stray else "no Parquet files"
        raise InputError(root, PARTITION, f"a {what} partitioned by clip_id "
                         "(clip_id=<id>/*.parquet)", got)
    if doc is not None:
        have = {f.relative_to(root).as_posix() for f in found}
        missing = [f for f in doc["files"] if f not in have]
        if missing:
            raise InputError(root, f"shard {missing[0]}", f"all {len(doc['files'])} files listed in "
                             f"{MANIFEST}", f"{len(missing)} missing")
        listed = set(doc["files"])
        found = [f for f in found if f.relative_to(root).as_posix() in listed]
    return [(clip_from_dir(f.parent.name), f) for f in found]


def check_schemas(files: Sequence[tuple[str, Path]], *, root) -> list[str]:
    """One schema for all files (names, order-free, and types); returns the column names.

    Parameters
    ----------
    files : sequence of (str, Path)
        ``(clip_id, file)`` pairs, as :func:`dataset_files` returns them.
    root : str or Path
        The dataset folder, named in errors.

    Returns
    -------
    list of str
        The shared column names, in the first file's order.
    """

    first_file, first = None, None
    for _, f in files:
        try:
            schema = pq.read_schema(f)
        except Exception as exc:  # noqa: BLE001 - any unreadable file is bad input
            raise InputError(f, None, "a readable Parquet file", f"{type(exc).__name__}: {exc}") from None
        fields = {n: str(schema.field(n).type) for n in schema.names}
        if PARTITION in fields:
            raise InputError(f, f"column {PARTITION!r}", "the clip id only in the folder name", "a column")
        if first is None:
            first_file, first = f, fields
            continue
        if fields != first:
            diff = sorted(set(fields) ^ set(first)) or sorted(
                n for n in fields if fields[n] != first[n] and not _null_type(fields[n], first[n]))
            if diff:
                col = diff[0]
                raise InputError(root, f"column {col!r}", f"one schema across clips (as in {first_file})",
                                 f"{fields.get(col, 'no such column')} in {f}")
    return list(first or ())


def _null_type(a: str, b: str) -> bool:
    return "null" in (a, b)


def _restore_clip(df: pd.DataFrame, clip_id: str) -> pd.DataFrame:
    df.insert(1 if "pair_id" in df.columns else 0, PARTITION, clip_id)
    return df


def iter_clips(path, *, what: str = "dataset") -> Iterator[tuple[str, pd.DataFrame]]:
    """Yield ``(clip_id, table)`` per clip (all of the clip's files), checking schema first.

    Parameters
    ----------
    path : str or Path
        The dataset folder.
    what : str, optional
        What the folder is, named in errors.

    Yields
    ------
    clip_id : str
        One clip, in sorted order.
    table : pandas.DataFrame
        That clip's rows, with its ``clip_id`` column restored.
    """

    root = Path(path)
    files = dataset_files(root, what=what)
    check_schemas(files, root=root)
    by_clip: dict[str, list[Path]] = {}
    for clip, f in files:
        by_clip.setdefault(clip, []).append(f)
    for clip, fs in by_clip.items():
        parts = [pq.read_table(f).to_pandas() for f in fs]
        df = parts[0] if len(parts) == 1 else pd.concat(parts, ignore_index=True)
        yield clip, _restore_clip(df, clip)


def read_dataset(path, *, what: str = "dataset") -> pd.DataFrame:
    """The whole dataset as one table (clips in sorted order), ``clip_id`` after ``pair_id``.

    Parameters
    ----------
    path : str or Path
        A partitioned dataset folder (``clip_id=<id>/`` Parquet parts).
    what : str, optional
        How errors call the folder, e.g. ``"metrics dataset"``.

    Returns
    -------
    pandas.DataFrame
        All rows of all clips, read through :func:`iter_clips`.
    """
    frames = [df for _, df in iter_clips(path, what=what)]
    return pd.concat(frames, ignore_index=True)


def write_manifest(root, files: Sequence[str], *, rows: int, extra: dict | None = None) -> None:
    """Write ``_dataset.json`` atomically (the last step of a complete dataset).

    Parameters
    ----------
    root : str or Path
        The dataset folder (usually the hidden folder being written).
    files : sequence of str
        The Parquet files, relative to ``root``.
    rows : int
        The total number of rows.
    extra : dict, optional
        More keys for the manifest.
    """

    doc = {"format": "nvrq-dataset", "version": 1, "partition": PARTITION,
           "rows": int(rows), "files": sorted(files), **(extra or {})}
    atomic_write_text(Path(root) / MANIFEST, json.dumps(doc, indent=1))


class DatasetWriter:
    """Write a whole dataset atomically: files go to a hidden sibling folder that replaces
    ``out`` only when the ``with`` block ends without an exception.

    ``write(clip_id, df)`` drops the ``clip_id`` column and writes
    ``clip_id=<id>/part-0.parquet``; string columns named in ``string_columns`` are stored as
    strings even when all values are missing, so every clip has one schema.

    Parameters
    ----------
    out : str or Path
        The dataset folder to (re)place.
    string_columns : sequence of str, optional
        Columns stored as strings whatever their values.
    """

    def __init__(self, out, *, string_columns: Sequence[str] = ()):
        self.out = Path(out)
        self.string_columns = set(string_columns)
        self.files: list[str] = []
        self.rows = 0

    def __enter__(self) -> DatasetWriter:
        if self.out.exists() and not self.out.is_dir():
            raise InputError(self.out, None, "a dataset folder (or a new path)", "an existing file")
        self._folder = atomic_folder(self.out)
        self.tmp = self._folder.__enter__()
        return self

    def write(self, clip_id: str, df: pd.DataFrame, *, name: str = "part-0") -> None:
        table = pa.Table.from_pandas(df.drop(columns=[PARTITION], errors="ignore"), preserve_index=False)
        for c in self.string_columns & set(table.column_names):
            i = table.column_names.index(c)
            table = table.set_column(i, c, table.column(c).cast(pa.string()))
        rel = f"{partition_dir(clip_id)}/{name}.parquet"
        (self.tmp / rel).parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(table, self.tmp / rel)
        self.files.append(rel)
        self.rows += len(df)

    def add_file(self, name: str, text: str) -> None:
        """A side file (e.g. ``failed.csv``) inside the dataset folder."""
        (self.tmp / name).write_text(text, encoding="utf-8")

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            write_manifest(self.tmp, self.files, rows=self.rows)
        self._folder.__exit__(exc_type, exc, tb)


def table_columns(path: str | Path) -> list[str]:
    """The column names of a table file (CSV or Parquet) or of a clip-partitioned dataset
    (this module's layout), read from its header (or first file's schema) only.

    Parameters
    ----------
    path : str or Path
        A ``.csv`` or ``.parquet`` file, or a dataset folder.

    Returns
    -------
    list of str
        The columns in file order.

    Raises
    ------
    InputError
        A dataset folder without partitions or unfinished (:func:`dataset_files`).
    """
    if is_dataset(path):
        return list(pq.read_schema(dataset_files(path)[0][1]).names)
    if str(path).lower().endswith(".parquet"):
        return list(pq.read_schema(path).names)
    return list(pd.read_csv(path, nrows=0).columns)
