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
``gold`` (hidden: key and item_id ``gold-good:<pair_id>`` shows the GT crop twice and must
be rated good; ``gold-bad:<pair_id>`` a severely broken copy, must be rated bad);
``repeat`` (key ``repeat:<pair_id>``, item_id the original test item's id).

Scene folder: ``gt_path``/``render_path`` are relative to the scene folder. It is
``--scene SCENE`` when given, else the pairs table's ``scene_root`` column (absolute, or
relative to the pairs file), else an error. The roots are recorded per clip in the manifest
(``annotate simulate`` reads ``SCENE/degradation.csv`` from there).
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import sqlite3
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from annotate import crops as _crops
from annotate import pairwise
from annotate.assign import choose_next, make_plan, pairwise_sides, plan_total, rater_seed
from annotate.design import attribute_columns, choose_views, select_test_pairs
from annotate.store import BINARY_VOTES, Store
from data_schema.errors import InputError
from data_schema.methods import method_columns
from data_schema.outputs import check_output_folder
from data_schema.perturbation import view_columns, with_perturbation_columns
from data_schema.tables import (
    GT_BOX_COLUMNS,
    ITEM_KINDS,
    PAIR_META_COLUMNS,
    PAIRS_COLUMNS,
    RENDER_BOX_COLUMNS,
    atomic_write_text,
    inside_scene,
    pair_scene_roots,
    read_metrics,
    read_table,
)
from nvrq.crops import cut_box

__all__ = ["build_study", "load_study", "Study", "StudyChanged", "crop_path", "unplaced_votes"]

_MANIFEST = "manifest.json"
#: study designs (manifest ``design``; absent: binary)
DESIGNS = ("binary", "pairwise")
#: the stored vote values of each design and what they mean
VOTES = {"binary": BINARY_VOTES, "pairwise": pairwise.VOTE_CODES}


def _opaque_ids(rng: np.random.Generator, n: int) -> list[str]:
    """``n`` distinct 16-hex-digit ids (seeded, so a rebuild names crops the same)."""
    ids: list[str] = []
    seen: set[str] = set()
    while len(ids) < n:
        s = rng.bytes(8).hex()
        if s not in seen:
            seen.add(s)
            ids.append(s)
    return ids


def _pick_training(pairs: pd.DataFrame, tests: pd.DataFrame, n: int,
                   rng: np.random.Generator) -> pd.DataFrame:
    """``n`` pairs outside the test set (else from it), offsets spread from small to large."""
    pool = pairs[~pairs["pair_id"].isin(set(tests["pair_id"]))]
    if pool.empty:
        pool = tests
    n = min(n, len(pool))
    if n == 0:
        return pool.iloc[:0]
    order = pool.assign(_a=pool["y_offset_m"].abs(), _r=rng.random(len(pool))).sort_values(["_a", "_r"])
    idx = np.round(np.linspace(0, len(order) - 1, n)).astype(int)
    return order.iloc[sorted(set(idx.tolist()))].drop(columns=["_a", "_r"])


