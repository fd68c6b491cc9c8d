"""A rating study folder: build it from a pairs table, load it, resolve its crops safely.

Layout of ``STUDY/``::

    manifest.json   seed, options and every choice (tracks, frames, offsets, items, scene roots)
    items.csv       one row per item: key, item_id, kind, pair_id, ref_file, ren_file,
                    expected (gold), pair metadata and attributes
    metrics.csv     pair_id + metric columns (only with --metrics)
    secrets.json    the admin token (file mode 600)
    crops/          <opaque id>.jpg|png display crops (names reveal nothing)
    votes.sqlite    the vote store (created on first use)

Item kinds (docs/FORMATS.md §5): ``test``; ``training`` (shown first, excluded from analysis);
``gold`` (hidden: key and item_id ``gold-good:<pair_id>`` shows the GT crop against a copy
of the GT image and must be rated good; ``gold-bad:<pair_id>`` a severely broken copy, must be
rated bad; :mod:`annotate.crops` makes gold and repeats look like real items in their bytes);
``repeat`` (key ``repeat:<pair_id>``, item_id the original test item's id).

Scene folder: ``gt_path``/``render_path`` are relative to the scene folder. It is
``--scene SCENE`` when given, else the pairs table's ``scene_root`` column (absolute, or
relative to the pairs file), else an error. The roots are recorded per clip in the manifest
(``annotate simulate`` reads ``SCENE/degradation.csv`` from there).
"""

from __future__ import annotations

import collections
import json
import os
import secrets
import sqlite3
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from annotate.access import check_access
from annotate.assign import make_plan, pairwise_sides, plan_seed, rater_seed
from annotate.binary import BinaryDesign
from annotate.chooser import RaterState, make_chooser
from annotate.crops import ImageCache, opaque_ids
from annotate.design import Choice, Design, StudyOptions, attribute_columns
from annotate.load import check_items_per_rater
from annotate.pairwise import PairwiseDesign
from annotate.store import Store
from annotate.study_sampling import DEFAULT_SAMPLING, check_sampling, study_sampling
from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN, REFERENCE_METHODS, method_values
from data_schema.options import options_or_keywords
from data_schema.outputs import check_output_folder
from data_schema.study_manifest import StudyManifest
from data_schema.tables import (
    ITEM_KINDS,
    PAIRS_COLUMNS,
    TableKind,
    atomic_folder,
    pair_scene_roots,
    read_metrics,
    read_table,
)
from data_schema.vocab import ItemKind, StudyDesign

__all__ = ["build_study", "load_study", "Study", "StudyChanged", "crop_path", "unplaced_votes"]

_MANIFEST = "manifest.json"
#: study designs by name (manifest ``design``; absent: binary)
DESIGNS: dict[str, Design] = {d.name: d for d in (BinaryDesign(), PairwiseDesign())}
#: Simulated raters (``annotate simulate``; a reserved prefix no person can sign in with):
#: their plans are seeded by the study seed alone, so a simulation is reproducible.
SIMULATED_PREFIX = "sim-"
#: Plans a server process keeps in memory (:meth:`Study.plan_for`).
PLAN_CACHE = 256
#: the stored vote values of each design and what they mean
VOTES = {name: d.votes for name, d in DESIGNS.items()}


