"""Shards of a scoring run: the plan, atomic shard files, resume and the final manifest.

A run of ``nvrq score PAIRS --engine ray --out METRICS/`` is cut into shards before any work:
within each clip, pairs that share a GT image stay together (so each GT crop is embedded
once) and consecutive GT groups are packed into shards of at most ``max_pairs`` pairs (a
larger group is a shard of its own). Shard ``k`` of clip ``c`` is written, when done, to
``METRICS/clip_id=<c>/shard-<k>.parquet`` through a hidden temporary file and an atomic
rename, with its rows in plan order and its timing in the file's metadata.

``METRICS/_plan.json`` (written first) fixes the plan: the pairs input, a fingerprint of its
pair ids, the metric columns, encoder and tau and every shard's file name. Running the same
command again after a crash reuses it and computes only the shards whose files are missing;
other options or other pairs are an error naming ``_plan.json``. When every shard exists,
``_dataset.json`` (the reader's mark of a complete dataset) and ``METRICS.timing.csv`` are
written. Readers refuse a folder with ``_plan.json`` but no ``_dataset.json``.

Both engines run through :func:`run_sharded` (plan, write each finished shard, finalize): the
Ray engine computes shards on a cluster (:mod:`nvrq.engines.ray_engine`), the local engine one
after another in this process (:mod:`nvrq.engines.local`). So their outputs have the same
layout, rows and columns, and either engine resumes the other's run.
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from tqdm import tqdm

from data_schema import datasets as ds
from data_schema import tables
from data_schema.errors import InputError
from data_schema.tables import TableKind, atomic_path, atomic_write_text, read_table, write_table
from nvrq.scoring.batches import gt_groups, pack_groups

__all__ = ["Shard", "PairsSource", "read_sources", "plan_shards", "Plan", "load_or_create_plan",
           "shard_pairs", "write_shard", "finalize", "run_sharded", "empty_columns", "ShardJob"]

TIMING_KEY = b"nvrq_timing"


@dataclass(frozen=True)
class PairsSource:
    """One readable unit of the pairs input: a clip's file of a dataset, or a whole table file
    (``rows`` index into it). ``base``: the folder relative ``scene_root`` values start from.

    Attributes
    ----------
    clip_id : str
        The clip this source holds.
    path : str
        The file read: a dataset's clip file or the whole table file.
    rows : (N,) int ndarray
        Positions of the source's rows in the file's table.
    gt_paths : (N,) str ndarray
        ``gt_path`` of each row.
    pair_ids : (N,) str ndarray
        ``pair_id`` of each row.
    base : str
        The folder relative ``scene_root`` values start from.
    """

    clip_id: str
    path: str
    rows: np.ndarray
    gt_paths: np.ndarray
    pair_ids: np.ndarray
    base: str


@dataclass(frozen=True)
class Shard:
    """``rows``: positions in ``source.path``'s table (GT groups kept together).

    Attributes
    ----------
    index : int
        The shard's number in the plan.
    clip_id : str
        The clip of its source.
    path : str
        Its source's pairs file.
    rows : tuple of int
        Positions in ``path``'s table (GT groups kept together).
    base : str
        The folder relative ``scene_root`` values start from.
    """

    index: int
    clip_id: str
    path: str
    rows: tuple
    base: str

    @property
    def name(self) -> str:
        return f"{ds.partition_dir(self.clip_id)}/shard-{self.index:05d}.parquet"


def read_sources(pairs_path, *, required) -> list[PairsSource]:
    """The pairs input as sources: per clip file of a dataset, or per clip of a table file
    (which then needs a ``clip_id`` column).

    Parameters
    ----------
    pairs_path : str or path-like
        A pairs dataset folder or a pairs table file.
    required : iterable of str
        Columns the pairs input must have.

    Returns
    -------
    list of PairsSource
        One source per clip.
    """

    p = Path(pairs_path)
    if ds.is_dataset(p):
        files = ds.dataset_files(p, what="pairs dataset")
        names = ds.check_schemas(files, root=p)
        tables.require_columns(pd.DataFrame(columns=list(names)), tuple(required), where=p)  # the schema's
        out = []
        for clip, f in files:
            t = pq.read_table(f, columns=["pair_id", "gt_path"]).to_pandas()
            out.append(PairsSource(clip, str(f), np.arange(len(t)), t["gt_path"].astype(str).to_numpy(),
                                   t["pair_id"].astype(str).to_numpy(), str(p.resolve())))
        return out
    df = read_table(p, required=tuple(required), kind=TableKind.PAIRS)
    if ds.PARTITION not in df.columns:
        raise InputError(p, "column 'clip_id'", "a pairs dataset partitioned by clip_id or a table "
                         "with a clip_id column", "neither")
    base = str(p.resolve().parent)
    groups = pd.Series(np.arange(len(df))).groupby(df[ds.PARTITION].astype(str), sort=True).groups
    return [PairsSource(str(c), str(p), np.asarray(rows), df["gt_path"].astype(str).to_numpy()[rows],
                        df["pair_id"].astype(str).to_numpy()[rows], base) for c, rows in groups.items()]


def plan_shards(sources: list[PairsSource], *, max_pairs: int) -> list[Shard]:
    """Cut every source into shards of whole GT groups (first-seen order), <= ``max_pairs`` each.

    Parameters
    ----------
    sources : list of PairsSource
        The pairs input's sources.
    max_pairs : int
        Most pairs per shard (a larger GT group is packed alone).

    Returns
    -------
    list of Shard
        The shards, numbered in order.
    """
    shards: list[Shard] = []
    for src in sources:
        for rows in pack_groups([src.rows[g] for g in gt_groups(src.gt_paths)], max_pairs):
            shards.append(Shard(len(shards), src.clip_id, src.path, tuple(rows.tolist()), src.base))
    return shards


@dataclass(frozen=True)
class Plan:
    """The run's plan (``_plan.json``) and which shards are still to do.

    Attributes
    ----------
    out : Path
        The run's output folder.
    shards : list of Shard
        Every planned shard.
    todo : list of Shard
        The shards not yet written.
    doc : dict
        The contents of ``_plan.json``.
    """

    out: Path
    shards: list
    todo: list
    doc: dict


def _fingerprint(sources: list[PairsSource]) -> str:
    h = hashlib.sha1()
    for s in sources:
        h.update(s.clip_id.encode() + b"\0")
        h.update("\n".join(s.pair_ids.tolist()).encode())
    return h.hexdigest()


#: keys of ``_plan.json`` a resumed run need not share: the whole scoring plan (its batch
#: sizes may differ; what must match is in the compared keys, the plan's ``options()``)
_NOT_COMPARED = ("score_plan",)


def load_or_create_plan(out, pairs_path, sources, *, options: dict, max_pairs: int) -> Plan:
    """Create ``out/_plan.json`` or check that the existing one is this run's; list missing shards.

    Parameters
    ----------
    out : str or path-like
        The output folder (new, empty, or an earlier run of the same command).
    pairs_path : str or path-like
        The pairs input (recorded in the plan).
    sources : list of PairsSource
        The pairs input's sources (:func:`read_sources`).
    options : dict
        The run's options, recorded in the plan and compared on resume.
    max_pairs : int
        Most pairs per shard.

    Returns
    -------
    Plan
        The plan, with the shards still to do.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(out, None, "a folder for the Ray engine's sharded output", "an existing file")
    shards = plan_shards(sources, max_pairs=max_pairs)
    doc = {"format": "nvrq-score-plan", "version": 1, "pairs": str(Path(pairs_path).resolve()),
           "n_pairs": int(sum(len(s.rows) for s in sources)), "fingerprint": _fingerprint(sources),
           "max_pairs": int(max_pairs), **options, "shards": [s.name for s in shards]}
    plan_file = out / ds.PLAN
    if plan_file.is_file():
        old = json.loads(plan_file.read_text(encoding="utf-8"))
        for key in (k for k in doc if k not in _NOT_COMPARED):
            if old.get(key) != doc[key]:
                raise InputError(plan_file, key, f"the same {key} as this run (or another `out` folder)",
                                 str(old.get(key))[:60])
    elif out.exists() and any(out.iterdir()):
        raise InputError(out, None, "a new or empty folder, or an earlier run of this command", "other files")
    else:
        atomic_write_text(plan_file, json.dumps(doc, indent=1))
    todo = [s for s in shards if not (out / s.name).is_file()]
    return Plan(out, shards, todo, doc)