def build_study(out: str | Path, pairs_path: str | Path, *, scene: str | None = None,
                metrics_path=None, tracks: int = 12,
                frames_per_track: int = 12, offsets: str = "all", votes_per_item: int = 5,
                seed: int = 0, n_training: int = 5, n_gold: int = 3, n_repeats: int = 5,
                size: int = 320, image_format: str = "jpg", access: str = "open",
                break_every: int = 50, design: str = "binary", methods: str | None = None,
                progress: bool = True) -> Path:
    """Build the study folder ``out`` (refused if it exists and is not empty); returns it.

    ``metrics_path``: None, a metrics table, or a list of them (joined on ``pair_id``).
    ``design`` in {'binary', 'pairwise'}: good/bad votes on (GT, render) items, or which of
    two methods' renders is closer to the GT (:mod:`annotate.pairwise`; the pairs table needs
    a ``method`` column); ``methods``: a comma list of the methods to compare (pairwise only;
    default every method of the table).

    Stages: check the options, read and check the pairs (and metrics) table, choose the
    items, cut their crops into a temporary folder, write the tables and the manifest, and
    rename the folder into place (nothing is left behind when a stage fails).
    """
    opts = _check_options(out, pairs_path, scene=scene, metrics_path=metrics_path, tracks=tracks,
                          frames_per_track=frames_per_track, offsets=offsets,
                          votes_per_item=votes_per_item, seed=seed, n_training=n_training,
                          n_gold=n_gold, n_repeats=n_repeats, size=size, image_format=image_format,
                          access=access, break_every=break_every, design=design,
                          methods=methods)
    pairs = _read_pairs(Path(pairs_path), scene)
    rng = np.random.default_rng(seed)
    # a binary study's items carry the method of their render ([] for single-method pairs);
    # pairwise items name theirs in method_a/method_b
    opts["method_columns"] = method_columns(pairs) if design == "binary" else []
    if design == "pairwise":
        opts["methods"] = pairwise.check_methods(pairs, methods, where=str(pairs_path))
        pairs, rows, chosen_offsets, record = pairwise.choose_items(
            pairs, rng, opts, pick_training=_pick_training, where=str(pairs_path))
        _check_images(pairwise.needed_images(rows), where=str(pairs_path))
    else:
        pairs, rows, chosen_offsets, record = _choose_items(pairs, rng, opts)
        _check_images(((r, column) for r, kind, *_ in rows
                       for column in (("gt_path",) if kind == "gold" else ("gt_path", "render_path"))),
                      where=str(pairs_path))
    metrics = _read_study_metrics(opts["metrics_paths"], pairs)
    out = Path(out)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent if out.parent.exists() else None))
    try:
        if design == "pairwise":
            items = pairwise.cut_crops(rows, pairs, tmp, ids=_opaque_ids(rng, 3 * len(rows)),
                                       image=_ImageCache(str(pairs_path)), opts=opts,
                                       where=str(pairs_path), progress=progress)
        else:
            items = _cut_crops(rows, pairs, tmp, rng=rng, opts=opts, where=str(pairs_path),
                               progress=progress)
        metric_cols = _write_tables(tmp, items, metrics)
        manifest = _manifest(out, pairs, items, opts, pairs_file=Path(pairs_path).resolve(),
                             metric_cols=metric_cols, offsets=chosen_offsets, tracks=record)
        _write_manifest(tmp, manifest)
        if out.exists():
            out.rmdir()
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def _check_options(out, pairs_path, **opts) -> dict:
    """Check ``build_study``'s keyword arguments (errors name the parameter); returns them
    with ``metrics_paths``, the list of metrics tables (``metrics_path``: a path or a list)."""
    mp = opts["metrics_path"]
    opts["metrics_paths"] = [] if mp is None else [mp] if isinstance(mp, str | os.PathLike) else list(mp)
    check_output_folder(out, kind="study", option="out",
                        inputs=[pairs_path, *opts["metrics_paths"], opts["scene"]])
    for name, lo in (("tracks", 1), ("frames_per_track", 1), ("votes_per_item", 1), ("size", 32),
                     ("break_every", 1), ("n_training", 0), ("n_gold", 0), ("n_repeats", 0)):
        val = opts[name]
        if isinstance(val, bool) or not isinstance(val, int | np.integer) or val < lo:
            raise InputError(name, None, f"an integer >= {lo}", val)
    if opts["image_format"] not in ("jpg", "png"):
        raise InputError("image_format", None, "one of {'jpg', 'png'}", opts["image_format"])
    if opts["access"] not in ("open", "token"):
        raise InputError("access", None, "one of {'open', 'token'}", opts["access"])
    if opts["design"] not in DESIGNS:
        raise InputError("design", None, "one of {'binary', 'pairwise'}", opts["design"])
    if opts["methods"] is not None and opts["design"] != "pairwise":
        raise InputError("methods", None, "no method list with --design binary (it compares "
                         "methods only with --design pairwise)", opts["methods"])
    return opts


def _read_pairs(pairs_path: Path, scene) -> pd.DataFrame:
    """The checked pairs table with ``_root`` (scene folder) and ``_row`` (line) columns."""
    pairs = read_table(pairs_path, required=PAIRS_COLUMNS, what="pairs table")
    if pairs.empty:
        raise InputError(pairs_path, None, "at least one pair", "an empty table")
    roots = pair_scene_roots(pairs, scene_root=scene, base=pairs_path.resolve().parent,
                             where=str(pairs_path))
    return pairs.assign(_root=roots, _row=np.arange(len(pairs)) + 2)


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