def build_study(out: str | Path, pairs_path: str | Path, options: StudyOptions | None = None, *,
                progress: bool = True, **keywords) -> Path:
    """Build the study folder ``out`` (refused if it exists and is not empty).

    Stages: check the options (:class:`annotate.design.StudyOptions`), read and check the
    pairs (and metrics) table, let the design choose the items, check the images they need,
    cut their crops into a new folder beside ``out``, write the tables and the manifest, and
    put the folder in place (:class:`data_schema.tables.atomic_folder`: nothing is left
    behind when a stage fails). The folder is private to its owner (mode 0o700: it holds the
    admin token and the votes).

    Parameters
    ----------
    out : str or pathlib.Path
        The study folder.
    pairs_path : str or pathlib.Path
        The pairs table (docs/FORMATS.md §3).
    options : annotate.design.StudyOptions, optional
        Every option of the study (counts, offsets, seed, display, access, design, scene folder,
        metrics tables; default ``StudyOptions()``).
    **keywords
        Deprecated spelling, kept for earlier callers: the fields of
        :class:`~annotate.design.StudyOptions` as keywords (``metrics_path``: a path or a list,
        for ``metrics_paths``). Not together with ``options``.
    progress : bool
        Show a progress bar.

    Returns
    -------
    pathlib.Path
        ``out``.

    Raises
    ------
    InputError
        A bad option (naming the parameter), a bad pairs or metrics table, a missing image.
    """
    opts = _check_options(out, pairs_path, options_or_keywords(
        StudyOptions, options, keywords, who="build_study", renames={"metrics_path": "metrics_paths"}))
    study_design = DESIGNS[opts.design]
    where = str(pairs_path)
    pairs = _read_pairs(Path(pairs_path), opts.scene)
    rng = np.random.default_rng(opts.seed)
    choice = study_design.choose_items(pairs, rng, opts, where=where)
    if opts.items_per_rater is not None:
        kinds = pd.Series([r["kind"] for r in choice.rows]).value_counts().to_dict()
        kinds["gold"] = min(2 * int(opts.n_gold), kinds.get("gold", 0))  # a rater's share of the pool
        check_items_per_rater(opts.items_per_rater, kinds)
    _check_images(study_design.needed_images(choice.rows), where=where)
    metrics = _read_study_metrics(opts.metrics_paths, choice.pairs)
    ids = opaque_ids(rng, study_design.crops_per_item * len(choice.rows))
    out = Path(out)
    with atomic_folder(out, mode=0o700) as tmp:
        items = study_design.cut_crops(choice, tmp, ids=ids, rng=rng, image=ImageCache(where),
                                       opts=opts, where=where, progress=progress)
        metric_cols = _write_tables(tmp, items, metrics)
        manifest = _manifest(out, choice, items, opts, extras=study_design.manifest_extras(choice),
                             pairs_file=Path(pairs_path).resolve(), metric_cols=metric_cols)
        _write_manifest(tmp, manifest)
    return out


def _check_options(out, pairs_path, opts: StudyOptions) -> StudyOptions:
    """Check the study's options (errors name the parameter); the options with
    ``metrics_paths`` a tuple of metrics tables (a single path or None accepted)."""
    mp = opts.metrics_paths
    mp = () if mp is None else (mp,) if isinstance(mp, str | os.PathLike) else tuple(mp)
    opts = replace(opts, metrics_paths=mp)
    check_output_folder(out, kind="study", option="out", inputs=[pairs_path, *mp, opts.scene])
    for name, lo in (("tracks", 1), ("frames_per_track", 1), ("votes_per_item", 1), ("size", 32),
                     ("break_every", 1), ("n_training", 0), ("n_gold", 0), ("n_repeats", 0)):
        val = getattr(opts, name)
        if isinstance(val, bool) or not isinstance(val, int | np.integer) or val < lo:
            raise InputError(param=name, expected=f"an integer >= {lo}", got=val)
    if opts.image_format not in ("jpg", "png"):
        raise InputError(param="image_format", expected="one of {'jpg', 'png'}", got=opts.image_format)
    check_access(opts.access, participant_param=opts.participant_param,
                 completion_url=opts.completion_url)
    if opts.design not in DESIGNS:
        raise InputError(param="design", expected="one of {'binary', 'pairwise'}", got=opts.design)
    cap = opts.items_per_rater
    if cap is not None and (isinstance(cap, bool) or not isinstance(cap, int | np.integer) or cap < 1):
        raise InputError(param="items_per_rater", expected="a positive integer or None", got=cap)
    if opts.methods is not None and opts.design != StudyDesign.PAIRWISE:
        raise InputError(param="methods", expected="no method list with `design` binary (it compares "
                         "methods only with `design` pairwise)", got=opts.methods)
    sampling = DEFAULT_SAMPLING[opts.design] if opts.sampling is None else opts.sampling
    cap = check_sampling(sampling, design=opts.design, votes_per_item=opts.votes_per_item,
                         max_votes_per_item=opts.max_votes_per_item)
    return replace(opts, sampling=sampling, max_votes_per_item=cap)


def _read_pairs(pairs_path: Path, scene) -> pd.DataFrame:
    """The checked pairs table with ``_root`` (scene folder) and ``_row`` (line) columns, without
    the pairs of the reference methods (``perfect``, ``floor``: the viewpoint floor is measured,
    never shown to raters; :data:`data_schema.methods.REFERENCE_METHODS`)."""
    pairs = read_table(pairs_path, required=PAIRS_COLUMNS, kind=TableKind.PAIRS)
    if pairs.empty:
        raise InputError(pairs_path, None, "at least one pair", "an empty table")
    rows = np.arange(len(pairs)) + 2
    shown = ~pd.Series(method_values(pairs)).isin(REFERENCE_METHODS).to_numpy()
    if not shown.any():
        raise InputError(pairs_path, METHOD_COLUMN, "at least one pair of a render other than the viewpoint "
                         "floor (methods perfect and floor are never shown)", "only those")
    pairs, rows = pairs[shown].reset_index(drop=True), rows[shown]
    roots = pair_scene_roots(pairs, scene_root=scene, base=pairs_path.resolve().parent,
                             where=str(pairs_path))
    return pairs.assign(_root=roots, _row=rows)


