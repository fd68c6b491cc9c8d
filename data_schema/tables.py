"""Tabular formats (docs/FORMATS.md §3-5): column names, reading with validation, atomic writing.

Tables are CSV or Parquet, chosen by the file suffix (``.csv`` / ``.parquet``).
Writing is atomic: the table goes to a temporary file beside the target and is renamed
into place, so an interrupted command never leaves a half-written file that looks complete.
"""

from __future__ import annotations

import contextlib
import enum
import math
import os
import re
import shutil
import tempfile
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath, PureWindowsPath

import numpy as np
import pandas as pd

from data_schema.defaults import MIN_SIDE_PX, MIN_VISIBLE  # shared by nvrq pairs and nvrq stability
from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN, check_table_methods, method_suffix
from data_schema.perturbation import perturbation_array, view_suffix
from data_schema.vocab import ItemKind

__all__ = [
    "PAIRS_COLUMNS",
    "RATINGS_COLUMNS",
    "PAIRWISE_VOTES_COLUMNS",
    "ITEM_KINDS",
    "TIMING_COLUMNS",
    "timing_path",
    "PAIR_META_COLUMNS",
    "OBJECT_COLUMNS",
    "IMAGES_COLUMNS",
    "TABLE_SUFFIXES",
    "MIN_SIDE_PX",
    "MIN_VISIBLE",
    "SOURCE_VISIBILITY",
    "VISIBILITY_COLUMNS",
    "pair_id",
    "pair_ids",
    "csv_line",
    "offset_cm",
    "parse_offsets",
    "read_table",
    "require_columns",
    "write_table",
    "atomic_write_text",
    "atomic_path",
    "atomic_folder",
    "current_umask",
    "GT_BOX_COLUMNS",
    "RENDER_BOX_COLUMNS",
    "pair_scene_roots",
    "check_pairs",
    "check_metrics",
    "check_scene_path",
    "inside_scene",
    "NO_FOLLOW_LINKS_ENV",
    "follow_links",
    "no_follow_links",
    "read_metrics",
    "TABLE_CHECKS",
    "pair_image_paths",
    "pair_boxes",
    "TableKind",
    "PairsTable",
    "pairs_table",
]

TABLE_SUFFIXES = (".csv", ".parquet")


#: docs/FORMATS.md §2, images.csv
IMAGES_COLUMNS = ("camera", "timestamp_us", "source", "y_offset_m", "path")

#: docs/FORMATS.md §3, fixed columns of a pairs table (scene attributes follow as extra columns).
PAIRS_COLUMNS = (
    "pair_id", "clip_id", "camera", "track_id", "label_class", "timestamp_us", "y_offset_m",
    "gt_path", "render_path", "gt_x0", "gt_y0", "gt_x1", "gt_y1", "r_x0", "r_y0", "r_x1", "r_y1",
)

#: docs/FORMATS.md §3: the object's visible fractions in the GT view and in the novel view
#: (:mod:`nvrq.geometry.visibility`), and the dataset's own visibility label where it has one.
VISIBILITY_COLUMNS = ("gt_visible", "novel_visible")
SOURCE_VISIBILITY = "source_visibility"

#: docs/FORMATS.md §5, the pair metadata carried into ratings.csv (attributes follow).
PAIR_META_COLUMNS = ("clip_id", "camera", "track_id", "label_class", "timestamp_us", "y_offset_m")

#: docs/FORMATS.md §3, §11-12: the columns that name one object in one frame (one GT crop)
#: and, with the view (the perturbation columns of :mod:`data_schema.perturbation`), one object
#: seen from one view, an *object view*: the key on which the renders of several methods are
#: paired. Its id is the pair id without a method (:func:`pair_ids`), the view compared at the
#: 0.01 precision of pair ids.
OBJECT_COLUMNS = ("clip_id", "camera", "track_id", "timestamp_us")

#: docs/FORMATS.md §5, fixed leading columns of ratings.csv.
RATINGS_COLUMNS = ("item_id", "rater_id", "vote", "voted_at", "response_ms", "kind")

#: docs/FORMATS.md §11-12, the leading columns of a pairwise study's votes (``annotate export``
#: writes them, then ``voted_at, response_ms`` and the object's columns).
PAIRWISE_VOTES_COLUMNS = ("item_id", "rater_id", "kind", "method_a", "method_b", "side_a", "choice")

