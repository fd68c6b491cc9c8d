"""Execution engines for scoring: ``local`` (one process, :mod:`nvrq.scoring.driver`; the default) and
``ray`` (a Ray cluster, :mod:`nvrq.engines.ray_engine`). Both call the same per-batch function
of :mod:`nvrq.scoring.core`, so they give the same numbers. A pairs dataset (a folder partitioned
by clip_id) is scored by either into the same sharded, resumable output folder
(:mod:`nvrq.engines.shards`; locally clip by clip, :mod:`nvrq.engines.local`).

Ray is an optional extra (``pip install -e ".[ray]"``); this package imports it only when
the Ray engine runs. The command-line options that choose an engine are
:mod:`nvrq.commands.engine_options`.
"""

from __future__ import annotations

from data_schema.errors import InputError

__all__ = ["ENGINES", "RAY_EXTRA", "SHARD_PAIRS", "require_ray"]

ENGINES = ("local", "ray")
#: Default number of pairs per output shard of a sharded run (GT groups are kept whole).
SHARD_PAIRS = 256
RAY_EXTRA = 'pip install -e ".[ray]"'


def require_ray():
    """Import ``ray`` and ``ray.data`` or stop with a one-line error naming the extra.

    Returns
    -------
    module
        The imported ``ray`` module.
    """

    try:
        import ray
        import ray.data  # noqa: F401
    except ImportError:
        raise InputError(param="engine", expected=f"Ray installed ({RAY_EXTRA})", got="ray is not installed") from None
    return ray

# a submodule (e.g. nvrq.engines.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.engines", {}, globals())