def _read_study_metrics(paths, pairs: pd.DataFrame) -> pd.DataFrame | None:
    """The metrics tables (checked as ``analyze`` checks them) joined on ``pair_id`` and
    restricted to the pairs; None without tables. A column in two tables is an error."""
    merged, seen = None, {}
    for path in paths:
        metrics = read_metrics(path)
        hit = metrics["pair_id"].isin(set(pairs["pair_id"].astype(str)))
        if not hit.any():
            raise InputError(path, "pair_id", "pair ids of the pairs table", "none matches")
        for col in metrics.columns.drop("pair_id"):
            if col in seen:
                raise InputError(path, f"column {col!r}", "each metric column in one metrics table",
                                 f"also in {seen[col]}")
            seen[col] = str(path)
        metrics = metrics[hit]
        merged = metrics if merged is None else merged.merge(metrics, on="pair_id", how="outer")
    return merged


def _check_images(needed, *, where: str) -> None:
    """Every image the items need (``needed``: ``(pairs record, column)``) lies in its scene
    folder and exists (before any crop is cut)."""
    seen = set()
    paths = ImageCache(where)
    for r, column in needed:
        path = paths.path(r, column)
        if path not in seen and not os.path.isfile(path):
            raise InputError(where, f"line {int(r['_row'])}: column {column!r}", "an existing image file",
                             f"{r[column]} (not found)")
        seen.add(path)


def _write_tables(tmp: Path, items: pd.DataFrame, metrics: pd.DataFrame | None) -> list[str]:
    """``items.csv`` and (with metrics) ``metrics.csv`` of the items' pairs; the metric columns."""
    items.to_csv(tmp / "items.csv", index=False)
    if metrics is None:
        return []
    shown = set(items["pair_id"])
    if "pair_id_a" in items.columns:  # pairwise: the renders' pairs
        shown = set(items["pair_id_a"]) | set(items["pair_id_b"])
    metrics[metrics["pair_id"].isin(shown)].to_csv(tmp / "metrics.csv", index=False)
    return [c for c in metrics.columns if c != "pair_id"]


def _manifest(out: Path, choice: Choice, items: pd.DataFrame, opts: StudyOptions, *, extras: dict,
              pairs_file: Path, metric_cols: list[str]) -> StudyManifest:
    """The study's ``manifest.json`` (every option and choice; the design's ``extras`` last), checked."""
    pairs = choice.pairs
    roots = pairs.drop_duplicates("clip_id").set_index("clip_id")["_root"]
    return StudyManifest.from_dict({
        "format": "nvrq-study", "version": 1,
        "study_id": f"{out.resolve().name}-{secrets.token_hex(4)}",
        "seed": int(opts.seed),
        **check_access(opts.access, participant_param=opts.participant_param,
                       completion_url=opts.completion_url),
        "votes_per_item": int(opts.votes_per_item), "break_every": int(opts.break_every),
        "sampling": opts.sampling, "max_votes_per_item": opts.max_votes_per_item,
        "items_per_rater": None if opts.items_per_rater is None else int(opts.items_per_rater),
        "display_size": int(opts.size), "image_format": opts.image_format,
        "options": {"tracks": int(opts.tracks), "frames_per_track": int(opts.frames_per_track),
                    "offsets": str(opts.offsets), "n_training": int(opts.n_training),
                    "n_gold_per_type": int(opts.n_gold), "n_repeats": int(opts.n_repeats)},
        "pairs": str(pairs_file),
        "metrics": [str(Path(p).resolve()) for p in opts.metrics_paths],
        "metric_columns": metric_cols,
        "attribute_columns": attribute_columns(pairs.drop(columns=["_root", "_row"])),
        "view_columns": list(choice.view_columns),
        "method_columns": list(choice.method_columns),
        "scene_roots": {str(k): str(v) for k, v in roots.items()},
        "offsets": choice.offsets, "tracks": choice.tracks,
        "counts": {kind: int((items["kind"] == kind).sum()) for kind in ITEM_KINDS},
        # each rater's gold items, drawn from the counts' gold pool (absent: every gold item)
        "gold_per_rater": min(2 * int(opts.n_gold), int((items["kind"] == ItemKind.GOLD).sum())),
        "training_order": items.loc[items["kind"] == ItemKind.TRAINING, "key"].tolist(),
        **extras,
    }, path=out / _MANIFEST)