#: docs/FORMATS.md §5, the values of ratings.csv's ``kind`` (and of a study item's kind).
ITEM_KINDS = tuple(ItemKind)

#: docs/FORMATS.md §4, the columns of ``METRICS.timing.csv``.
TIMING_COLUMNS = ("metric", "seconds", "pairs")


def timing_path(metrics_path: str | os.PathLike) -> Path:
    """The timing table written beside a metrics table: ``x/M.{csv,parquet}`` -> ``x/M.timing.csv``.

    Parameters
    ----------
    metrics_path : str or path-like
        The metrics table's path.

    Returns
    -------
    Path
        The timing table's path.

    >>> timing_path("out/M.parquet").as_posix()
    'out/M.timing.csv'
    """
    path = Path(metrics_path)
    return path.with_name(path.stem + ".timing.csv")


def pair_id(clip_id: str, camera: str, track_id: str, timestamp_us: int, y_offset_m: float, *,
            method: str = "") -> str:
    """docs/FORMATS.md §3 pair id (of a lateral view; ``method``: the render's method, if any).

    Parameters
    ----------
    clip_id : str
        The clip.
    camera : str
        The camera.
    track_id : str
        The object's track.
    timestamp_us : int
        The frame's timestamp, in microseconds.
    y_offset_m : float
        The lateral render offset, in metres (2 decimals in the id).
    method : str
        The render's method; ``''`` for none.

    Returns
    -------
    str
        ``CLIP:CAMERA:TRACK:T:+Y.YY`` then ``:METHOD`` when given.

    >>> pair_id("clip", "front", "car-1", 100000, 1.0)
    'clip:front:car-1:100000:+1.00'
    >>> pair_id("clip", "front", "car-1", 0, -0.5, method="3dgs")
    'clip:front:car-1:0:-0.50:3dgs'
    """
    base = f"{clip_id}:{camera}:{track_id}:{int(timestamp_us)}:{float(y_offset_m):+.2f}"
    return base + method_suffix([method])[0]


def pair_ids(df: pd.DataFrame, methods=None) -> list[str]:
    """docs/FORMATS.md §3 and §9 pair id of each row of ``df``: ``CLIP:CAMERA:TRACK:T:VIEW``,
    then ``:METHOD`` for a row with a method. Without methods it is the id of the row's object
    view (:data:`OBJECT_COLUMNS` and the view).

    Parameters
    ----------
    df : pandas.DataFrame
        (N rows) :data:`OBJECT_COLUMNS` and the view columns (``y_offset_m``, the optional
        6-DoF ones).
    methods : sequence of str, optional
        (N,) each row's method, ``''`` for none (default: no method).

    Returns
    -------
    list of str

    >>> df = pd.DataFrame({"clip_id": ["c", "c"], "camera": ["f", "f"], "track_id": ["t", "t"],
    ...                    "timestamp_us": [5, 5], "y_offset_m": [1.0, 0.0], "yaw_deg": [0.0, 5.0]})
    >>> pair_ids(df), pair_ids(df, ["3dgs", ""])
    (['c:f:t:5:+1.00', 'c:f:t:5:yaw=+5.00'], ['c:f:t:5:+1.00:3dgs', 'c:f:t:5:yaw=+5.00'])
    """
    clip, camera, track, ts = (df[c] for c in OBJECT_COLUMNS)
    ts = pd.to_numeric(ts).astype(np.int64)
    views = view_suffix(perturbation_array(df))
    suffix = [""] * len(df) if methods is None else method_suffix(methods)
    return [f"{c}:{cam}:{t}:{s}:{v}{m}" for c, cam, t, s, v, m in zip(
        clip, camera, track, ts, views, suffix, strict=True)]


def offset_cm(y_offset_m) -> np.ndarray:
    """Offsets in metres -> integer centimetres, the precision of :func:`pair_id`; same shape.

    Parameters
    ----------
    y_offset_m : float or array-like
        Offsets in metres.

    Returns
    -------
    int64 ndarray
        Offsets in centimetres, rounded, same shape.

    >>> offset_cm([0.004, -1.5, 2.999]).tolist()
    [0, -150, 300]
    """
    return np.round(np.asarray(y_offset_m, dtype=np.float64) * 100).astype(np.int64)


