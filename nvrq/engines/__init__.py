"""Execution engines for scoring: ``local`` (one process, :mod:`nvrq.scoring.driver`; the default) and
``ray`` (a Ray cluster, :mod:`nvrq.engines.ray_engine`). Both call the same per-batch function
of :mod:`nvrq.scoring.core`, so they give the same numbers. A pairs dataset (a folder partitioned
by clip_id) is scored by either into the same sharded, resumable output folder
(:mod:`nvrq.engines.shards`; locally clip by clip, :mod:`nvrq.engines.local`).

Ray is an optional extra (``pip install -e ".[ray]"``); this package imports it only when
the Ray engine runs.
"""

from __future__ import annotations

from data_schema.cliargs import int_arg
from data_schema.errors import InputError

__all__ = ["ENGINES", "RAY_EXTRA", "add_engine_args", "require_ray"]

ENGINES = ("local", "ray")
RAY_EXTRA = 'pip install -e ".[ray]"'


def add_engine_args(parser) -> None:
    """``--engine {local,ray}``, ``--address``, ``--actors``, ``--shard-pairs`` on a command."""
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
    g.add_argument("--shard-pairs", type=int_arg(), default=256, metavar="N",
                   help="pairs per output shard of a sharded run (--engine ray, or a pairs dataset), "
                        "GT groups kept whole (default 256)")


def require_ray():
    """Import ``ray`` and ``ray.data`` or stop with a one-line error naming the extra."""

    try:
        import ray
        import ray.data  # noqa: F401
    except ImportError:
        raise InputError(param="engine", expected=f"Ray installed ({RAY_EXTRA})", got="ray is not installed") from None
    return ray