@lru_cache(maxsize=4)
def _pairs_file(path: str) -> pd.DataFrame:
    """A pairs file read once per process (a dataset's clip file or a whole table; the last 4 kept)."""

    if path.endswith(".parquet"):
        return pd.read_parquet(path)
    return read_table(path, kind=TableKind.PAIRS)


def shard_pairs(shard: Shard) -> pd.DataFrame:
    """The shard's rows of its pairs file, in plan order (index 0..n-1).

    Parameters
    ----------
    shard : Shard
        The shard to read.

    Returns
    -------
    pandas.DataFrame
        Its pairs rows.
    """

    return _pairs_file(shard.path).iloc[list(shard.rows)].reset_index(drop=True)


def write_shard(out, shard: Shard, table: pd.DataFrame, timing: dict) -> None:
    """Write one shard's metrics atomically (hidden temporary file, then rename).

    Parameters
    ----------
    out : str or path-like
        The run's output folder.
    shard : Shard
        The shard written (its ``name`` is the file's path under ``out``).
    table : pandas.DataFrame
        The shard's metrics: ``pair_id`` and the metric columns.
    timing : dict
        Seconds per column, stored in the Parquet schema metadata.
    """

    t = pa.Table.from_pandas(table, preserve_index=False)
    t = t.replace_schema_metadata({**(t.schema.metadata or {}), TIMING_KEY: json.dumps(timing).encode()})
    target = Path(out) / shard.name
    with atomic_path(target) as tmp:
        pq.write_table(t, tmp)