def parse_offsets(text: str, *, field: str = "offsets") -> list[float]:
    """A comma list of render offsets in metres -> floats in the given order.

    Parameters
    ----------
    text : str
        E.g. ``'-3,-2,0,1.5'``.
    field : str
        The parameter or option named in errors (its ``param``).

    Returns
    -------
    list of float

    Raises
    ------
    InputError
        An item is not a finite number, or there is none.

    >>> parse_offsets("-3,-2, 0,1.5")
    [-3.0, -2.0, 0.0, 1.5]
    """
    expected = "a comma list of finite numbers of metres, e.g. -3,-2,-1,0,1,2,3"
    try:
        values = [float(t) for t in str(text).split(",") if t.strip()]
    except ValueError:
        raise InputError(param=field, expected=expected, got=text) from None
    if not values or not all(math.isfinite(v) for v in values):
        raise InputError(param=field, expected=expected, got=text)
    return values


def _check_suffix(path: Path, what: str) -> str:
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise InputError(path, None, f"a {what} file ending in .csv or .parquet", suffix or "no suffix")
    return suffix


class TableKind(str, enum.Enum):
    """The kinds of table :func:`read_table` reads; each kind has its checks
    (:data:`TABLE_CHECKS`) and its name in errors (the value).

    >>> TableKind.PAIRS.value, TableKind("metrics table") is TableKind.METRICS
    ('pairs table', True)
    """

    TABLE = "table"
    PAIRS = "pairs table"
    METRICS = "metrics table"


def read_table(
    path: str | os.PathLike,
    *,
    required: Sequence[str] = (),
    what: str | None = None,
    dtype: dict | None = None,
    kind: TableKind | None = None,
) -> pd.DataFrame:
    """Read a CSV/Parquet table and check that ``required`` columns are present.

    Parameters
    ----------
    path : path
        A ``.csv`` or ``.parquet`` file.
    required : sequence of str
        Columns it must have.
    what : str, optional
        The name errors give the table (default: ``kind``'s). Deprecated: a ``what`` equal to
        a :class:`TableKind`'s value (``'pairs table'``) without ``kind`` still chooses that
        kind, with a :class:`DeprecationWarning` (the checks come from ``kind`` alone).
    dtype : dict, optional
        CSV column dtypes.
    kind : TableKind, optional
        The table's kind: its checks (:data:`TABLE_CHECKS`) run once, here.

    Returns
    -------
    pandas.DataFrame
        The table, numbers converted by the kind's checks.

    Raises
    ------
    InputError
        Naming the file and the first missing column or bad value.
    """
    if kind is None:
        kind = TableKind.TABLE
        if what in {k.value for k in TableKind}:  # the older spelling: a typo skipped the checks
            warnings.warn(f"read_table(what={what!r}) choosing the checks is deprecated: pass "
                          f"kind=TableKind.{TableKind(what).name}", DeprecationWarning, stacklevel=2)
            kind = TableKind(what)
    what = what or kind.value
    path = Path(path)
    if not path.exists():  # before the suffix: a missing path is missing, whatever its name
        raise InputError(path, None, f"an existing {what} file", "no such file")
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
    require_columns(df, required, where=path)
    check = TABLE_CHECKS.get(kind)
    return df if check is None else check(df, where=str(path))


def require_columns(df: pd.DataFrame, required: Sequence[str], *, where: object) -> pd.DataFrame:
    """``df`` if it has every column of ``required``; else :class:`InputError` naming ``where``
    and the first missing column (and listing the columns it has).

    Parameters
    ----------
    df : pandas.DataFrame
        The table.
    required : sequence of str
        The columns it must have.
    where : object
        What errors name (the table's file).

    Returns
    -------
    pandas.DataFrame
        ``df`` itself.
    """
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise InputError(where, f"column {missing[0]!r}", f"the columns {', '.join(required)}",
                         f"columns {', '.join(map(str, df.columns))}")
    return df


