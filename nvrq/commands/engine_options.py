"""The engine options of ``nvrq score`` and ``nvrq proxy imagenet|clip``: the options themselves,
their checks, the ``--engine ray`` branch (a thin shell over
:func:`nvrq.engines.ray_engine.score_on_ray`) and the report line of a sharded run (either engine).

Layer: commands (CLI shell).
"""

from __future__ import annotations

import sys
from pathlib import Path

from data_schema.errors import InputError
from nvrq.cli_types import int_arg, show_progress
from nvrq.engines import ENGINES, SHARD_PAIRS

__all__ = ["add_engine_args", "check_engine_args", "sharded_output", "report_sharded", "run_ray"]


def add_engine_args(parser) -> None:
    """Add ``--engine {local,ray}``, ``--address``, ``--actors`` and ``--shard-pairs`` to a command.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser; the options go in its argument group ``engine``.
    """
    g = parser.add_argument_group("engine")
    g.add_argument("--engine", choices=ENGINES, default="local",
                   help="local: this process (default); ray: a Ray cluster. With ray, or a pairs "
                        "dataset on local, --out is a folder of Parquet shards partitioned by "
                        "clip_id, resumable")
    g.add_argument("--address", default=None, metavar="ADDR",
                   help="--engine ray: join the cluster at ADDR (HEAD:6379, or auto); default: start "
                        "a local Ray instance sized to this machine")
    g.add_argument("--actors", type=int_arg(), default=None, metavar="N",
                   help="--engine ray: encoder actors (default: one per GPU with --device cuda, else "
                        "one per 2 CPUs)")
    g.add_argument("--shard-pairs", type=int_arg(), default=SHARD_PAIRS, metavar="N",
                   help="pairs per output shard of a sharded run (--engine ray, or a pairs dataset), "
                        f"GT groups kept whole (default {SHARD_PAIRS})")


def sharded_output(args, *, local_datasets: bool = False) -> bool:
    """Whether the command writes a sharded, resumable folder.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments (``engine``, ``pairs``).
    local_datasets : bool, optional
        Whether the command scores a pairs dataset locally into such a folder.

    Returns
    -------
    bool
        True with ``--engine ray``, and on the local engine for a pairs dataset when
        ``local_datasets``.
    """
    from data_schema import datasets as ds

    return args.engine == "ray" or (local_datasets and ds.is_dataset(args.pairs))


def check_engine_args(args, *, local_datasets: bool = False) -> None:
    """Refuse options that only make sense with the other engine, and a sharded run's bad output.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of the command.
    local_datasets : bool, optional
        As for :func:`sharded_output`.

    Raises
    ------
    InputError
        ``--address`` or ``--actors`` without ``--engine ray``; ``--precision`` other than fp32 or
        ``--column-tag`` with it; ``--scene`` or an ``--out`` with a suffix for a sharded run.
    """
    if args.engine != "ray" and args.address:
        raise InputError("--address", None, "--engine ray", f"--engine {args.engine}")
    if args.engine != "ray" and getattr(args, "actors", None) is not None:
        raise InputError("--actors", None, "--engine ray (the local engine has no actors)", f"--engine {args.engine}")
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
    """Print the one stderr line after a sharded run, and a warning line per metric column
    with no value (:func:`nvrq.scoring.core.empty_column_warning`).

    Parameters
    ----------
    res : dict
        :func:`nvrq.engines.shards.run_sharded`'s counts (``shards``, ``shards_done_before``,
        ``pairs_scored``, ``seconds``, ``empty_columns``).
    out : str or Path
        The output folder.
    engine : str
        The engine's name in the line, e.g. ``"Ray"``.
    """
    done = f"{res['shards_done_before']} of {res['shards']} shards were already written; " \
        if res["shards_done_before"] else ""
    print(f"{done}scored {res['pairs_scored']} pairs in {res['seconds']:.1f} s on {engine} -> {out}",
          file=sys.stderr)
    from nvrq.scoring.core import empty_column_warning

    for metric in res.get("empty_columns", ()):
        print(empty_column_warning(metric, res["pairs"]), file=sys.stderr)


def run_ray(args, scorer) -> int:
    """Run ``scorer`` over ``args.pairs`` on Ray into ``args.out``, the timing table beside it.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments (``pairs``, ``out``, ``shard_pairs``, ``actors``, ``quiet``,
        ``address``).
    scorer : object
        A scorer of :mod:`nvrq.engines.scorers`.

    Returns
    -------
    int
        The exit status, 0.
    """
    from data_schema.tables import timing_path
    from nvrq.engines.ray_engine import RayJob, score_on_ray

    job = RayJob(pairs=str(args.pairs), out=str(args.out), scorer=scorer, shard_pairs=args.shard_pairs,
                 actors=args.actors, progress=show_progress(args))
    res = score_on_ray(job, timing_path=timing_path(args.out), address=args.address)
    report_sharded(res, args.out, engine="Ray")
    return 0