def _write_manifest(tmp: Path, manifest: StudyManifest) -> None:
    """``manifest.json`` and ``secrets.json`` (the admin token, file mode 600)."""
    manifest.write(tmp / _MANIFEST)
    secret = tmp / "secrets.json"
    secret.write_text(json.dumps({"admin_token": secrets.token_urlsafe(24)}))
    os.chmod(secret, 0o600)


def crop_path(study_root: str | Path, name: str) -> Path:
    """The crop file ``name`` inside ``STUDY/crops``; refuses anything that leaves that folder.

    Parameters
    ----------
    study_root : str or pathlib.Path
        The study folder.
    name : str
        The crop's file name, relative to ``STUDY/crops``.

    Returns
    -------
    pathlib.Path
        The resolved path of an existing file directly inside ``STUDY/crops``.

    Raises
    ------
    InputError
        When ``name`` leads outside that folder, holds a NUL, or names no file.

    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp()); (d / "crops").mkdir(); _ = (d / "crops" / "ab.jpg").write_bytes(b"x")
    >>> crop_path(d, "ab.jpg").name
    'ab.jpg'
    >>> crop_path(d, "../manifest.json")
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: crop: ../manifest.json: expected a file inside the study's crops folder, got outside
    """
    base = (Path(study_root) / "crops").resolve()
    name = str(name)
    target = (base / name).resolve()
    if "\x00" in name or target.parent != base or not target.is_file():
        raise InputError("crop", name, "a file inside the study's crops folder",
                         "outside" if target.parent != base else "no such file")
    return target