def csv_line(i: int) -> str:
    """``'line N'`` of the table row at position ``i`` (0-based) in its CSV file (the header is
    line 1), as errors name it.

    Parameters
    ----------
    i : int
        The row's 0-based position.

    Returns
    -------
    str
        ``'line N'`` with N = ``i + 2``.

    >>> csv_line(0)
    'line 2'
    """
    return f"line {i + 2}"


def _first(mask) -> int:
    return int(np.flatnonzero(np.asarray(mask))[0])


def _unique_ids(df: pd.DataFrame, col: str, where: str) -> None:
    if col not in df.columns:
        return
    empty = df[col].isna() | (df[col].astype(str).str.strip() == "")
    if empty.any():
        raise InputError(where, f"{csv_line(_first(empty))}: {col}", f"a {col}", "empty")
    dup = df[col].astype(str).duplicated()
    if dup.any():
        i = _first(dup)
        raise InputError(where, f"{csv_line(i)}: {col}", "each pair once", f"{df[col].iloc[i]!r} again")


def _numeric(df: pd.DataFrame, col: str, where: str, what: str, *, integer: bool = False) -> None:
    num = pd.to_numeric(df[col], errors="coerce")
    bad = ~np.isfinite(num.to_numpy(dtype=float))
    if integer:
        bad |= ~bad & (num.fillna(0) != np.round(num.fillna(0))).to_numpy()
    if bad.any():
        i = _first(bad)
        raise InputError(where, f"{csv_line(i)}: column {col!r}", what, repr(df[col].iloc[i]))
    df[col] = num.astype(np.int64) if integer else num.astype(np.float64)


def check_pairs(df: pd.DataFrame, *, where: str) -> pd.DataFrame:
    """docs/FORMATS.md §3 checks of the columns present: unique non-empty ``pair_id``; integer
    ``timestamp_us`` and box corners; finite ``y_offset_m``; ``gt_path``/``render_path``
    inside the scene folder (:func:`check_scene_path`); valid ``method`` names (when the
    column is there). Returns ``df`` (numbers converted).

    Parameters
    ----------
    df : pandas.DataFrame
        A pairs table as read; its number columns are converted in place.
    where : str
        The pairs file, named in errors.

    Returns
    -------
    pandas.DataFrame
        The same ``df``: ``timestamp_us`` and box corners int64, ``y_offset_m`` float64.
    """
    _unique_ids(df, "pair_id", where)
    if METHOD_COLUMN in df.columns:
        check_table_methods(df, where=where, what="line")
    for col in ("timestamp_us", *GT_BOX_COLUMNS, *RENDER_BOX_COLUMNS):
        if col in df.columns:
            _numeric(df, col, where, "an integer", integer=True)
    if "y_offset_m" in df.columns:
        _numeric(df, "y_offset_m", where, "a finite number of metres")
    for col in ("gt_path", "render_path"):
        if col in df.columns:
            bad = _outside_scene(df[col])
            if bad.any():  # vectorised screen; the first offender gets the full message
                i = _first(bad)
                check_scene_path(df[col].iloc[i], where=where, field=f"{csv_line(i)}: column {col!r}")
    return df


_OUTSIDE = re.compile(r"^\s*$|^[/\\]|^[A-Za-z]:|(?:^|[/\\])\.\.(?:[/\\]|$)")


def _outside_scene(paths: pd.Series):
    """Boolean mask of values that break :func:`check_scene_path` (empty, absolute, ``..``);
    each distinct value is tested once."""
    uniq = pd.unique(paths)
    bad = {v: not isinstance(v, str) or _OUTSIDE.search(v) is not None for v in uniq}
    return paths.map(bad).to_numpy(dtype=bool)


def check_metrics(df: pd.DataFrame, *, where: str) -> pd.DataFrame:
    """docs/FORMATS.md §4 checks: at least one row; each ``pair_id`` once; numeric metric values.

    Parameters
    ----------
    df : pandas.DataFrame
        A metrics table as read; text metric columns are made numeric in place.
    where : str
        The metrics file, named in errors.

    Returns
    -------
    pandas.DataFrame
        The same ``df``, every column but ``pair_id`` numeric.
    """
    if len(df) == 0:
        raise InputError(where, None, "at least one metrics row", "a header only")
    _unique_ids(df, "pair_id", where)
    for col in df.columns:
        if col == "pair_id" or pd.api.types.is_numeric_dtype(df[col]) or pd.api.types.is_bool_dtype(df[col]):
            continue
        conv = pd.to_numeric(df[col], errors="coerce")
        bad = conv.isna() & df[col].notna()
        if bad.any():
            i = _first(bad)
            raise InputError(where, f"{csv_line(i)}: column {col!r}", "a numeric metric value", df[col].iloc[i])
        df[col] = conv
    return df


