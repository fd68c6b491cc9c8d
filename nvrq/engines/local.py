"""``nvrq score DATASET --out METRICS/`` on the local engine: a pairs dataset, shard by shard.

Engines layer. The run has the Ray engine's plan, output and resume
(:func:`nvrq.engines.shards.run_sharded`): the dataset is cut into the same shards (whole GT
groups within a clip, at most ``shard_pairs`` pairs each), each shard is scored in this process
by the local driver (:func:`nvrq.scoring.driver.score_pairs`, with its decoding beside the
encoder) and written atomically as soon as it is done, then the timing table and
``_dataset.json`` are written. A killed run, started again with the same command, computes only
the shards whose files are missing.

Memory stays bounded by a clip and a shard: the shards come clip by clip, each reads its rows
from its clip's file (:func:`nvrq.engines.shards.shard_pairs`; a few clip files kept), and
only one shard's images and crops are held at a time. The encoder is loaded once, and only
when some shard is left to do. No Ray needed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping

from data_schema.errors import check_int
from nvrq.engines import SHARD_PAIRS
from nvrq.engines import shards as sh
from nvrq.scoring.driver import score_pairs
from nvrq.scoring.plan import ScorePlan

__all__ = ["score_dataset"]


def score_dataset(pairs, out, plan: ScorePlan, *, timing_path, load_encoder: Callable[[], object] | None = None,
                  shard_pairs: int = SHARD_PAIRS, rename: Mapping[str, str] | None = None,
                  progress: bool = True) -> dict:
    """Score (or finish scoring) the pairs dataset ``pairs`` into the folder ``out``.

    Parameters
    ----------
    pairs : path
        A pairs dataset (a folder partitioned by ``clip_id``) or a table with ``clip_id``.
    out : path
        The output folder (sharded, resumable).
    plan : ScorePlan
        What to compute (:func:`nvrq.scoring.plan.resolve_plan`), checked there once.
    timing_path : path
        The timing table (``metric, seconds, pairs``), written when every shard exists.
    load_encoder : callable, optional
        ``load_encoder()`` returns the encoder of the plan's encoder columns; called once, only
        when a shard is left to do.
    shard_pairs : int
        Pairs per shard (GT groups kept whole).
    rename : mapping, optional
        A column -> the name it is written under (``nvrq:E`` -> ``nvrq:E@int8``).
    progress : bool
        A progress bar on stderr.

    Returns
    -------
    dict
        The counts of :func:`nvrq.engines.shards.run_sharded`.

    Raises
    ------
    InputError
        Naming ``shard_pairs``, or ``encoder`` when the plan has encoder columns and no loader,
        before the plan file is written.
    """
    rename = dict(rename or {})
    check_int("shard_pairs", shard_pairs)
    if plan.encoder_specs and load_encoder is None:
        from data_schema.errors import InputError

        raise InputError(param="encoder", expected=f"a loaded encoder for {', '.join(plan.model_columns)}", got=None)
    options = {**plan.options(), "columns": [rename.get(c, c) for c in plan.columns],
               "score_plan": plan.to_dict()}

    def compute(todo: list[sh.Shard]) -> Iterator[sh.ShardResult]:
        encoder = load_encoder() if load_encoder is not None else None
        for shard in todo:  # planned clip by clip
            res = score_pairs(sh.shard_pairs(shard), plan=plan, encoder=encoder, base=shard.base, progress=False,
                              where=shard.path)
            seconds = dict(zip(res.timing["metric"], res.timing["seconds"].astype(float), strict=True))
            yield (shard, res.table.rename(columns=rename),
                   {rename.get(c, c): s for c, s in seconds.items()})

    return sh.run_sharded(pairs, out, sh.ShardJob(options, shard_pairs, timing_path, progress=progress),
                          compute=compute)