def _choose_items(pairs: pd.DataFrame, rng: np.random.Generator, opts: dict):
    """The pairs (with 6-DoF columns when they have views), rows ``(pair record, kind, key,
    item_id, expected)`` of every item, the chosen offsets or views and the per-track record."""
    chosen_views = choose_views(opts["offsets"], pairs)
    opts["view_columns"] = view_cols = view_columns(pairs)  # [] for lateral-only pairs
    if view_cols:
        pairs = with_perturbation_columns(pairs)
    chosen_offsets = chosen_views if view_cols else sorted(float(v.partition("=")[2] or 0) for v in chosen_views)
    tests, record = select_test_pairs(pairs, offsets=chosen_views, n_tracks=int(opts["tracks"]),
                                      frames_per_track=int(opts["frames_per_track"]), rng=rng)
    training = _pick_training(pairs, tests, opts["n_training"], rng)
    gold_src = tests.iloc[sorted(rng.choice(len(tests), size=min(2 * opts["n_gold"], len(tests)),
                                            replace=False).tolist())]
    rep_src = tests.iloc[sorted(rng.choice(len(tests), size=min(opts["n_repeats"], len(tests)),
                                           replace=False).tolist())]

    def recs(df: pd.DataFrame) -> list[dict]:
        return df.to_dict("records")

    rows = [(r, "training", "training:" + r["pair_id"], r["pair_id"], None) for r in recs(training)]
    rows += [(r, "test", r["pair_id"], r["pair_id"], None) for r in recs(tests)]
    for i, r in enumerate(recs(gold_src)):
        tag = "gold-good" if i % 2 == 0 else "gold-bad"
        rows.append((r, "gold", f"{tag}:{r['pair_id']}", f"{tag}:{r['pair_id']}",
                     int(tag == "gold-good")))
    rows += [(r, "repeat", "repeat:" + r["pair_id"], r["pair_id"], None) for r in recs(rep_src)]
    return pairs, rows, chosen_offsets, record


def _check_images(needed, *, where: str) -> None:
    """Every image the items need (``needed``: ``(pairs record, column)``) lies in its scene
    folder and exists (before any crop is cut)."""
    seen = set()
    paths = _ImageCache(where)
    for r, column in needed:
        path = paths.path(r, column)
        if path not in seen and not os.path.isfile(path):
            raise InputError(where, f"line {int(r['_row'])}: column {column!r}", "an existing image file",
                             f"{r[column]} (not found)")
        seen.add(path)


class _ImageCache:
    """Images of the pairs table read once each (the last 64 kept), paths checked by the
    scene-folder rule of :func:`data_schema.tables.inside_scene`."""

    def __init__(self, where: str):
        self.where, self.cache = where, {}

    def path(self, r, column: str) -> str:
        """The checked path of the image in ``column`` of pairs row ``r``."""
        field = f"line {int(r['_row'])}: column {column!r}"
        return inside_scene(r["_root"], r[column], where=self.where, field=field)

    def __call__(self, r, column: str) -> np.ndarray:
        field = f"line {int(r['_row'])}: column {column!r}"
        path = self.path(r, column)
        if path not in self.cache:
            if len(self.cache) > 64:
                self.cache.clear()
            self.cache[path] = _crops.read_bgr(Path(path), where=self.where, field=field)
        return self.cache[path]


def _cut_crops(rows, pairs: pd.DataFrame, tmp: Path, *, rng, opts: dict, where: str,
               progress: bool) -> pd.DataFrame:
    """Cut, pad and write the two display crops of every item into ``tmp/crops``; the items."""
    (tmp / "crops").mkdir()
    fmt, size = opts["image_format"], int(opts["size"])
    attrs = attribute_columns(pairs.drop(columns=["_root", "_row"]))
    ids = _opaque_ids(rng, 2 * len(rows))
    image = _ImageCache(where)
    items = []
    for k, (r, kind, key, item_id, expected) in enumerate(
            tqdm(rows, desc="cutting crops", unit="item", disable=not progress)):
        line = int(r["_row"])
        gt = cut_box(image(r, "gt_path"), [r[c] for c in GT_BOX_COLUMNS],
                        where=where, field=f"line {line}: gt box")
        if kind == "gold":
            ren = gt.copy() if expected == 1 else _crops.broken_render(gt, rng=rng)
        else:
            ren = cut_box(image(r, "render_path"), [r[c] for c in RENDER_BOX_COLUMNS],
                             where=where, field=f"line {line}: render box")
        a, b = _crops.pad_pair(gt, ren, size=size)
        ref_file, ren_file = f"{ids[2 * k]}.{fmt}", f"{ids[2 * k + 1]}.{fmt}"
        _crops.write_image(tmp / "crops" / ref_file, a, fmt=fmt)
        _crops.write_image(tmp / "crops" / ren_file, b, fmt=fmt)
        meta = {c: r[c] for c in (*PAIR_META_COLUMNS, *opts["view_columns"], *opts["method_columns"], *attrs)}
        items.append({"key": key, "item_id": item_id, "kind": kind, "pair_id": r["pair_id"],
                      "ref_file": ref_file, "ren_file": ren_file,
                      "crop_side": max(*gt.shape[:2], *ren.shape[:2]),
                      "expected": np.nan if expected is None else expected, **meta})
    return pd.DataFrame(items)


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