def read_metrics(path) -> pd.DataFrame:
    """Read a metrics table (docs/FORMATS.md §4): ``pair_id`` + numeric metric columns.

    Parameters
    ----------
    path : str or path-like
        The metrics table (CSV or Parquet).

    Returns
    -------
    pandas.DataFrame
        The checked table, ``pair_id`` as str.
    """
    return read_table(path, required=("pair_id",), kind=TableKind.METRICS, dtype={"pair_id": str})


#: docs/FORMATS.md §7: set to 1 (or pass ``--no-follow-links``) to refuse image paths whose
#: symbolic links lead outside the scene folder; by default links are followed.
NO_FOLLOW_LINKS_ENV = "NVRQ_NO_FOLLOW_LINKS"


def follow_links(follow: bool | None = None) -> bool:
    """Whether image paths may follow symbolic links out of the scene folder: ``follow`` when
    given, else yes unless ``$NVRQ_NO_FOLLOW_LINKS`` is set (to anything but ``''`` or ``0``).

    Parameters
    ----------
    follow : bool or None
        The rule when given; None: from the environment.

    Returns
    -------
    bool
        Whether links may be followed.

    >>> follow_links(False), follow_links(True)
    (False, True)
    """
    if follow is not None:
        return bool(follow)
    return os.environ.get(NO_FOLLOW_LINKS_ENV, "").strip() in ("", "0")


@contextlib.contextmanager
def no_follow_links(strict: bool = True):
    """Within the block, the strict link rule applies (``strict``; else nothing changes): it sets
    ``$NVRQ_NO_FOLLOW_LINKS=1``, so threads, subprocesses and a Ray instance started here see it
    too, and restores the variable on exit. The ``--no-follow-links`` option of the CLIs.

    Parameters
    ----------
    strict : bool
        Whether to apply the strict rule; False: nothing changes.

    Yields
    ------
    None
        Control, inside the block.
    """
    if not strict:
        yield
        return
    old = os.environ.get(NO_FOLLOW_LINKS_ENV)
    os.environ[NO_FOLLOW_LINKS_ENV] = "1"
    try:
        yield
    finally:
        if old is None:
            os.environ.pop(NO_FOLLOW_LINKS_ENV, None)
        else:
            os.environ[NO_FOLLOW_LINKS_ENV] = old


def check_scene_path(rel, *, where: str, field: str) -> str:
    """The path rule of ``images.csv`` and pairs tables: a non-empty path relative to the
    scene folder, without ``..`` (checked on the text; symbolic links by :func:`inside_scene`).

    Parameters
    ----------
    rel : str
        The path to check.
    where : str
        What errors name (the file).
    field : str
        The field errors name.

    Returns
    -------
    str
        ``rel`` unchanged.

    >>> check_scene_path("images/a.png", where="pairs.csv", field="gt_path")
    'images/a.png'
    >>> check_scene_path("../x.png", where="pairs.csv", field="gt_path")
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: pairs.csv: gt_path: expected a path inside the scene folder (relative, no '..'), got ../x.png
    """
    if not isinstance(rel, str) or not rel.strip():
        raise InputError(where, field, "a relative image path", repr(rel))
    posix = rel.replace("\\", "/")
    if PurePosixPath(posix).is_absolute() or PureWindowsPath(rel).is_absolute() \
            or PureWindowsPath(rel).drive or ".." in PurePosixPath(posix).parts:
        raise InputError(where, field, "a path inside the scene folder (relative, no '..')", rel)
    return rel


