"""The ``--engine ray`` branch of ``nvrq score`` (a thin shell over :func:`score_on_ray`)."""

from __future__ import annotations

import sys

from data_schema.errors import InputError

__all__ = ["check_engine_args", "run_ray_score"]


def check_engine_args(args) -> None:
    """Options that only make sense with one engine, and the Ray engine's output folder."""
    if args.engine != "ray":
        if args.address:
            raise InputError("--address", None, "--engine ray", f"--engine {args.engine}")
        return
    if str(args.out).lower().endswith((".csv", ".parquet")):
        raise InputError("--out", None, "a folder for --engine ray (Parquet shards partitioned by clip_id)",
                         args.out)
    if args.shard_pairs < 1:
        raise InputError("--shard-pairs", None, "a positive number of pairs", args.shard_pairs)
    if args.actors is not None and args.actors < 1:
        raise InputError("--actors", None, "a positive number of actors", args.actors)


def run_ray_score(args, *, columns, encoder_name, tau, timing_path) -> int:
    """Score on Ray; ``columns``/``encoder_name``/``tau`` resolved by the caller as for local."""
    from nvrq.engines import require_ray
    from nvrq.engines.ray_engine import RayJob, score_on_ray

    require_ray()
    job = RayJob(pairs=str(args.pairs), out=str(args.out), columns=tuple(columns), encoder=encoder_name,
                 weights=args.weights, device=args.device, tau=tau, batch_size=args.batch_size,
                 shard_pairs=args.shard_pairs, actors=args.actors, progress=not args.quiet)
    res = score_on_ray(job, timing_path=timing_path, address=args.address)
    done = f"{res['shards_done_before']} of {res['shards']} shards were already written; " \
        if res["shards_done_before"] else ""
    print(f"{done}scored {res['pairs_scored']} pairs in {res['seconds']:.1f} s on Ray -> {args.out}",
          file=sys.stderr)
    return 0
