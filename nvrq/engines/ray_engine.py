"""``nvrq score PAIRS --engine ray [--address ADDR] --out METRICS/``: scoring on a Ray cluster.

Stages (Ray Data, streaming):

1. The driver reads the pairs input (a dataset partitioned by ``clip_id``, or a table with a
   ``clip_id`` column) and plans shards (:mod:`nvrq.engines.shards`): GT groups stay whole,
   so every GT crop is still embedded once. Shards already on disk are skipped (resume).
2. CPU tasks (one per shard): read the shard's pairs rows, decode each image once and cut
   the crops (:func:`nvrq.scoring.batches.iter_crop_batches`), and compute the pixel metrics with
   :func:`nvrq.scoring.core.score_crop_batch`.
3. An actor pool holds the encoder (one GPU per actor with ``--device cuda``, CPU actors
   otherwise) and computes NVRQ / NVRQ-CA with the same :func:`score_crop_batch`.
4. The driver writes each finished shard atomically as it arrives, then the manifest.

The pairs files and images must be readable at the same paths on every node; only the driver
writes (each shard through a temporary file and a rename, so a killed driver leaves whole shards).
"""

from __future__ import annotations

import logging
import pickle
import re
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.tables import follow_links
from nvrq.encoders.registry import load_for_worker
from nvrq.engines import SHARD_PAIRS, require_ray
from nvrq.engines import shards as sh
from nvrq.engines.scorers import timing_per_column
from nvrq.scoring.batches import iter_crop_batches
from nvrq.scoring.core import compute_columns
from nvrq.scoring.plan import ScorePlan

__all__ = ["RayJob", "connect", "check_address", "score_on_ray", "actor_pool"]


@dataclass(frozen=True)
class RayJob:
    """A Ray run: the pairs input, the output folder and what to compute
    (a scorer of :mod:`nvrq.engines.scorers`).

    Attributes
    ----------
    pairs : str
        Path of the pairs input (a pairs dataset or a table file).
    out : str
        Output folder of the sharded metrics.
    scorer : object
        What to compute: a scorer of :mod:`nvrq.engines.scorers` (or a score plan).
    shard_pairs : int
        Most pairs per shard (GT groups kept whole).
    actors : int or None
        Number of model actors; None: one per GPU (cuda) or half the CPUs.
    progress : bool
        Whether to show progress.
    """

    pairs: str
    out: str
    scorer: object
    shard_pairs: int = SHARD_PAIRS
    actors: int | None = None
    progress: bool = True


def check_address(address: str) -> None:
    """One-line error when nothing listens at ``HOST:PORT`` (Ray would otherwise wait a minute).

    Parameters
    ----------
    address : str
        Ray address ``HOST:PORT`` (optionally ``ray://``-prefixed), or ``"auto"`` (not checked).
    """
    if address == "auto":
        return
    host, _, port = address.rpartition(":")
    host = host.removeprefix("ray://") or "127.0.0.1"
    try:
        with socket.create_connection((host, int(port)), timeout=3):
            return
    except (OSError, ValueError) as exc:
        raise InputError(param="address", expected="a running Ray cluster at HOST:PORT (`ray start --head`)",
                         got=f"{address} ({type(exc).__name__}: {exc})") from None


@contextmanager
def connect(address: str | None = None):
    """Use the running Ray session, or join ``address``, or start a local instance sized to
    this machine; a session started here is shut down on exit.

    Parameters
    ----------
    address : str or None
        Ray cluster address to join (checked first); None: the running session or a local one.

    Yields
    ------
    module
        The ``ray`` module, initialized.
    """
    ray = require_ray()
    if address:
        check_address(address)
    if ray.is_initialized():
        yield ray
        return

    ray.init(address=address, include_dashboard=False, log_to_driver=False,
             logging_level=logging.WARNING, configure_logging=True)
    try:
        yield ray
    finally:
        ray.shutdown()


def _decode_shard(row: dict, *, scorer, follow: bool) -> dict:
    """CPU task: the shard's crops (decode + crop) and its pixel metrics. ``follow``: the
    driver's link rule (:func:`data_schema.tables.follow_links`; a worker's environment may differ)."""

    shard = row["shard"]
    df = sh.shard_pairs(shard)
    batches = list(iter_crop_batches(df, base=shard.base, max_pairs=max(len(df), 1), background=False,
                                     where=shard.path, follow_links=follow))
    timings = {"decode": sum(b.decode_seconds for b in batches)}
    values = {c: np.full(len(df), np.nan) for c in scorer.columns}
    for b in batches if scorer.pixel_columns else ():  # a ScorePlan's encoder-free columns, checked by it
        for c, v in compute_columns(b, scorer.pixel_specs, timings=timings).items():
            values[c][b.rows] = v
    extra = {c: df[c].to_numpy() for c in scorer.extra_columns}
    return {"shard": shard, "payload": pickle.dumps((df["pair_id"].to_numpy(), batches, values, extra, timings))}


class _ModelActor:
    """Actor: builds the scorer's model (encoder, classifier, CLIP) once, then scores shards."""

    def __init__(self, scorer, threads: int | None):
        import torch

        if threads:
            torch.set_num_threads(threads)
        self.scorer = scorer
        self.model = scorer.load()

    def __call__(self, batch: dict) -> dict:
        return {"shard": batch["shard"], "payload": [_finish(p, self.scorer, self.model) for p in batch["payload"]]}


