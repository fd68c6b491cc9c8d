"""The engine options of ``nvrq score`` and ``nvrq proxy imagenet|clip``: their checks, the
``--engine ray`` branch (a thin shell over :func:`nvrq.engines.ray_engine.score_on_ray`) and the
report line of a sharded run (either engine)."""

from __future__ import annotations

import sys
from pathlib import Path

from data_schema import datasets as ds
from data_schema.errors import InputError
from data_schema.tables import timing_path
from nvrq.engines.ray_engine import RayJob, score_on_ray

__all__ = ["check_engine_args", "sharded_output", "report_sharded", "run_ray"]


def sharded_output(args, *, local_datasets: bool = False) -> bool:
    """Whether the command writes a sharded, resumable folder: always with ``--engine ray``, and
    on the local engine for a pairs dataset when the command scores datasets locally."""
    return args.engine == "ray" or (local_datasets and ds.is_dataset(args.pairs))


def check_engine_args(args, *, local_datasets: bool = False) -> None:
    """Options that only make sense with one engine, and a sharded run's output folder
    (``local_datasets``: the local engine scores a pairs dataset into such a folder too)."""
    if args.engine != "ray" and args.address:
        raise InputError("--address", None, "--engine ray", f"--engine {args.engine}")
    if args.engine == "ray":
        if getattr(args, "precision", "fp32") != "fp32":
            raise InputError("--precision", None, "fp32 with --engine ray (reduced precision runs on "
                             "the local engine)", args.precision)
        if getattr(args, "column_tag", None) is not None:
            raise InputError("--column-tag", None, "untagged columns with --engine ray", args.column_tag)
    if not sharded_output(args, local_datasets=local_datasets):
        return
    why = "--engine ray" if args.engine == "ray" else "a pairs dataset"
    if getattr(args, "scene", None) is not None:
        raise InputError("--scene", None, f"the pairs' scene_root column with {why}", args.scene)
    if Path(args.out).suffix != "":
        raise InputError("--out", None, f"a folder without a suffix for {why} (Parquet shards "
                         "partitioned by clip_id)", args.out)


def report_sharded(res: dict, out, *, engine: str) -> None:
    """The one stderr line after a sharded run (:func:`nvrq.engines.shards.run_sharded`'s counts)."""
    done = f"{res['shards_done_before']} of {res['shards']} shards were already written; " \
        if res["shards_done_before"] else ""
    print(f"{done}scored {res['pairs_scored']} pairs in {res['seconds']:.1f} s on {engine} -> {out}",
          file=sys.stderr)


def run_ray(args, scorer) -> int:
    """Run ``scorer`` (:mod:`nvrq.engines.scorers`) over ``args.pairs`` on Ray into ``args.out``
    (timing table beside it, :func:`data_schema.tables.timing_path`)."""

    job = RayJob(pairs=str(args.pairs), out=str(args.out), scorer=scorer, shard_pairs=args.shard_pairs,
                 actors=args.actors, progress=not args.quiet)
    res = score_on_ray(job, timing_path=timing_path(args.out), address=args.address)
    report_sharded(res, args.out, engine="Ray")
    return 0