def inside_scene(root, rel: str, *, where: str, field: str, linked: dict | None = None,
                 follow: bool | None = None) -> str:
    """``root/rel`` as a string after :func:`check_scene_path` (docs/FORMATS.md §7).

    Symbolic links on the way are followed (an image folder linked from other storage), unless
    :func:`follow_links` of ``follow`` is false: then the resolved file must lie in the
    resolved ``root``. ``linked``: one table's cache, per parent folder of ``rel``, of whether a
    folder on its way is a symlink, so rows in the same few folders check each folder once (the
    file every time).

    Parameters
    ----------
    root : str or path-like
        The scene folder.
    rel : str
        The image path relative to ``root``.
    where : str
        What errors name (the file).
    field : str
        The field errors name.
    linked : dict or None
        A table's cache of whether a folder on the way is a symlink.
    follow : bool or None
        The link rule (:func:`follow_links`); None: from the environment.

    Returns
    -------
    str
        The joined path ``root/rel``.
    """
    check_scene_path(rel, where=where, field=field)
    path = os.path.join(str(root), rel)
    if follow_links(follow):
        return path
    parts = Path(rel).parts
    via_link = None if linked is None else linked.get(parts[:-1])
    if via_link is None:
        via_link = any(os.path.islink(os.path.join(str(root), *parts[:k])) for k in range(1, len(parts)))
        if linked is not None:
            linked[parts[:-1]] = via_link
    if via_link or os.path.islink(path):
        real, base = os.path.realpath(path), os.path.realpath(str(root))
        if os.path.commonpath([real, base]) != base:
            raise InputError(where, field, "a file inside the scene folder (a symlink leaves it, and "
                             f"links are not followed: `no_follow_links` or {NO_FOLLOW_LINKS_ENV}=1)", rel)
    return path


#: The checks applied by :func:`read_table` to a table of each :class:`TableKind`.
TABLE_CHECKS = {TableKind.PAIRS: check_pairs, TableKind.METRICS: check_metrics}


def current_umask() -> int:
    """The process's umask (read from ``/proc/self/status`` where it can be, else set and restored).

    Returns
    -------
    int
        The umask, e.g. ``0o022``. Temporary files and folders (``mkstemp``, ``mkdtemp``) are
        private (0600/0700) whatever it is; :class:`atomic_path` and :class:`atomic_folder` give
        their outputs the mode a plain ``open``/``mkdir`` would have.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


class atomic_path:
    """Context manager yielding a temporary path beside ``target``; renamed onto it on success.

    Parameters
    ----------
    target : str or path-like
        The output file (its folder is created if needed).

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
        if self.target.is_dir():
            raise InputError(self.target, None, "an output file path", "an existing folder")
        try:
            self.target.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{self.target.name}.", suffix=".part" + self.target.suffix,
                                       dir=self.target.parent)
        except OSError as exc:
            raise _write_error(self.target, exc) from None
        os.close(fd)
        os.chmod(tmp, 0o666 & ~current_umask())  # mkstemp makes 0600: the output follows the umask
        self.tmp = Path(tmp)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            try:
                os.replace(self.tmp, self.target)
                return False
            except OSError as err:
                exc = err
        self.tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise _write_error(self.target, exc) from None
        return False


