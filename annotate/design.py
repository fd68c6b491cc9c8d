"""The study design (paper section 4): which tracks, frames and views raters see.

Layer: annotate (rating study).

Pure functions on a pairs table (docs/FORMATS.md §3). A *track* is ``(clip_id, track_id)``; a
*frame* of it is ``(camera, timestamp_us)``. A *view* is a render perturbation, keyed by its
label (:mod:`data_schema.perturbation`; a lateral offset ``y`` is the view ``y=+1.00``, 0 is
``none``). A frame is usable when the pairs table holds the object in **every** chosen view
there, so with views along several axes (``'all'``) every chosen frame is shown along each
axis; raters never see which (items are opaque).

- :func:`parse_offsets`: ``'all'`` or a comma list, matched at 0.01 m (as in ``pair_id``).
- :func:`choose_views`: ``'all'`` (every view of the table) or lateral offsets as labels.
- :func:`choose_tracks`: tracks spread over strata (label class x scene attributes):
  strata are visited round-robin in a seeded random order, one random track each visit.
- :func:`spread_frames`: ``k`` frames evenly along the track (by time), first and last
  included.
- :func:`pick_training`: the training items, outside the test set, offsets from large to small
  (the first ones clearly different from their GT crop).
- :func:`choose_tests`: the views, test rows and training rows of a study, by the three above.

The two study designs, good/bad votes (:class:`annotate.binary.BinaryDesign`) and which of two
methods (:class:`annotate.pairwise.PairwiseDesign`), are two implementations of
:class:`Design`: ``annotate build`` (:func:`annotate.study.build_study`) checks its options into
one frozen :class:`StudyOptions`, lets the design choose the items (a :class:`Choice`), checks
the images they need, cuts their crops and adds the design's manifest keys.

>>> spread_frames(10, 4)
[0, 3, 6, 9]
>>> spread_frames(3, 12)
[0, 1, 2]
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np
import pandas as pd

from annotate.load import DEFAULT_ITEMS_PER_RATER
from data_schema.defaults import BREAK_EVERY, DISPLAY_SIZE
from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN
from data_schema.perturbation import (
    AXES,
    EXTRA_PERTURBATION_COLUMNS,
    VIEW_COLUMNS,
    labels,
    lateral,
    perturbation_array,
)
from data_schema.tables import PAIRS_COLUMNS, offset_cm, parse_offsets
from data_schema.vocab import Access, StudyDesign

__all__ = ["choose_offsets", "choose_views", "attribute_columns", "usable_frames", "choose_tracks",
           "spread_frames", "select_test_pairs", "pick_training", "choose_tests", "StudyOptions", "Choice",
           "Design", "GOLD_POOL"]

#: Gold items are cut for this many times the gold items one rater sees (``2 x n_gold``, as
#: far as the test items allow); each rater's are drawn from that pool
#: (:func:`annotate.assign.draw_gold`), so counting which items more than ``votes_per_item``
#: identities see does not single the gold out.
GOLD_POOL = 4

_EXTRA_NON_ATTRIBUTES = ("scene_root", *VIEW_COLUMNS, METHOD_COLUMN)


def attribute_columns(pairs: pd.DataFrame) -> list[str]:
    """Scene attribute columns: those after the contract columns (``scene_root``, the view
    columns, ``method`` and ``_*`` excluded).

    Parameters
    ----------
    pairs : pandas.DataFrame
        A pairs table.

    Returns
    -------
    list of str
    """
    return [c for c in pairs.columns if c not in PAIRS_COLUMNS
            and c not in _EXTRA_NON_ATTRIBUTES and not str(c).startswith("_")]


def choose_offsets(spec: str, available) -> list[float]:
    """Chosen offsets (sorted, metres) from ``'all'`` or ``'0,1.5,-1.5'``, among ``available``.

    Parameters
    ----------
    spec : str
        ``'all'`` or a comma list of offsets, metres.
    available : iterable of float
        The offsets of the pairs table, metres.

    Returns
    -------
    list of float
        Sorted, metres.

    Raises
    ------
    InputError
        No offset, or one not in ``available``.

    >>> choose_offsets("all", [0.0, 1.0, -1.0, 1.0])
    [-1.0, 0.0, 1.0]
    >>> choose_offsets("1, 0", [0.0, 1.0, -1.0])
    [0.0, 1.0]
    """
    have = sorted(set(offset_cm(available).tolist()))
    if str(spec).strip().lower() == "all":
        chosen = have
    else:
        chosen = sorted(set(offset_cm(parse_offsets(spec, field="offsets")).tolist()))
        missing = [c for c in chosen if c not in have]
        if missing or not chosen:
            raise InputError(param="offsets", expected=f"offsets present in the pairs table ({[h / 100 for h in have]})",
                             got=spec)
    return [c / 100 for c in chosen]


def _view_keys(views) -> list[str]:
    """View labels from labels, or from lateral offsets in metres (the former API)."""
    views = list(views)
    if all(isinstance(v, str) for v in views):
        return views
    return labels(lateral(views))


def _view_order(label: str) -> tuple:
    """Sort key of a view label: axis order, then value ('none' first)."""
    if label == "none":  # the real camera sits at 0 among the lateral offsets
        return (AXES.index("y"), 0.0, label)
    axis, _, value = label.split(",")[0].partition("=")
    return (AXES.index(axis) if "," not in label else len(AXES), float(value), label)


def choose_views(spec: str, pairs: pd.DataFrame) -> list[str]:
    """Chosen view labels: ``'all'`` -> every view of ``pairs`` (old tables: their offsets);
    else a comma list of lateral offsets in metres (:func:`parse_offsets`).

    Parameters
    ----------
    spec : str
        ``'all'`` or a comma list of lateral offsets, metres.
    pairs : pandas.DataFrame
        The pairs table.

    Returns
    -------
    list of str
        View labels (:func:`data_schema.perturbation.labels`).

    >>> choose_views("all", pd.DataFrame({"y_offset_m": [1.0, 0.0], "yaw_deg": [0.0, 5.0]}))
    ['y=+1.00', 'yaw=+5.00']
    """
    if str(spec).strip().lower() == "all":
        return sorted(set(labels(perturbation_array(pairs))), key=_view_order)
    lat = pairs[~pairs.reindex(columns=list(EXTRA_PERTURBATION_COLUMNS), fill_value=0.0).ne(0).any(axis=1)]
    return _view_keys(choose_offsets(spec, lat["y_offset_m"]))


def usable_frames(pairs: pd.DataFrame, offsets: list, *, min_views: int | None = None) -> pd.DataFrame:
    """One row per (clip_id, track_id, camera, timestamp_us) holding every chosen view (or at
    least ``min_views`` of them).

    ``offsets``: view labels, or lateral offsets in metres. Columns: clip_id, track_id,
    camera, timestamp_us, label_class + attribute columns.

    Parameters
    ----------
    pairs : pandas.DataFrame
        The pairs table, one row per object and view.
    offsets : list
        View labels, or lateral offsets in metres.
    min_views : int, optional
        The fewest chosen views a frame must hold (default: all of them).

    Returns
    -------
    pandas.DataFrame
        The frames' keys, class and attributes, sorted by the keys.
    """
    want = set(_view_keys(offsets))
    df = pairs.assign(_cm=labels(perturbation_array(pairs)))
    df = df[df["_cm"].isin(want)]
    keys = ["clip_id", "track_id", "camera", "timestamp_us"]
    counts = df.groupby(keys, sort=True)["_cm"].nunique()
    full = counts[counts >= (len(want) if min_views is None else min_views)].index
    first = df.drop_duplicates(keys).set_index(keys)
    cols = ["label_class", *attribute_columns(pairs)]
    return first.loc[full, cols].reset_index()


def choose_tracks(frames: pd.DataFrame, n_tracks: int, rng: np.random.Generator) -> list[tuple]:
    """``n_tracks`` (clip_id, track_id) keys spread over label class x attribute strata.

    Parameters
    ----------
    frames : pandas.DataFrame
        :func:`usable_frames`.
    n_tracks : int
        Tracks wanted.
    rng : numpy.random.Generator
        Source of the draw.

    Returns
    -------
    list of (str, str)
        ``(clip_id, track_id)``.
    """
    attrs = [c for c in frames.columns if c not in ("clip_id", "track_id", "camera", "timestamp_us")]
    tracks = frames.drop_duplicates(["clip_id", "track_id"])
    strata: dict[tuple, list[tuple]] = {}
    for row in tracks.itertuples(index=False):
        d = row._asdict()
        strata.setdefault(tuple(str(d[a]) for a in attrs), []).append((d["clip_id"], d["track_id"]))
    pools = [strata[k] for k in sorted(strata)]
    pools = [[p[i] for i in rng.permutation(len(p))] for p in pools]
    pools = [pools[i] for i in rng.permutation(len(pools))]
    chosen: list[tuple] = []
    while len(chosen) < n_tracks and any(pools):
        for pool in pools:
            if pool and len(chosen) < n_tracks:
                chosen.append(pool.pop(0))
    return chosen


def spread_frames(n: int, k: int) -> list[int]:
    """Indices of ``min(n, k)`` positions spread evenly over ``range(n)``.

    Parameters
    ----------
    n : int
        Positions available.
    k : int
        Positions wanted.

    Returns
    -------
    list of int
    """
    if n <= k:
        return list(range(n))
    return sorted(set(np.round(np.linspace(0, n - 1, k)).astype(int).tolist()))


def select_test_pairs(pairs: pd.DataFrame, *, offsets: list[float], n_tracks: int,
                      frames_per_track: int, rng: np.random.Generator
                      ) -> tuple[pd.DataFrame, list[dict]]:
    """Test pairs of the design and a JSON-able record of the chosen tracks and frames: tracks
    with a frame holding every view first (:func:`usable_frames`), then, when they are fewer
    than ``n_tracks``, tracks whose frames hold at least two of the views, with the views they
    have (:func:`_partial_frames`; docs/FORMATS.md §8, "Tracks and frames").

    Parameters
    ----------
    pairs : pandas.DataFrame
        The pairs table.
    offsets : list
        View labels, or lateral offsets in metres.
    n_tracks : int
        Tracks wanted.
    frames_per_track : int
        Frames per track.
    rng : numpy.random.Generator
        Source of the draw.

    Returns
    -------
    pairs : pandas.DataFrame
        The test pairs.
    tracks : list of dict
        The chosen tracks and frames (manifest ``tracks``).
    """
    frames = usable_frames(pairs, offsets)
    chosen = choose_tracks(frames, n_tracks, rng) if len(frames) else []
    if len(chosen) < n_tracks:  # too few tracks seen at every view: fill with tracks seen at some
        some = _partial_frames(pairs, offsets, frames)
        if len(some):
            chosen += choose_tracks(some, n_tracks - len(chosen), rng)
            frames = pd.concat([frames, some], ignore_index=True)
    if frames.empty:
        raise InputError("pairs", "y_offset_m",
                         f"at least one (track, frame) holding {min(2, len(offsets))} of the views {offsets}",
                         "none")
    record, keep = [], []
    for clip_id, track_id in chosen:
        tf = frames[(frames["clip_id"] == clip_id) & (frames["track_id"] == track_id)]
        tf = tf.sort_values(["timestamp_us", "camera"]).reset_index(drop=True)
        idx = spread_frames(len(tf), frames_per_track)
        sel = tf.iloc[idx]
        keep.append(sel[["clip_id", "track_id", "camera", "timestamp_us"]])
        record.append({"clip_id": str(clip_id), "track_id": str(track_id),
                       "label_class": str(tf["label_class"].iloc[0]),
                       "frames": [[str(c), int(t)] for c, t in zip(sel["camera"], sel["timestamp_us"], strict=True)]})
    keys = pd.concat(keep, ignore_index=True)
    want = set(_view_keys(offsets))
    sel = pairs.merge(keys, on=["clip_id", "track_id", "camera", "timestamp_us"])
    sel = sel[np.isin(labels(perturbation_array(sel)), sorted(want))]
    sel = sel.drop_duplicates("pair_id")
    order = ["y_offset_m", *[c for c in EXTRA_PERTURBATION_COLUMNS if c in sel.columns]]
    return sel.sort_values(["clip_id", "track_id", "timestamp_us", "camera", *order], kind="stable"
                           ).reset_index(drop=True), record


def _partial_frames(pairs: pd.DataFrame, offsets: list, full: pd.DataFrame) -> pd.DataFrame:
    """The frames holding at least two of the chosen views (one, where one is chosen) of the
    tracks that hold every view in none of their frames (:func:`usable_frames`' rows). Under a
    visibility rule (``nvrq pairs --min-visible``) an object hidden at some views still shows
    at the others: a study would otherwise rate only the few tracks never hidden."""
    some = usable_frames(pairs, offsets, min_views=min(2, len(set(_view_keys(offsets)))))
    seen = pd.MultiIndex.from_frame(full[["clip_id", "track_id"]].astype(str))
    keep = ~pd.MultiIndex.from_frame(some[["clip_id", "track_id"]].astype(str)).isin(seen)
    return some[keep].reset_index(drop=True)


def _box_side(rows: pd.DataFrame) -> pd.Series | None:
    """The longer side of each row's GT box in camera pixels (None without box columns)."""
    cols = ("gt_x0", "gt_y0", "gt_x1", "gt_y1")
    if not all(c in rows.columns for c in cols):
        return None
    box = rows[list(cols)].apply(pd.to_numeric, errors="coerce")
    return np.maximum(box["gt_x1"] - box["gt_x0"], box["gt_y1"] - box["gt_y0"])


def pick_training(pairs: pd.DataFrame, tests: pd.DataFrame, n: int,
                  rng: np.random.Generator) -> pd.DataFrame:
    """The training items of a study: ``n`` rows of ``pairs`` outside the test set (else from
    it), their offsets spread from large to small: a rater's first items are clearly different
    (the largest ``|y_offset_m|`` there is, 2 m or more when the table has it), the subtle
    ones come last. With GT box columns, only the larger half of the objects (box side at
    least the median) are candidates, when they are enough: a small object is drawn
    enlarged many times over (×12 enlargements of a blur taught nothing).

    Parameters
    ----------
    pairs : pandas.DataFrame
        The candidates (``pair_id``, ``y_offset_m``): pairs, or one row per object view.
    tests : pandas.DataFrame
        The chosen test rows (``pair_id``).
    n : int
        How many (fewer when there are fewer candidates).
    rng : numpy.random.Generator
        Breaks ties between equal offsets.

    Returns
    -------
    pandas.DataFrame
        The chosen rows of ``pairs``, by decreasing ``|y_offset_m|``.
    """
    pool = pairs[~pairs["pair_id"].isin(set(tests["pair_id"]))]
    if pool.empty:
        pool = tests
    n = min(n, len(pool))
    if n == 0:
        return pool.iloc[:0]
    pool = pool.assign(_a=-pool["y_offset_m"].abs(), _r=rng.random(len(pool)))
    side = _box_side(pool)
    if side is not None and (side >= side.median()).sum() >= n:  # the larger objects only
        pool = pool[side >= side.median()]
    order = pool.sort_values(["_a", "_r"])
    idx = np.round(np.linspace(0, len(order) - 1, n)).astype(int)
    return order.iloc[sorted(set(idx.tolist()))].drop(columns=["_a", "_r"])


def choose_tests(table: pd.DataFrame, rng: np.random.Generator, opts: StudyOptions, *,
                 has_views: bool) -> tuple[list, pd.DataFrame, list[dict], pd.DataFrame]:
    """The chosen views and the test and training rows of a study, from one row per pair (the
    good/bad study) or per object view (the pairwise study).

    Parameters
    ----------
    table : pandas.DataFrame
        The candidate rows (``pair_id``, the object and view columns, ``label_class``).
    rng : numpy.random.Generator
        The study's generator: tracks, frames, then training rows are drawn from it.
    opts : StudyOptions
        ``offsets``, ``tracks``, ``frames_per_track`` and ``n_training`` are used.
    has_views : bool
        The pairs have 6-DoF views (else lateral offsets only).

    Returns
    -------
    offsets : list
        The chosen view labels, or offsets in metres for lateral-only pairs (manifest ``offsets``).
    tests : pandas.DataFrame
        The test rows (:func:`select_test_pairs`).
    tracks : list of dict
        The record of the chosen tracks and frames (manifest ``tracks``).
    training : pandas.DataFrame
        The training rows (:func:`pick_training`).

    Raises
    ------
    InputError
        Offsets the table lacks, or no frame holding two of the chosen views.
    """
    views = choose_views(opts.offsets, table)
    offsets = views if has_views else sorted(float(v.partition("=")[2] or 0) for v in views)
    tests, record = select_test_pairs(table, offsets=views, n_tracks=int(opts.tracks),
                                      frames_per_track=int(opts.frames_per_track), rng=rng)
    return offsets, tests, record, pick_training(table, tests, opts.n_training, rng)


@dataclass(frozen=True)
class StudyOptions:
    """The options of ``annotate build``, made once by the CLI
    (:func:`annotate.commands.build.options_from_args`) or by an API caller, and checked by
    :func:`annotate.study.build_study`.

    Parameters
    ----------
    tracks, frames_per_track : int
        Tracks chosen (spread over classes and scene attributes) and frames per track.
    offsets : str
        ``'all'`` or a comma list of lateral offsets in metres (:func:`choose_views`).
    votes_per_item : int
        Votes collected per item.
    seed : int
        Seeds every choice and crop name (a rebuild gives the same study).
    n_training, n_gold, n_repeats : int
        Training items, gold items per type, repeated test items.
    size : int
        The side of the square display crops in pixels (>= 32).
    image_format : {'jpg', 'png'}
        The display crops' format.
    access : {'open', 'token', 'crowd'}
        Who may rate (:mod:`annotate.access`).
    break_every : int
        A break offered every ``break_every`` votes.
    design : {'binary', 'pairwise'}
        Good/bad votes, or which of two methods' renders is closer to the GT.
    methods : str or None
        The comma list of methods a pairwise study compares (None: every method of the table).
    scene : str or None
        The scene folder (None: the pairs table's ``scene_root`` column).
    metrics_paths : tuple of path
        Metrics tables joined on ``pair_id`` and copied into the study.
    participant_param, completion_url : str or None
        Crowd only: the panel's participant-id parameter and the URL shown at the end.
    items_per_rater : int or None
        The most items one rater is given (None: every item).
    sampling : {'uniform', 'active', 'adaptive'} or None
        Where the votes go (:mod:`annotate.study_sampling`): ``'uniform'`` (every test item
        gets ``votes_per_item``), ``'active'`` (pairwise only: the next comparison by expected
        information gain) or ``'adaptive'`` (binary only: curtailed sampling); None: the
        design's default, :data:`annotate.study_sampling.DEFAULT_SAMPLING` (pairwise active,
        binary uniform).
    max_votes_per_item : int or None
        ``'adaptive'`` only: the most votes one test item may get (None: the default of
        :func:`annotate.study_sampling.check_sampling`).

    A frozen value: :func:`dataclasses.replace` makes a changed copy.
    """

    tracks: int = 12
    frames_per_track: int = 12
    offsets: str = "all"
    votes_per_item: int = 5
    scene: str | None = None
    seed: int = 0
    n_training: int = 5
    n_gold: int = 3
    n_repeats: int = 5
    metrics_paths: tuple = ()
    size: int = DISPLAY_SIZE
    image_format: str = "jpg"
    access: str = Access.OPEN
    break_every: int = BREAK_EVERY
    methods: str | None = None
    design: str = StudyDesign.BINARY
    participant_param: str | None = None
    completion_url: str | None = None
    items_per_rater: int | None = DEFAULT_ITEMS_PER_RATER
    sampling: str | None = None
    max_votes_per_item: int | None = None


@dataclass(frozen=True)
class Choice:
    """The items a design chose (:meth:`Design.choose_items`).

    ``pairs``: the pairs table the items come from (with the 6-DoF columns of
    :func:`data_schema.perturbation.with_perturbation_columns` when it has views); ``rows``:
    one per item in items.csv order, in the design's own form; ``offsets``: the chosen offsets
    in metres (lateral-only pairs) or view labels; ``tracks``: the per-track record of the
    chosen tracks and frames (manifest ``tracks``); ``view_columns``: the view columns items
    carry (``[]`` for lateral-only pairs); ``method_columns``: ``['method']`` when each item
    shows one method's render of multi-method pairs; ``methods``: the methods a pairwise study
    compares.

    Attributes
    ----------
    pairs : pandas.DataFrame
        The pairs table the items come from.
    rows : list
        One per item, in items.csv order.
    offsets : list
        Chosen offsets (metres) or view labels.
    tracks : list of dict
        The chosen tracks and frames.
    view_columns : list of str
        View columns the items carry.
    method_columns : list of str
        ``['method']`` or ``[]``.
    methods : list of str
        Methods a pairwise study compares.
    """

    pairs: pd.DataFrame
    rows: list
    offsets: list
    tracks: list
    view_columns: list
    method_columns: list = field(default_factory=list)
    methods: list = field(default_factory=list)


class Design(Protocol):
    """A study design: what ``annotate build`` asks of it (module docstring).

    ``name``: the manifest's ``design``; ``votes``: the stored vote values and their meaning
    (:class:`annotate.store.Store`); ``crops_per_item``: the display crops of an item, each
    named by one opaque id.
    """

    name: str
    votes: dict
    crops_per_item: int

    def choose_items(self, pairs: pd.DataFrame, rng: np.random.Generator, opts: StudyOptions, *,
                     where: str) -> Choice:
        """The items of the study.

        Parameters
        ----------
        pairs : pandas.DataFrame
            The checked pairs table (``_root`` scene folder and ``_row`` line columns).
        rng : numpy.random.Generator
            The study's generator (every choice is seeded).
        opts : StudyOptions
            The checked options.
        where : str
            The pairs table, named in errors.

        Returns
        -------
        Choice

        Raises
        ------
        InputError
            Options the table cannot satisfy (offsets or methods it lacks, no frame holding
            two of the chosen views).
        """
        ...

    def needed_images(self, rows) -> Iterator[tuple[object, str]]:
        """``(pairs record, column)`` of every image the items ``rows`` show."""
        ...

    def cut_crops(self, choice: Choice, folder: Path, *, ids: list[str], rng: np.random.Generator,
                  image, opts: StudyOptions, where: str, progress: bool) -> pd.DataFrame:
        """Cut the crops of every item, pad them to one square and write them into ``folder/crops``.

        Parameters
        ----------
        choice : Choice
            From :meth:`choose_items`.
        folder : pathlib.Path
            The study folder being written.
        ids : list of str
            :attr:`crops_per_item` crop file names per item, in order.
        rng : numpy.random.Generator
            The study's generator, for crops drawn at random.
        image : callable
            ``image(record, column)``: a pairs row's image (:class:`annotate.crops.ImageCache`).
        opts : StudyOptions
            ``image_format`` and ``size`` (the display square) are used.
        where : str
            The pairs table, named in errors.
        progress : bool
            Show a progress bar.

        Returns
        -------
        pandas.DataFrame
            The items table (docs/FORMATS.md §5, §12).

        Raises
        ------
        InputError
            An unreadable image or a box outside it.
        """
        ...

    def manifest_extras(self, choice: Choice) -> dict:
        """Keys the design adds at the end of the manifest."""
        ...