def finalize(plan: Plan, *, timing_path) -> pd.DataFrame:
    """All shards present: write ``METRICS.timing.csv`` and ``_dataset.json``; returns the timing.

    Parameters
    ----------
    plan : Plan
        The run's plan (every shard must be written).
    timing_path : str or path-like
        Where to write the timing table.

    Returns
    -------
    pandas.DataFrame
        The timing table: ``metric``, ``seconds`` (summed over shards) and ``pairs``.
    """

    missing = [s.name for s in plan.shards if not (plan.out / s.name).is_file()]
    if missing:
        raise InputError(plan.out, f"shard {missing[0]}", "every planned shard written", f"{len(missing)} missing")
    seconds: dict[str, float] = {}
    for s in plan.shards:
        meta = pq.read_schema(plan.out / s.name).metadata or {}
        for k, v in json.loads(meta.get(TIMING_KEY, b"{}")).items():
            seconds[k] = seconds.get(k, 0.0) + float(v)
    cols = plan.doc["columns"]
    timing = pd.DataFrame({"metric": cols, "seconds": [seconds.get(c, 0.0) for c in cols],
                           "pairs": plan.doc["n_pairs"]})
    write_table(timing, timing_path)
    for leftover in plan.out.glob(f"{ds.PARTITION}=*/.shard-*"):
        leftover.unlink(missing_ok=True)
    ds.write_manifest(plan.out, [s.name for s in plan.shards], rows=plan.doc["n_pairs"],
                      extra={"kind": "metrics", "columns": cols})
    return timing


