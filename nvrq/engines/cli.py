"""The ``--engine ray`` branch of ``nvrq score`` and ``nvrq proxy imagenet|clip`` (a thin shell
over :func:`nvrq.engines.ray_engine.score_on_ray`)."""

from __future__ import annotations

import sys
from pathlib import Path

from data_schema.errors import InputError
from data_schema.tables import timing_path
from nvrq.engines.ray_engine import RayJob, score_on_ray

__all__ = ["check_engine_args", "run_ray"]


def check_engine_args(args) -> None:
    """Options that only make sense with one engine, and the Ray engine's output folder."""
    if args.engine != "ray":
        if args.address:
            raise InputError("--address", None, "--engine ray", f"--engine {args.engine}")
        return
    if getattr(args, "precision", "fp32") != "fp32":
        raise InputError("--precision", None, "fp32 with --engine ray (reduced precision runs on "
                         "the local engine)", args.precision)
    if getattr(args, "column_tag", None) is not None:
        raise InputError("--column-tag", None, "untagged columns with --engine ray", args.column_tag)
    if getattr(args, "scene", None) is not None:
        raise InputError("--scene", None, "the pairs' scene_root column with --engine ray", args.scene)
    if Path(args.out).suffix != "":
        raise InputError("--out", None, "a folder without a suffix for --engine ray (Parquet shards partitioned by clip_id)",
                         args.out)
    if getattr(args, "batch_size", 1) < 1:
        raise InputError("--batch-size", None, "a positive integer", args.batch_size)
    if args.shard_pairs < 1:
        raise InputError("--shard-pairs", None, "a positive number of pairs", args.shard_pairs)
    if args.actors is not None and args.actors < 1:
        raise InputError("--actors", None, "a positive number of actors", args.actors)


def run_ray(args, scorer) -> int:
    """Run ``scorer`` (:mod:`nvrq.engines.scorers`) over ``args.pairs`` on Ray into ``args.out``
    (timing table beside it, :func:`data_schema.tables.timing_path`)."""

    job = RayJob(pairs=str(args.pairs), out=str(args.out), scorer=scorer, shard_pairs=args.shard_pairs,
                 actors=args.actors, progress=not args.quiet)
    res = score_on_ray(job, timing_path=timing_path(args.out), address=args.address)
    done = f"{res['shards_done_before']} of {res['shards']} shards were already written; " \
        if res["shards_done_before"] else ""
    print(f"{done}scored {res['pairs_scored']} pairs in {res['seconds']:.1f} s on Ray -> {args.out}",
          file=sys.stderr)
    return 0