class atomic_folder:
    """Context manager yielding a new empty folder beside ``target``; on success it takes the
    place of ``target`` (a folder already there is moved aside, then removed), on an exception
    it is removed and ``target`` is left as it was. The parent folders of ``target`` are created
    when missing.

    Parameters
    ----------
    target : str or os.PathLike
        The folder to write.
    mode : int, optional
        The new folder's mode (default: 0o777 less the umask, as ``mkdir`` makes a folder; a
        study folder is 0o700).

    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_folder(d / "out") as tmp:
    ...     _ = (tmp / "x.txt").write_text("hi")
    >>> (d / "out" / "x.txt").read_text(), sorted(p.name for p in d.iterdir())
    ('hi', ['out'])
    """

    def __init__(self, target: str | os.PathLike, *, mode: int | None = None):
        self.target = Path(target)
        self.mode = 0o777 & ~current_umask() if mode is None else mode

    def __enter__(self) -> Path:
        out = self.target
        out.parent.mkdir(parents=True, exist_ok=True)
        self.tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".part", dir=out.parent))
        os.chmod(self.tmp, self.mode)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> bool:
        out = self.target
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            return False
        old = None
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".old", dir=out.parent))
            os.replace(out, old / out.name)
        os.replace(self.tmp, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        return False


def _write_error(target: Path, exc: OSError) -> InputError:
    """One-line error for an output that cannot be written (read-only folder, disk full...)."""
    return InputError(target, None, "a writable output location", exc.strerror or type(exc).__name__)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically.

    Parameters
    ----------
    path : str or path-like
        The output file.
    text : str
        The text, written as UTF-8.
    """
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_table(df: pd.DataFrame, path: str | os.PathLike, *, columns: Iterable[str] | None = None) -> Path:
    """Write ``df`` as CSV or Parquet (by suffix) atomically; returns the path.

    Parameters
    ----------
    df : pandas.DataFrame
        The table (written without its index).
    path : str or path-like
        The output file, ``.csv`` or ``.parquet``.
    columns : iterable of str or None
        The columns to write, in order; None: all.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    suffix = _check_suffix(path, "table")
    if columns is not None:
        df = df.loc[:, list(columns)]
    with atomic_path(path) as tmp:
        if suffix == ".csv":
            df.to_csv(tmp, index=False)
        else:
            df.to_parquet(tmp, index=False)
    return path


# --- reading a pairs table's images and boxes (used by score, annotate, proxies, stability) ---

GT_BOX_COLUMNS = ("gt_x0", "gt_y0", "gt_x1", "gt_y1")
RENDER_BOX_COLUMNS = ("r_x0", "r_y0", "r_x1", "r_y1")


def pair_scene_roots(df: pd.DataFrame, *, scene_root=None, base=None, where: str = "pairs"):
    """Absolute scene folder of every pair row, ``(N,)`` object array of strings.

    Rule: ``scene_root`` (the ``--scene`` option) when given; else the table's ``scene_root``
    column, a relative value taken from ``base`` (the pairs file's folder; default the
    current directory). ``gt_path``/``render_path`` are relative to that folder.

    Parameters
    ----------
    df : pandas.DataFrame
        The pairs table (N rows).
    scene_root : str or path-like or None
        The one scene folder of every row (``--scene``).
    base : str or path-like or None
        The folder relative ``scene_root`` values start from.
    where : str
        What errors name (the pairs file).

    Returns
    -------
    (N,) object ndarray of str
        Absolute scene folders.
    """
    if scene_root is not None:
        root = Path(scene_root).resolve()
        if not root.is_dir():
            raise InputError(param="scene_root", expected="an existing scene folder", got=str(scene_root))
        return np.full(len(df), str(root), dtype=object)
    if "scene_root" not in df.columns:
        raise InputError(where, "column 'scene_root'",
                         "a scene folder (scene_root) or a scene_root column (gt_path/render_path are relative to it)",
                         "neither")
    base = Path(base) if base is not None else Path.cwd()
    uniq = {r: str((base / str(r)).resolve()) for r in df["scene_root"].astype(str).unique()}
    return df["scene_root"].astype(str).map(uniq).to_numpy(dtype=object)


def pair_image_paths(df: pd.DataFrame, column: str, *, scene_root=None, base=None,
                     where: str = "pairs", follow: bool | None = None):
    """Absolute image paths of ``column`` (``gt_path`` or ``render_path``), ``(N,)`` object array.

    Every path obeys the scene-folder rule (:func:`inside_scene`, links followed as ``follow``
    says) and names an existing file.

    Parameters
    ----------
    df : pandas.DataFrame
        The pairs table (N rows).
    column : str
        ``'gt_path'`` or ``'render_path'``.
    scene_root, base : str or path-like or None
        How each row's scene folder is found (:func:`pair_scene_roots`).
    where : str
        The pairs file, named in errors with the row and ``column``.
    follow : bool or None
        The link rule (:func:`follow_links`); None: from the environment.

    Returns
    -------
    (N,) object ndarray of str
        Absolute paths of existing image files.
    """
    roots = pair_scene_roots(df, scene_root=scene_root, base=base, where=where)
    rel = df[column].to_numpy(dtype=object)
    seen: dict = {}
    for i, key in enumerate(zip(roots, rel, strict=True)):
        if key not in seen:  # each distinct image once (lstat calls for the strict link rule)
            field = f"{csv_line(i)}: column {column!r}"
            seen[key] = inside_scene(*key, where=where, field=field, follow=follow)
            if not os.path.isfile(seen[key]):
                raise InputError(where, field, "an existing image file", f"{key[1]} (not found)")
    return np.array([seen[k] for k in zip(roots, rel, strict=True)], dtype=object)


def pair_boxes(df: pd.DataFrame, columns, *, where: str = "pairs"):
    """Inclusive integer boxes ``(N, 4)`` int64 from four columns (e.g. :data:`GT_BOX_COLUMNS`).

    Parameters
    ----------
    df : pandas.DataFrame
        The pairs table (N rows).
    columns : sequence of str
        The four box columns x0, y0, x1, y1.
    where : str
        What errors name (the pairs file).

    Returns
    -------
    (N, 4) int64 ndarray
        Inclusive pixel boxes x0, y0, x1, y1.
    """
    columns = list(columns)
    vals = df[columns].to_numpy()
    try:
        arr = vals.astype(np.float64)
    except (TypeError, ValueError):
        raise InputError(where, f"columns {', '.join(columns)}", "integer pixel indices", "non-numbers") from None
    bad = ~np.isfinite(arr).all(axis=1) | (arr != np.round(arr)).any(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(where, f"row {i + 2}, columns {', '.join(columns)}", "integer pixel indices",
                         vals[i].tolist())
    return arr.astype(np.int64)


# --- typed tables: read and checked once, then handed down --------------------------------------

@dataclass(frozen=True)
class PairsTable:
    """A pairs table checked once (:func:`pairs_table`): boxes as integer arrays and
    image paths made absolute, so nothing downstream parses or checks them again.

    Attributes
    ----------
    frame : pandas.DataFrame
        The N rows, numbers converted (:func:`check_pairs`).
    gt_boxes, render_boxes : (N, 4) int64
        Inclusive pixel boxes ``x0, y0, x1, y1`` (:data:`GT_BOX_COLUMNS`, :data:`RENDER_BOX_COLUMNS`).
    gt_paths, render_paths : (N,) object arrays of str
        Absolute image paths, each inside its scene folder and an existing file.
    where : str
        What errors name (the pairs file).
    """

    frame: pd.DataFrame
    gt_boxes: np.ndarray
    render_boxes: np.ndarray
    gt_paths: np.ndarray
    render_paths: np.ndarray
    where: str

    def __len__(self) -> int:
        return len(self.frame)

    def take(self, rows) -> PairsTable:
        """The rows ``rows`` (positions), in that order.

        Parameters
        ----------
        rows : (K,) int array

        Returns
        -------
        PairsTable
        """
        rows = np.asarray(rows, np.int64)
        return PairsTable(self.frame.iloc[rows].reset_index(drop=True), self.gt_boxes[rows],
                          self.render_boxes[rows], self.gt_paths[rows], self.render_paths[rows], self.where)


#: the columns a :class:`PairsTable` needs (besides ``scene_root`` or a scene folder)
PAIRS_CROP_COLUMNS = ("pair_id", "gt_path", "render_path", *("gt_x0", "gt_y0", "gt_x1", "gt_y1"),
                      *("r_x0", "r_y0", "r_x1", "r_y1"))


def pairs_table(df: pd.DataFrame, *, scene_root=None, base=None, where: str = "pairs",
                follow: bool | None = None) -> PairsTable:
    """A :class:`PairsTable` of pairs held in memory: the columns, boxes and image paths
    checked once.

    Parameters
    ----------
    df : pandas.DataFrame
        docs/FORMATS.md §3 columns (:data:`PAIRS_CROP_COLUMNS`).
    scene_root, base : path, optional
        Where the image paths are relative to (:func:`pair_scene_roots`).
    where : str
        What errors name.
    follow : bool, optional
        The link rule (:func:`follow_links`).

    Returns
    -------
    PairsTable

    Raises
    ------
    InputError
        A missing column, a bad box, or an image path outside its scene or missing.
    """
    require_columns(df, PAIRS_CROP_COLUMNS, where=where)
    paths = [pair_image_paths(df, c, scene_root=scene_root, base=base, where=where, follow=follow)
             for c in ("gt_path", "render_path")]
    return PairsTable(df, pair_boxes(df, GT_BOX_COLUMNS, where=where), pair_boxes(df, RENDER_BOX_COLUMNS, where=where),
                      paths[0], paths[1], str(where))