def _manifest(out: Path, pairs: pd.DataFrame, items: pd.DataFrame, opts: dict, *, pairs_file: Path,
              metric_cols: list[str], offsets: list[float], tracks) -> dict:
    """The study's ``manifest.json`` (every option and choice)."""
    roots = pairs.drop_duplicates("clip_id").set_index("clip_id")["_root"]
    return {
        "format": "nvrq-study", "version": 1,
        "study_id": f"{out.resolve().name}-{secrets.token_hex(4)}",
        "seed": int(opts["seed"]), "access": opts["access"],
        "votes_per_item": int(opts["votes_per_item"]), "break_every": int(opts["break_every"]),
        "display_size": int(opts["size"]), "image_format": opts["image_format"],
        "options": {"tracks": int(opts["tracks"]), "frames_per_track": int(opts["frames_per_track"]),
                    "offsets": str(opts["offsets"]), "n_training": int(opts["n_training"]),
                    "n_gold_per_type": int(opts["n_gold"]), "n_repeats": int(opts["n_repeats"])},
        "pairs": str(pairs_file),
        "metrics": [str(Path(p).resolve()) for p in opts["metrics_paths"]],
        "metric_columns": metric_cols,
        "attribute_columns": attribute_columns(pairs.drop(columns=["_root", "_row"])),
        "view_columns": opts["view_columns"],
        "method_columns": opts["method_columns"],
        "scene_roots": {str(k): str(v) for k, v in roots.items()},
        "offsets": offsets, "tracks": tracks,
        "counts": {kind: int((items["kind"] == kind).sum()) for kind in ITEM_KINDS},
        "training_order": items.loc[items["kind"] == "training", "key"].tolist(),
        **({"design": "pairwise", "methods": list(opts["methods"])}
           if opts["design"] == "pairwise" else {}),
    }


def _write_manifest(tmp: Path, manifest: dict) -> None:
    """``manifest.json`` and ``secrets.json`` (the admin token, file mode 600)."""
    atomic_write_text(tmp / _MANIFEST, json.dumps(manifest, indent=1, default=str))
    secret = tmp / "secrets.json"
    secret.write_text(json.dumps({"admin_token": secrets.token_urlsafe(24)}))
    os.chmod(secret, 0o600)


def crop_path(study_root: str | Path, name: str) -> Path:
    """The crop file ``name`` inside ``STUDY/crops``; refuses anything that leaves that folder.

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
    """A loaded study: its folder, manifest, items (indexed by key) and vote store."""

    root: Path
    manifest: dict
    items: pd.DataFrame
    store: Store

    @property
    def quota(self) -> int:
        return int(self.manifest["votes_per_item"])

    def admin_token(self) -> str:
        if "_admin_token" not in self.__dict__:
            self._admin_token = json.loads((self.root / "secrets.json").read_text())["admin_token"]
        return self._admin_token

    def keys(self, kind: str) -> list[str]:
        return self.items.index[self.items["kind"] == kind].tolist()

    def plan_for(self, rater: str) -> dict:
        """The rater's stored plan, creating (and storing) it on first use.

        A stored plan never changes, so it is kept in memory after the first read.
        """
        cache = self.__dict__.setdefault("_plans", {})
        plan = cache.get(rater)
        if plan is None:
            plan = self.store.plan(rater)
            if plan is None:
                self.store.add_rater(rater, plan=self.new_plan(rater))
                plan = self.store.plan(rater)
            cache[rater] = plan
        return plan

    @property
    def design(self) -> str:
        """``'binary'`` (good/bad; every study built before designs existed) or ``'pairwise'``."""
        return self.manifest.get("design", "binary")

    def new_plan(self, rater: str) -> dict:
        reps = {k: k.split(":", 1)[1] for k in self.keys("repeat")}
        seed = rater_seed(self.manifest["seed"], rater)
        plan = make_plan(training=self.manifest["training_order"], tests=self.keys("test"),
                         golds=self.keys("gold"), repeats=reps, seed=seed)
        if self.design == "pairwise":  # which side A is shown on, per item, for this rater
            plan["sides"] = pairwise_sides(plan, seed=seed)
        return plan

    def next_item(self, rater: str) -> str | None:
        """Key of the rater's next unrated item (None: done)."""
        plan = self.plan_for(rater)
        return self.store.next_item(
            rater, lambda a, v, loads: choose_next(plan, a, v, loads, quota=self.quota))

    def progress(self, rater: str) -> dict:
        """``{'training_done', 'training_total', 'done', 'total'}`` (done/total exclude training).

        Reads the rater's own rows and the per-item vote counters only, so its cost does not
        grow with the other raters' votes.
        """
        plan = self.plan_for(rater)
        assigned, voted, votes = self.store.rater_state(rater)
        training = set(plan["training"])
        loads = {k: n for k, n in votes.items() if k not in voted}  # others' votes on open items
        return {"training_done": len(voted & training), "training_total": len(training),
                "done": len(voted - training),
                "total": plan_total(plan, assigned, loads, quota=self.quota)}

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
                if found != self.manifest["study_id"]:
                    raise StudyChanged(f"{path}: study_id is {found!r}, the server was started "
                                       f"for {self.manifest['study_id']!r}")
                self._manifest_sig = sig
        except (OSError, ValueError) as err:
            raise StudyChanged(f"{path}: {err}") from err


