"""The shard-size default is one constant: ``nvrq.engines.SHARD_PAIRS`` (256), used by the
``--shard-pairs`` option, the local engine and the Ray engine's job."""

from __future__ import annotations

import argparse
import dataclasses
import inspect

from nvrq import engines
from nvrq.commands.engine_options import add_engine_args
from nvrq.engines import local, ray_engine


def test_one_shard_default_everywhere():
    assert engines.SHARD_PAIRS == 256
    parser = argparse.ArgumentParser()
    add_engine_args(parser)
    assert parser.get_default("shard_pairs") == engines.SHARD_PAIRS
    assert f"default {engines.SHARD_PAIRS}" in " ".join(parser.format_help().split())
    assert inspect.signature(local.score_dataset).parameters["shard_pairs"].default == engines.SHARD_PAIRS
    job = {f.name: f.default for f in dataclasses.fields(ray_engine.RayJob)}
    assert job["shard_pairs"] == engines.SHARD_PAIRS


def test_the_default_follows_the_constant(monkeypatch):
    """Changing the constant changes the option's default: nothing else spells the number."""
    import importlib

    from nvrq.commands import engine_options

    monkeypatch.setattr(engines, "SHARD_PAIRS", 17)
    try:
        reloaded = importlib.reload(engine_options)
        parser = argparse.ArgumentParser()
        reloaded.add_engine_args(parser)
        assert parser.get_default("shard_pairs") == 17
        assert "default 17" in " ".join(parser.format_help().split())
    finally:
        monkeypatch.undo()
        importlib.reload(engine_options)
