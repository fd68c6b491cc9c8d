"""``nvrq score DATASET --out METRICS/`` on the local engine: a pairs dataset, shard by shard.

The run has the Ray engine's plan, output and resume (:func:`nvrq.engines.shards.run_sharded`):
the dataset is cut into the same shards (whole GT groups within a clip, at most
``shard_pairs`` pairs each), each shard is scored in this process by the local driver
(:func:`nvrq.scoring.driver.score_pairs`, with its decoding beside the encoder) and written atomically
as soon as it is done, then the timing table and ``_dataset.json`` are written. A killed run,
started again with the same command, computes only the shards whose files are missing.

Memory stays bounded by a clip and a shard: the shards come clip by clip, each reads its rows
from its clip's file (:func:`nvrq.engines.shards.shard_pairs`; a few clip files kept), and
only one shard's images and crops are held at a time. The encoder is loaded once, and only
when some shard is left to do. No Ray needed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence

from data_schema.errors import check_int
from nvrq.engines import shards as sh
from nvrq.scoring.core import check_metric_args
from nvrq.scoring.driver import REQUIRED_COLUMNS, score_pairs

__all__ = ["score_dataset"]


def score_dataset(pairs, out, *, metrics: Sequence[str], options: Mapping, timing_path,
                  load_encoder: Callable[[], object] | None = None, tau: float | None = None,
                  batch_size: int = 32, shard_pairs: int = 256, rename: Mapping[str, str] | None = None,
                  progress: bool = True) -> dict:
    """Score (or finish scoring) the pairs dataset ``pairs`` into the folder ``out``.

    ``metrics``: column names (:func:`nvrq.metrics.resolve_metrics`); ``load_encoder()``
    returns the encoder that ``nvrq:*``/``nvrq_ca:*`` need (called once, only when a shard is
    left to do); ``tau`` for NVRQ-CA. ``rename`` maps a column to the name it is written under
    (e.g. ``nvrq:E`` -> ``nvrq:E@int8``). ``options`` go to ``_plan.json``: what a resumed run
    must share with the first (their ``columns`` are the written names). ``timing_path``: the
    timing table (``metric, seconds, pairs``) written when every shard exists.
    Returns the counts of :func:`nvrq.engines.shards.run_sharded`.
    """
    metrics, rename = list(metrics), dict(rename or {})
    # bad arguments stop here, before the plan is written (the loader stands for the encoder)
    check_metric_args(metrics, encoder=load_encoder, tau=tau, batch_size=batch_size)
    check_int("shard_pairs", shard_pairs)

    def compute(todo: list[sh.Shard]) -> Iterator[sh.ShardResult]:
        encoder = load_encoder() if load_encoder is not None else None
        for shard in todo:  # planned clip by clip
            res = score_pairs(sh.shard_pairs(shard), metrics=metrics, encoder=encoder, tau=tau,
                              base=shard.base, batch_size=batch_size, progress=False, where=shard.path)
            seconds = dict(zip(res.timing["metric"], res.timing["seconds"].astype(float), strict=True))
            yield (shard, res.table.rename(columns=rename),
                   {rename.get(c, c): s for c, s in seconds.items()})

    return sh.run_sharded(pairs, out, required=REQUIRED_COLUMNS, options=dict(options),
                          max_pairs=shard_pairs, timing_path=timing_path, compute=compute,
                          progress=progress, desc="score")