#: what an engine yields per finished shard: the shard, its table (``pair_id`` + columns, rows
#: in plan order) and its seconds per column
ShardResult = tuple[Shard, pd.DataFrame, dict]


@dataclass(frozen=True)
class ShardJob:
    """What a sharded run shares with its resumptions, and how it runs.

    Attributes
    ----------
    options : dict
        What a resumed run must share with the first (``_plan.json``'s keys; ``columns`` the
        written names); a ``score_plan`` key (:meth:`nvrq.scoring.plan.ScorePlan.to_dict`) is
        recorded and not compared.
    shard_pairs : int
        Pairs per shard (GT groups kept whole).
    timing_path : path
        The timing table written at the end.
    extra_columns : tuple of str
        Pairs columns the scorer needs besides :data:`nvrq.scoring.driver.REQUIRED_COLUMNS`.
    progress : bool
        A progress bar on stderr.
    desc : str
        The progress bar's label.
    """

    options: dict
    shard_pairs: int
    timing_path: object
    extra_columns: tuple = ()
    progress: bool = True
    desc: str = "score"


def run_sharded(pairs_path, out, job: ShardJob, *,
                compute: Callable[[list[Shard]], Iterable[ShardResult]]) -> dict:
    """Run (or resume) a sharded scoring run of ``pairs_path`` into the folder ``out``.

    Plans the shards (:func:`load_or_create_plan`), hands the shards still to do to
    ``compute``, which yields ``(shard, table, seconds per column)`` as each finishes, writes
    each one atomically as it arrives, then writes the timing table and the manifest
    (:func:`finalize`).

    Parameters
    ----------
    pairs_path : path
        A pairs dataset, or a table with ``clip_id``.
    out : path
        The output folder.
    job : ShardJob
        The options, shard size, timing path and progress.
    compute : callable
        ``compute(todo) -> iterable of (shard, table, seconds)``.

    Returns
    -------
    dict
        ``{pairs, shards, shards_done_before, pairs_scored, seconds, empty_columns}``
        (:func:`empty_columns`).
    """
    from nvrq.scoring.driver import REQUIRED_COLUMNS

    t0 = time.perf_counter()
    sources = read_sources(pairs_path, required=REQUIRED_COLUMNS + tuple(job.extra_columns))
    plan = load_or_create_plan(out, pairs_path, sources, options=job.options, max_pairs=job.shard_pairs)
    n_todo = sum(len(s.rows) for s in plan.todo)
    if plan.todo:
        results: Iterator[ShardResult] = iter(compute(plan.todo))
        try:
            with tqdm(total=n_todo, unit="pair", desc=job.desc, file=sys.stderr, disable=not job.progress,
                      dynamic_ncols=True) as bar:
                for shard, table, timing in results:
                    write_shard(plan.out, shard, table, timing)
                    bar.update(len(table))
        finally:
            close = getattr(results, "close", None)
            if close is not None:  # a generator's clean-up (a Ray session, a model) runs now
                close()
            _pairs_file.cache_clear()
    finalize(plan, timing_path=job.timing_path)
    return {"pairs": plan.doc["n_pairs"], "shards": len(plan.shards),
            "shards_done_before": len(plan.shards) - len(plan.todo), "pairs_scored": n_todo,
            "seconds": time.perf_counter() - t0, "empty_columns": empty_columns(plan)}


def empty_columns(plan: Plan) -> list[str]:
    """The metric columns of a finished run with no finite value in any shard (a metric NaN on
    every pair: undefined for these crops); reads each shard's columns until each has one.

    Parameters
    ----------
    plan : Plan
        The finished run's plan.

    Returns
    -------
    list of str
        The columns with no finite value.
    """
    left = list(plan.doc["columns"])
    for s in plan.shards:
        if not left:
            break
        t = pq.read_table(plan.out / s.name, columns=left)
        left = [c for c in left if not np.isfinite(t[c].to_numpy().astype(np.float64)).any()]
    return left