@dataclass
class Study:
    """A loaded study: its folder, manifest, items (indexed by key) and vote store.

    Attributes
    ----------
    root : pathlib.Path
        The study folder (resolved).
    manifest : StudyManifest
        The study's ``manifest.json``, read and checked.
    items : pandas.DataFrame
        The rows of ``items.csv``, indexed by ``key``.
    store : Store
        The study's vote store (``votes.sqlite``).
    """

    root: Path
    manifest: StudyManifest
    items: pd.DataFrame
    store: Store

    @property
    def quota(self) -> int:
        return int(self.manifest.votes_per_item)

    def admin_token(self) -> str:
        if "_admin_token" not in self.__dict__:
            self._admin_token = json.loads((self.root / "secrets.json").read_text())["admin_token"]
        return self._admin_token

    def keys(self, kind: str) -> list[str]:
        """The item keys of ``kind`` in items.csv order (a new list; computed once per kind)."""
        cache = self.__dict__.setdefault("_keys", {})
        if kind not in cache:
            cache[kind] = tuple(self.items.index[self.items["kind"] == kind])
        return list(cache[kind])

    def plan_for(self, rater: str, *, register: bool = True) -> dict:
        """The rater's plan: the stored one, else a new one (stored when ``register``).

        A plan never changes (a new one is a function of the study's secret and the rater),
        so it is kept in memory after the first use, in a cache of at most
        :data:`PLAN_CACHE` plans (the least recently used is dropped; measured: a plan is
        about 80 kB at 1,000 items and every arrival made one). ``register=False``: a crowd
        arrival's plan, used before its first vote and stored with it
        (:func:`annotate.access.register_crowd_rater`).
        """
        cache = self.__dict__.setdefault("_plans", collections.OrderedDict())
        plan = cache.get(rater)
        if plan is not None:
            cache.move_to_end(rater)
            return plan
        plan = self.store.plan(rater)
        if plan is None:
            plan = self.new_plan(rater)
            if register:
                self.store.add_rater(rater, plan=plan)
                plan = self.store.plan(rater)
        cache[rater] = plan
        while len(cache) > PLAN_CACHE:
            cache.popitem(last=False)
        return plan

    def is_full(self) -> bool:
        """Whether a new rater would be given no test item: every test item has its
        ``votes_per_item`` standing votes (uniform), or the study's sampler has spent its
        budget or closed every item (active, adaptive)."""
        chooser = self.chooser
        chooser.refresh(self.store.history_after)
        return chooser.is_full(self.store.item_loads(), self.keys(ItemKind.TEST))

    @property
    def sampling(self) -> str:
        """``'uniform'`` (every study built before ``--sampling``), ``'active'`` or ``'adaptive'``."""
        return study_sampling(self.manifest)[0]

    @property
    def chooser(self):
        """This process's next-item chooser (:mod:`annotate.chooser`; made on first use)."""
        if "_chooser_obj" not in self.__dict__:
            self._chooser_obj = make_chooser(self)
        return self._chooser_obj

    @property
    def sampler(self):
        """This process's :mod:`annotate.study_sampling` sampler (its chooser's), or None
        for a uniform study."""
        return getattr(self.chooser, "sampler", None)

    @property
    def design(self) -> str:
        """``'binary'`` (good/bad; every study built before designs existed) or ``'pairwise'``."""
        return self.manifest.design

    @property
    def tests_per_rater(self) -> int | None:
        """The test items one rater is given at most: the manifest's ``items_per_rater`` less
        the training, gold and repeat items (None: no cap, as in studies built before it)."""
        cap = self.manifest.items_per_rater
        if cap is None:
            return None
        return int(cap) - sum(self.rater_counts()[k] for k in ("training", "gold", "repeat"))

    @property
    def gold_per_rater(self) -> int | None:
        """Gold items one rater is shown, drawn from the study's pool (manifest
        ``gold_per_rater``; None in studies built before the pool: every gold item)."""
        n = self.manifest.gold_per_rater
        return None if n is None else int(n)

    def rater_counts(self) -> dict[str, int]:
        """Items of each kind one rater is shown at most: the manifest's ``counts`` with
        ``gold`` the rater's share of the gold pool (:attr:`gold_per_rater`)."""
        counts = {k: int(self.manifest.counts.get(k, len(self.keys(k)))) for k in ITEM_KINDS}
        if self.gold_per_rater is not None:
            counts["gold"] = min(self.gold_per_rater, counts["gold"])
        return counts

    def new_plan(self, rater: str) -> dict:
        """A new plan for ``rater``, seeded by :func:`annotate.assign.plan_seed` (keyed with
        the study's secret: the seed alone predicts nothing); a simulated rater's
        (``sim-``) by :func:`annotate.assign.rater_seed`, so simulations repeat exactly."""
        reps = {k: k.split(":", 1)[1] for k in self.keys(ItemKind.REPEAT)}
        seed = (rater_seed(self.manifest.seed, rater) if rater.startswith(SIMULATED_PREFIX)
                else plan_seed(self.admin_token(), self.manifest.seed, rater))
        plan = make_plan(training=self.manifest.training_order, tests=self.keys(ItemKind.TEST),
                         golds=self.keys(ItemKind.GOLD), repeats=reps, seed=seed,
                         max_tests=self.tests_per_rater, n_gold=self.gold_per_rater)
        if self.design == StudyDesign.PAIRWISE:  # which side A is shown on, per item, for this rater
            plan["sides"] = pairwise_sides(plan, seed=seed)
        return plan

    def next_item(self, rater: str) -> str | None:
        """Key of the rater's next unrated item (None: done, or, when :meth:`waiting` says
        so, nothing free until other raters' claims end)."""
        chooser, observe = self._chooser(self.plan_for(rater))
        return self.store.next_item(rater, chooser, observe=observe)

    def next_with_progress(self, rater: str) -> tuple[str | None, dict]:
        """(:meth:`next_item`, :meth:`progress` once it is handed out), read in one store
        transaction: what the page shows after each vote."""
        plan = self.plan_for(rater)
        chooser, observe = self._chooser(plan)
        key, (assigned, voted, votes) = self.store.next_item_state(rater, chooser, observe=observe)
        return key, self._progress(plan, assigned, voted, votes)

    def _chooser(self, plan: dict) -> tuple:
        """(chooser, observe) for :meth:`annotate.store.Store.next_item`: the study's
        :mod:`annotate.chooser` on the rater's ``plan`` (a sampler observes the votes)."""
        chooser = self.chooser
        return (lambda a, v, loads: chooser.next(RaterState(plan, a, v, loads)),
                chooser.observe)

    def waiting(self, rater: str) -> bool:
        """Whether the rater has items left that other raters' claims hold right now (when
        :meth:`next_item` gives None: True means "retry in a minute", False "all done").

        The same choice as :meth:`next_item` with standing votes only, claims not counted.
        """
        plan = self.plan_for(rater)
        assigned, voted, votes = self.store.rater_state(rater)
        chooser = self.chooser
        chooser.refresh(self.store.history_after)
        return chooser.next(RaterState(plan, assigned, voted, votes)) is not None

    def progress(self, rater: str) -> dict:
        """``{'training_done', 'training_total', 'done', 'total'}`` (done/total exclude training).

        Reads the rater's own rows and the per-item vote counters only, so its cost does not
        grow with the other raters' votes.
        """
        assigned, voted, votes = self.store.rater_state(rater)
        return self._progress(self.plan_for(rater), assigned, voted, votes)

    def _progress(self, plan: dict, assigned: list[str], voted: set[str],
                  votes: dict[str, int]) -> dict:
        training = set(plan["training"])
        loads = {k: n for k, n in votes.items() if k not in voted}  # others' votes on open items
        return {"training_done": len(voted & training), "training_total": len(training),
                "done": len(voted - training),
                "total": self.chooser.total(RaterState(plan, assigned, voted, loads))}

    def check_current(self) -> None:
        """Raise :class:`StudyChanged` when the folder's manifest is no longer this study's.

        A study rebuilt (or removed) under a running server must not receive its votes.
        Costs one ``stat`` per call; the manifest is re-read only when the file changed.
        """
        path = self.root / _MANIFEST
        try:
            st = path.stat()
            sig = (st.st_ino, st.st_mtime_ns, st.st_size)
            if sig != getattr(self, "_manifest_sig", None):
                found = json.loads(path.read_text()).get("study_id")
                if found != self.manifest.study_id:
                    raise StudyChanged(f"{path}: study_id is {found!r}, the server was started "
                                       f"for {self.manifest.study_id!r}")
                self._manifest_sig = sig
        except (OSError, ValueError) as err:
            raise StudyChanged(f"{path}: {err}") from err


