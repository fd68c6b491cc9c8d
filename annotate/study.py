"""A rating study folder: build it from a pairs table, load it, resolve its crops safely.

Layout of ``STUDY/``::

    manifest.json   seed, options and every choice (tracks, frames, offsets, items, scene roots)
    items.csv       one row per item: key, item_id, kind, pair_id, ref_file, ren_file,
                    expected (gold), pair metadata and attributes
    metrics.csv     pair_id + metric columns (only with --metrics)
    secrets.json    the admin token (file mode 600)
    crops/          <opaque id>.jpg|png display crops (names reveal nothing)
    votes.sqlite    the vote store (created on first use)

Item kinds (SPEC section 5): ``test``; ``training`` (shown first, excluded from analysis);
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
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from annotate import crops as _crops
from annotate.assign import choose_next, make_plan, plan_total, rater_seed
from annotate.design import attribute_columns, choose_offsets, select_test_pairs
from annotate.store import Store
from data_schema.errors import InputError
from data_schema.tables import (
    ITEM_KINDS,
    PAIR_META_COLUMNS,
    PAIRS_COLUMNS,
    atomic_write_text,
    pair_scene_roots,
    read_table,
)

__all__ = ["build_study", "load_study", "Study", "crop_path"]

_MANIFEST = "manifest.json"


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
                metrics_path: str | Path | None = None, tracks: int = 12,
                frames_per_track: int = 12, offsets: str = "all", votes_per_item: int = 5,
                seed: int = 0, n_training: int = 5, n_gold: int = 3, n_repeats: int = 5,
                size: int = 320, image_format: str = "jpg", access: str = "open",
                break_every: int = 50, progress: bool = True) -> Path:
    """Build the study folder ``out`` (refused if it exists and is not empty); returns it."""
    out = Path(out)
    pairs_path = Path(pairs_path)
    if out.exists() and any(out.iterdir()):
        raise InputError(out, None, "a new or empty study folder (votes are never overwritten)",
                         "a non-empty folder")
    for name, val, lo in (("--tracks", tracks, 1), ("--frames-per-track", frames_per_track, 1),
                          ("--votes-per-item", votes_per_item, 1), ("--size", size, 32),
                          ("--break-every", break_every, 1)):
        if int(val) < lo:
            raise InputError(name, None, f"an integer >= {lo}", val)
    if image_format not in ("jpg", "png"):
        raise InputError("--image-format", None, "one of {'jpg', 'png'}", image_format)
    if access not in ("open", "token"):
        raise InputError("--access", None, "one of {'open', 'token'}", access)
    pairs = read_table(pairs_path, required=PAIRS_COLUMNS, what="pairs table")
    if pairs.empty:
        raise InputError(pairs_path, None, "at least one pair", "an empty table")
    pairs = pairs.assign(_root=pair_scene_roots(pairs, scene_root=scene, base=pairs_path.resolve().parent,
                                                         where=str(pairs_path)), _row=np.arange(len(pairs)))
    rng = np.random.default_rng(seed)
    chosen_offsets = choose_offsets(offsets, pairs["y_offset_m"])
    tests, record = select_test_pairs(pairs, offsets=chosen_offsets, n_tracks=int(tracks),
                                      frames_per_track=int(frames_per_track), rng=rng)
    training = _pick_training(pairs, tests, n_training, rng)
    gold_src = tests.iloc[sorted(rng.choice(len(tests), size=min(2 * n_gold, len(tests)),
                                            replace=False).tolist())]
    rep_src = tests.iloc[sorted(rng.choice(len(tests), size=min(n_repeats, len(tests)),
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

    attrs = attribute_columns(pairs.drop(columns=["_root", "_row"]))
    ids = _opaque_ids(rng, 2 * len(rows))
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent if out.parent.exists() else None))
    (tmp / "crops").mkdir()
    cache: dict[str, np.ndarray] = {}

    def image(root: str, rel: str, row: int, field: str) -> np.ndarray:
        path = str(Path(root) / rel)
        if path not in cache:
            if len(cache) > 64:
                cache.clear()
            cache[path] = _crops.read_bgr(Path(path), where=str(pairs_path), field=f"row {row}: {field}")
        return cache[path]

    items = []
    try:
        for k, (r, kind, key, item_id, expected) in enumerate(
                tqdm(rows, desc="cutting crops", unit="item", disable=not progress)):
            row = int(r["_row"])
            gt = _crops.cut(image(r["_root"], r["gt_path"], row, "gt_path"),
                            [r[f"gt_{c}"] for c in ("x0", "y0", "x1", "y1")],
                            where=str(pairs_path), field=f"row {row}: gt box")
            if kind == "gold":
                ren = gt.copy() if expected == 1 else _crops.broken_render(gt, rng=rng)
            else:
                ren = _crops.cut(image(r["_root"], r["render_path"], row, "render_path"),
                                 [r[f"r_{c}"] for c in ("x0", "y0", "x1", "y1")],
                                 where=str(pairs_path), field=f"row {row}: render box")
            a, b = _crops.pad_pair(gt, ren, size=int(size))
            ref_file, ren_file = f"{ids[2 * k]}.{image_format}", f"{ids[2 * k + 1]}.{image_format}"
            _crops.write_image(tmp / "crops" / ref_file, a, fmt=image_format)
            _crops.write_image(tmp / "crops" / ren_file, b, fmt=image_format)
            meta = {c: r[c] for c in (*PAIR_META_COLUMNS, *attrs)}
            items.append({"key": key, "item_id": item_id, "kind": kind, "pair_id": r["pair_id"],
                          "ref_file": ref_file, "ren_file": ren_file,
                          "expected": np.nan if expected is None else expected, **meta})
        items_df = pd.DataFrame(items)
        items_df.to_csv(tmp / "items.csv", index=False)
        metric_cols: list[str] = []
        if metrics_path is not None:
            metrics = read_table(metrics_path, required=["pair_id"], what="metrics table")
            metric_cols = [c for c in metrics.columns if c != "pair_id"]
            metrics[metrics["pair_id"].isin(set(items_df["pair_id"]))].to_csv(
                tmp / "metrics.csv", index=False)
        roots = pairs.drop_duplicates("clip_id").set_index("clip_id")["_root"]
        manifest = {
            "format": "nvrq-study", "version": 1,
            "study_id": f"{out.resolve().name}-{secrets.token_hex(4)}",
            "seed": int(seed), "access": access, "votes_per_item": int(votes_per_item),
            "break_every": int(break_every), "display_size": int(size), "image_format": image_format,
            "options": {"tracks": int(tracks), "frames_per_track": int(frames_per_track),
                        "offsets": str(offsets), "n_training": int(n_training),
                        "n_gold_per_type": int(n_gold), "n_repeats": int(n_repeats)},
            "pairs": str(pairs_path.resolve()),
            "metrics": None if metrics_path is None else str(Path(metrics_path).resolve()),
            "metric_columns": metric_cols, "attribute_columns": attrs,
            "scene_roots": {str(k): str(v) for k, v in roots.items()},
            "offsets": chosen_offsets, "tracks": record,
            "counts": {kind: int((items_df["kind"] == kind).sum()) for kind in ITEM_KINDS},
            "training_order": [it["key"] for it in items if it["kind"] == "training"],
        }
        atomic_write_text(tmp / _MANIFEST, json.dumps(manifest, indent=1, default=str))
        secret = tmp / "secrets.json"
        secret.write_text(json.dumps({"admin_token": secrets.token_urlsafe(24)}))
        os.chmod(secret, 0o600)
        if out.exists():
            out.rmdir()
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


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
        return json.loads((self.root / "secrets.json").read_text())["admin_token"]

    def keys(self, kind: str) -> list[str]:
        return self.items.index[self.items["kind"] == kind].tolist()

    def plan_for(self, rater: str) -> dict:
        """The rater's stored plan, creating (and storing) it on first use."""
        plan = self.store.plan(rater)
        if plan is None:
            self.store.add_rater(rater, plan=self.new_plan(rater))
            plan = self.store.plan(rater)
        return plan

    def new_plan(self, rater: str) -> dict:
        reps = {k: k.split(":", 1)[1] for k in self.keys("repeat")}
        return make_plan(training=self.manifest["training_order"], tests=self.keys("test"),
                         golds=self.keys("gold"), repeats=reps,
                         seed=rater_seed(self.manifest["seed"], rater))

    def next_item(self, rater: str) -> str | None:
        """Key of the rater's next unrated item (None: done)."""
        plan = self.plan_for(rater)
        return self.store.next_item(
            rater, lambda a, v, loads: choose_next(plan, a, v, loads, quota=self.quota))

    def progress(self, rater: str) -> dict:
        """``{'training_done', 'training_total', 'done', 'total'}`` (done/total exclude training)."""
        plan = self.plan_for(rater)
        asg = self.store.assignments(rater)
        voted = set(asg.loc[asg["voted"], "item"])
        training = set(plan["training"])
        others = self.store.assignments()
        others = others[(others["rater"] != rater) & others["voted"]]
        loads = others.groupby("item").size().to_dict()
        return {"training_done": len(voted & training), "training_total": len(training),
                "done": len(voted - training),
                "total": plan_total(plan, asg["item"].tolist(), loads, quota=self.quota)}


def load_study(root: str | Path) -> Study:
    """Load ``STUDY/`` (InputError if it is not a study folder)."""
    root = Path(root).resolve()
    path = root / _MANIFEST
    if not path.is_file():
        raise InputError(root, _MANIFEST, "a study folder made by 'annotate build'", "no manifest")
    manifest = json.loads(path.read_text())
    items = pd.read_csv(root / "items.csv", dtype={"key": str, "item_id": str, "pair_id": str,
                                                   "camera": str, "track_id": str, "clip_id": str})
    return Study(root, manifest, items.set_index("key", drop=False).rename_axis(None),
                 Store(root / "votes.sqlite", manifest["study_id"]))
