"""The model options and the encoder-and-tau CLI loader (nvrq/commands/model_options.py): tau comes from --tau >
config > registry and is checked before the model loads, the encoder named in --metrics is the
one loaded, and the commands report the core's parameter errors as the options typed."""

from __future__ import annotations

import argparse
import json

import pytest

from data_schema.errors import InputError
from nvrq.cli import main
from nvrq.commands.model_options import add_encoder_arguments, load_encoder_and_tau
from nvrq.encoders.registry import encoder_for_metrics


def _args(*argv):
    p = argparse.ArgumentParser()
    add_encoder_arguments(p)
    return p.parse_args(list(argv))


def test_encoder_comes_from_metrics_or_option():
    assert encoder_for_metrics(["psnr", "nvrq:dinov2-small"], None) == "dinov2-small"
    assert encoder_for_metrics(["psnr"], "clip-b16") == "clip-b16"
    assert encoder_for_metrics(["psnr"], None) == "efficientnet-lite0"
    with pytest.raises(InputError, match="one encoder"):
        encoder_for_metrics(["nvrq:dinov2-small", "nvrq_ca:clip-b16"], None)
    with pytest.raises(InputError, match=r"^metrics: .*given as encoder \(clip-b16\)"):
        encoder_for_metrics(["nvrq:dinov2-small"], "clip-b16")


def test_tau_from_option_then_config_and_checked_before_loading(tmp_path, monkeypatch):
    loaded = []
    monkeypatch.setattr("nvrq.encoders.load_encoder", lambda cfg: loaded.append(cfg.name) or cfg.name)
    cfg = tmp_path / "tau.json"
    cfg.write_text(json.dumps({"dinov2-small": {"tau": 0.42}}))
    assert load_encoder_and_tau(_args("--config", str(cfg), "--encoder", "dinov2-small"),
                                needs_tau=True) == ("dinov2-small", 0.42)
    assert load_encoder_and_tau(_args("--config", str(cfg), "--tau", "0.3"),
                                needs_tau=True, name="dinov2-small")[1] == 0.3
    with pytest.raises(SystemExit):  # refused when the command line is parsed (issue 23 item 2)
        _args("--tau", "1.5")
    args = _args()
    args.tau = 1.5  # a caller's bad value: still refused before loading
    with pytest.raises(InputError, match=r"^tau: expected a number strictly between 0 and 1"):
        load_encoder_and_tau(args, needs_tau=True)
    assert loaded == ["dinov2-small", "dinov2-small"]  # the bad tau stopped before loading


def test_cli_reports_core_parameter_errors_as_options(tiny_scene, tmp_path, capsys):
    root, pairs = tiny_scene
    pairs.to_csv(tmp_path / "p.csv", index=False)
    rc = main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"), "--metrics",
               "psnr,nvrq_ca", "--tau", "1.5", "--quiet"])
    assert rc == 2 and "--tau: expected a number strictly between 0 and 1" in capsys.readouterr().err
    rc = main(["score", str(tmp_path / "p.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr",
               "--batch-size", "0", "--quiet"])
    assert rc == 2 and "--batch-size: expected a positive integer, got 0" in capsys.readouterr().err
    assert not (tmp_path / "m.csv").exists()
    rc = main(["stability", str(tmp_path / "p.csv"), "--out", str(tmp_path / "st"), "--metrics", "psnr",
               "--n-objects", "1", "--quiet"])
    assert rc == 2 and "--n-objects: expected an integer >= 2, got 1" in capsys.readouterr().err