class StudyChanged(RuntimeError):
    """The study folder changed under a running server (rebuilt or removed): restart it."""


def load_study(root: str | Path) -> Study:
    """Load ``STUDY/`` (InputError naming the file if it is not a readable study folder).

    Parameters
    ----------
    root : str or pathlib.Path
        The study folder made by ``annotate build``.

    Returns
    -------
    Study
        The study with its manifest, items table and opened vote store.
    """
    root = Path(root).resolve()
    path = root / _MANIFEST
    if not path.is_file():
        raise InputError(root, _MANIFEST, "a study folder made by 'annotate build'", "no manifest")
    manifest = StudyManifest.read(path)
    items_path = root / "items.csv"
    if not items_path.is_file():
        raise InputError(items_path, None, "the study's items table", "no such file")
    design = manifest.design
    files = ("ref_file", "a_file", "b_file", "method_a", "method_b") if design == StudyDesign.PAIRWISE else (
        "ref_file", "ren_file")
    items = read_table(items_path, required=("key", "item_id", "kind", "pair_id", *files),
                       what="study items table",
                       dtype={"key": str, "item_id": str, "pair_id": str, "camera": str,
                              "track_id": str, "clip_id": str, "method_a": str, "method_b": str,
                              "pair_id_a": str, "pair_id_b": str, "expected": str}
                       if design == StudyDesign.PAIRWISE else
                       {"key": str, "item_id": str, "pair_id": str, "camera": str,
                        "track_id": str, "clip_id": str})
    if items["key"].duplicated().any() or items["key"].isna().any():
        raise InputError(items_path, "key", "one row per item key", "a duplicated or empty key")
    db = root / "votes.sqlite"
    try:
        store = Store(db, manifest.study_id, votes=VOTES[design])
    except sqlite3.Error as exc:
        raise InputError(db, None, "a readable SQLite vote store in a writable study folder",
                         f"{type(exc).__name__}: {exc}") from None
    return Study(root, manifest, items.set_index("key", drop=False).rename_axis(None), store)


def unplaced_votes(study: Study) -> dict[str, int]:
    """Votes in the study's store that an export cannot place, counted by reason
    (``{reason: n}``; empty when every vote has an item of this study).

    Parameters
    ----------
    study : Study
        The loaded study.

    Returns
    -------
    dict of str to int
        Number of unplaceable votes per reason (votes for unknown items, votes recorded under
        another study id).
    """
    votes = study.store.votes()
    out = {}
    unknown = int((~votes["item"].isin(study.items.index)).sum())
    if unknown:
        out["for items not in items.csv"] = unknown
    other = study.store.other_study_votes()
    if other:
        out["recorded under another study id (the folder was rebuilt)"] = other
    return out