def _finish(payload: bytes, scorer, model) -> bytes:
    """The shard's model columns (if any) and its table ``pair_id`` + columns, pickled."""

    pair_ids, batches, values, extra, timings = pickle.loads(payload)
    for b in batches if scorer.model_columns else ():
        for c, v in scorer.score(model, b, extra, timings).items():
            values[c][b.rows] = v
    table = pd.DataFrame({"pair_id": pair_ids, **{c: values[c] for c in scorer.columns}})
    return pickle.dumps((table, timing_per_column(scorer, timings)))


def actor_pool(ray, n: int) -> dict:
    """``map_batches`` keywords for a fixed pool of ``n`` actors, in the spelling the installed
    Ray does not deprecate: ``compute=ActorPoolStrategy(size=n)`` from Ray 2.51 (which deprecates
    ``concurrency=``), ``concurrency=n`` in Ray 2.9 to 2.50 (which deprecate ``compute=``).

    Parameters
    ----------
    ray : module
        The ``ray`` module (only its ``__version__`` is read to choose the spelling).
    n : int
        Number of actors in the pool.

    Returns
    -------
    dict
        Keywords for ``map_batches``: ``{"concurrency": n}`` or ``{"compute": ActorPoolStrategy}``.

    >>> from types import SimpleNamespace as NS
    >>> actor_pool(NS(__version__="2.9.3"), 3)
    {'concurrency': 3}
    """
    major, minor = (int(re.match(r"\d+", p).group()) for p in ray.__version__.split(".")[:2])
    if (major, minor) < (2, 51):
        return {"concurrency": n}
    from ray.data import ActorPoolStrategy

    return {"compute": ActorPoolStrategy(size=n)}


def _pipeline(ray, job: RayJob, todo: list):
    """The Ray Data stream of finished shards: ``{"shard", "payload"}`` rows."""
    import ray.data

    ctx = ray.data.DataContext.get_current()
    ctx.enable_progress_bars = False
    ctx.verbose_stats_logs = False
    items = [{"shard": s} for s in todo]
    scorer = job.scorer
    stream = ray.data.from_items(items, override_num_blocks=max(1, len(items))).map(
        _decode_shard, fn_kwargs={"scorer": scorer, "follow": follow_links()}, num_cpus=1)
    if not scorer.model_columns:
        return stream.map(lambda r: {"shard": r["shard"], "payload": _finish(r["payload"], scorer, None)})
    if isinstance(scorer, ScorePlan) and scorer.loader is None:  # the plan names its encoder; the actor loads it
        scorer = replace(scorer, loader=load_for_worker)
    cpus = int(ray.cluster_resources().get("CPU", 1))
    gpus = int(ray.cluster_resources().get("GPU", 0))
    cuda = scorer.device.startswith("cuda")
    if cuda and gpus < 1:
        raise InputError(param="device", expected="a GPU in the Ray cluster for a cuda device", got="none")
    n = job.actors or (gpus if cuda else max(1, cpus // 2))
    threads = None if cuda else max(1, cpus // n)
    # actors reserve half a CPU (or a GPU), so decode tasks run beside them and are not fused in
    stream = stream.map_batches(
        _ModelActor, fn_constructor_kwargs={"scorer": scorer, "threads": threads}, batch_size=1,
        **actor_pool(ray, n), num_gpus=1 if cuda else 0, num_cpus=1 if cuda else 0.5)
    return stream


def _input_error(exc: BaseException) -> InputError | None:
    """The user's InputError inside a Ray task error, as a plain one-line InputError."""
    seen = exc
    for _ in range(10):
        if isinstance(seen, InputError):
            return InputError(seen.where, seen.field, seen.expected, seen.got,
                              param=getattr(seen, "param", None))
        seen = getattr(seen, "cause", None) or seen.__cause__
        if seen is None:
            return None
    return None


def score_on_ray(job: RayJob, *, timing_path, address: str | None = None) -> dict:
    """Run (or resume) ``job`` (:func:`nvrq.engines.shards.run_sharded`); write ``timing_path``
    at the end; returns counts ``{pairs, shards, shards_done_before, pairs_scored, seconds}``.

    Parameters
    ----------
    job : RayJob
        The run: pairs input, output folder, scorer and sharding options.
    timing_path : str or path-like
        Where to write the per-column timing table.
    address : str or None
        Ray cluster address to join; None: the running session or a local one.

    Returns
    -------
    dict
        Counts of the run (:func:`nvrq.engines.shards.run_sharded`).
    """

    require_ray()
    if address:
        check_address(address)  # before anything is written

    def compute(todo: list) -> Iterator[sh.ShardResult]:
        with connect(address) as ray:
            try:
                for row in _pipeline(ray, job, todo).iter_rows():
                    table, timing = pickle.loads(row["payload"])
                    yield row["shard"], table, timing
            except Exception as exc:
                err = _input_error(exc)
                if err is None:
                    raise
                raise err from None

    options = job.scorer.options()
    if hasattr(job.scorer, "to_dict"):  # a ScorePlan: recorded whole beside what must match
        options["score_plan"] = job.scorer.to_dict()
    return sh.run_sharded(job.pairs, job.out, sh.ShardJob(options, job.shard_pairs, timing_path,
                                                          tuple(job.scorer.extra_columns), job.progress,
                                                          "score (ray)"), compute=compute)