class StudyChanged(RuntimeError):
    """The study folder changed under a running server (rebuilt or removed): restart it."""


def load_study(root: str | Path) -> Study:
    """Load ``STUDY/`` (InputError naming the file if it is not a readable study folder)."""
    root = Path(root).resolve()
    path = root / _MANIFEST
    if not path.is_file():
        raise InputError(root, _MANIFEST, "a study folder made by 'annotate build'", "no manifest")
    manifest = _read_manifest(path)
    items_path = root / "items.csv"
    if not items_path.is_file():
        raise InputError(items_path, None, "the study's items table", "no such file")
    design = manifest.get("design", "binary")
    files = ("ref_file", "a_file", "b_file", "method_a", "method_b") if design == "pairwise" else (
        "ref_file", "ren_file")
    items = read_table(items_path, required=("key", "item_id", "kind", "pair_id", *files),
                       what="study items table",
                       dtype={"key": str, "item_id": str, "pair_id": str, "camera": str,
                              "track_id": str, "clip_id": str, "method_a": str, "method_b": str,
                              "pair_id_a": str, "pair_id_b": str, "expected": str}
                       if design == "pairwise" else
                       {"key": str, "item_id": str, "pair_id": str, "camera": str,
                        "track_id": str, "clip_id": str})
    if items["key"].duplicated().any() or items["key"].isna().any():
        raise InputError(items_path, "key", "one row per item key", "a duplicated or empty key")
    db = root / "votes.sqlite"
    try:
        store = Store(db, manifest["study_id"], votes=VOTES[design])
    except sqlite3.Error as exc:
        raise InputError(db, None, "a readable SQLite vote store in a writable study folder",
                         f"{type(exc).__name__}: {exc}") from None
    return Study(root, manifest, items.set_index("key", drop=False).rename_axis(None), store)


#: manifest.json keys every reader relies on, and their JSON types.
#: (``design``, absent in binary studies, is checked in :func:`_read_manifest`.)
_MANIFEST_KEYS = {"study_id": str, "seed": int, "access": str, "votes_per_item": int,
                  "training_order": list, "counts": dict}


def _read_manifest(path: Path) -> dict:
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, None, "a JSON study manifest", f"unreadable JSON ({exc})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != "nvrq-study":
        raise InputError(path, "format", "'nvrq-study'", repr(manifest.get("format") if isinstance(
            manifest, dict) else type(manifest).__name__))
    for key, typ in _MANIFEST_KEYS.items():
        if not isinstance(manifest.get(key), typ) or isinstance(manifest.get(key), bool):
            raise InputError(path, key, f"a JSON {typ.__name__}", repr(manifest.get(key)))
    if manifest.get("design", "binary") not in DESIGNS:
        raise InputError(path, "design", "one of {'binary', 'pairwise'}", repr(manifest["design"]))
    return manifest


def unplaced_votes(study: Study) -> dict[str, int]:
    """Votes in the study's store that an export cannot place, counted by reason
    (``{reason: n}``; empty when every vote has an item of this study)."""
    votes = study.store.votes()
    out = {}
    unknown = int((~votes["item"].isin(study.items.index)).sum())
    if unknown:
        out["for items not in items.csv"] = unknown
    other = study.store.other_study_votes()
    if other:
        out["recorded under another study id (the folder was rebuilt)"] = other
    return out
