"""Every argument is checked before anything is read, loaded or exported (issue 23 item 2).

Each case gives a command a bad argument and inputs that do not exist: had the command read its
inputs or loaded a model first, it would fail on the missing file (or on the patched loaders
below) instead of naming the option. Each must end with exit status 2, one stderr line naming
the option, quickly, with nothing created (no output, no export cache).
"""

from __future__ import annotations

import time

import pytest

from analysis.cli import main as analyze_main
from annotate.cli import main as annotate_main
from nvrq.cli import main as nvrq_main

MAINS = {"nvrq": nvrq_main, "annotate": annotate_main, "analyze": analyze_main}

SCORE = ["score", "{tmp}/in/pairs.csv", "--out", "{tmp}/m.csv", "--metrics", "psnr,nvrq",
         "--cache-dir", "{tmp}/cache"]
CASES = [
    ("nvrq", [*SCORE, "--batch-size", "0"], "--batch-size"),
    ("nvrq", [*SCORE, "--threads", "0"], "--threads"),
    ("nvrq", [*SCORE, "--tau", "1.5"], "--tau"),
    ("nvrq", [*SCORE, "--min-spearman", "2"], "--min-spearman"),
    ("nvrq", [*SCORE, "--batch-size", "many"], "--batch-size"),
    ("nvrq", ["score", "{tmp}/in/pairs", "--out", "{tmp}/m", "--engine", "ray", "--shard-pairs", "0"],
     "--shard-pairs"),
    ("nvrq", ["score", "{tmp}/in/pairs", "--out", "{tmp}/m", "--engine", "ray", "--actors", "0"], "--actors"),
    ("nvrq", ["score", "{tmp}/in/pairs.csv", "--out", "{tmp}/m.txt", "--metrics", "nvrq"], "m.txt"),
    ("nvrq", ["proxy", "imagenet", "{tmp}/in/pairs.csv", "--out", "{tmp}/p.csv", "--batch-size", "0"],
     "--batch-size"),
    ("nvrq", ["proxy", "clip", "{tmp}/in/pairs.csv", "--clip", "{tmp}/in/clip", "--out", "{tmp}/p.csv",
              "--threads", "-2"], "--threads"),
    ("nvrq", ["proxy", "detect", "{tmp}/in/pairs.csv", "--yolo", "{tmp}/in/y.pt", "--out", "{tmp}/d.csv",
              "--imgsz", "0"], "--imgsz"),
    ("nvrq", ["stability", "{tmp}/in/pairs.csv", "--out", "{tmp}/st", "--n-objects", "1"], "--n-objects"),
    ("nvrq", ["stability", "{tmp}/in/pairs.csv", "--out", "{tmp}/st", "--seed", "-1"], "--seed"),
    ("nvrq", ["stability", "{tmp}/in/pairs.csv", "--out", "{tmp}/st", "--batch-size", "0"], "--batch-size"),
    ("nvrq", ["calibrate-tau", "{tmp}/in/pairs.csv", "--max-crops", "0"], "--max-crops"),
    ("nvrq", ["calibrate-tau", "{tmp}/in/pairs.csv", "--batch-size", "0"], "--batch-size"),
    ("nvrq", ["calibrate-runtime", "{tmp}/in/pairs.csv", "--sample", "0", "--cache-dir", "{tmp}/cache"],
     "--sample"),
    ("nvrq", ["calibrate-runtime", "{tmp}/in/pairs.csv", "--min-spearman", "5"], "--min-spearman"),
    ("nvrq", ["pairs", "{tmp}/in/scene", "--out", "{tmp}/p.csv", "--min-area", "-1"], "--min-area"),
    ("nvrq", ["synth", "{tmp}/s", "--fps", "0"], "--fps"),
    ("nvrq", ["synth", "{tmp}/s", "--seconds", "nan"], "--seconds"),
    ("nvrq", ["synth", "{tmp}/s", "--seed", "-3"], "--seed"),
    ("nvrq", ["render-plan", "{tmp}/in/scene", "--offsets", "a,b", "--out", "{tmp}/plan.csv"], "--offsets"),
    ("nvrq", ["import", "nurec", "{tmp}/in/a.usdz", "{tmp}/s", "--offsets", "x"], "--offsets"),
    ("nvrq", ["import", "drivestudio", "{tmp}/in/ds", "{tmp}/s", "--offsets", "x"], "--offsets"),
    ("nvrq", ["import", "drivestudio", "{tmp}/in/ds", "{tmp}/s", "--fps", "0"], "--fps"),
    ("nvrq", ["import", "drivestudio", "{tmp}/in/ds", "{tmp}/s", "--dataset", "lyft"], "--dataset"),
    ("nvrq", ["render-plan", "{tmp}/in/scene", "--format", "npz", "--out", "{tmp}/plan.csv"], "--format"),
    ("nvrq", ["render-plan", "{tmp}/in/scene", "--method", "a:b", "--out", "{tmp}/plan.npz"], "--method"),
    ("nvrq", ["import", "renders", "{tmp}/in/scene", "{tmp}/in/renders", "--method", "gt"], "--method"),
    ("nvrq", ["import", "renders", "{tmp}/in/scene", "{tmp}/in/renders", "--existing-method", "1"],
     "--existing-method"),
    *[("nvrq", ["demo", "{tmp}/demo", flag, bad], flag)
      for flag, bad in (("--raters", "0"), ("--seconds", "0"), ("--size", "0x0"), ("--offsets", "left"),
                        ("--encoder", "nope"))],
    ("annotate", ["build", "{tmp}/study", "--pairs", "{tmp}/in/pairs.csv", "--tracks", "0"], "--tracks"),
    ("annotate", ["build", "{tmp}/study", "--pairs", "{tmp}/in/pairs.csv", "--training", "-1"], "--training"),
    ("annotate", ["build", "{tmp}/study", "--pairs", "{tmp}/in/pairs.csv", "--break-every", "0"],
     "--break-every"),
    ("annotate", ["simulate", "{tmp}/in/study", "--raters", "0"], "--raters"),
    ("annotate", ["serve", "{tmp}/in/study", "--port", "70000"], "--port"),
    ("analyze", ["{tmp}/in/ratings.csv", "--out", "{tmp}/rep", "--bootstrap", "-1"], "--bootstrap"),
    ("analyze", ["{tmp}/in/ratings.csv", "--out", "{tmp}/rep", "--seed", "-1"], "--seed"),
    ("analyze", ["{tmp}/in/ratings.csv", "--out", "{tmp}/rep", "--margin", "nan"], "--margin"),
    # an option of the method comparison without --compare-methods names itself (not --target)
    ("analyze", ["--pairs", "{tmp}/in/pairs.csv", "--nta", "{tmp}/in/nta.csv", "--out", "{tmp}/rep"],
     "error: --nta: expected --compare-methods as well"),
    ("analyze", ["{tmp}/in/ratings.csv", "--sets", "{tmp}/in/sets.csv", "--out", "{tmp}/rep"],
     "error: --sets: expected --compare-methods as well"),
]


def _loaded(*args, **kwargs):
    raise AssertionError("a model was loaded or exported before the arguments were checked")


@pytest.fixture
def no_models(monkeypatch):
    """Every way a command loads, exports or builds something expensive fails the test."""
    # the commands import what they run in run() (so --help stays light): patched at the source
    import nvrq.commands.demo as demo
    import nvrq.encoders as enc
    import nvrq.encoders.runtimes as rt
    import nvrq.proxies.classifier_drop as classifier
    import nvrq.proxies.clip_drop as clip
    import nvrq.proxies.yolo as yolo
    import nvrq.synth as synth

    for mod, name in [(enc, "load_encoder"), (rt, "wrap_runtime"), (rt, "exported"), (enc, "build_random"),
                      (classifier, "load_classifier"), (clip, "load_clip"), (yolo, "run_yolo"),
                      (synth, "generate_scene"), (demo, "_entry")]:
        monkeypatch.setattr(mod, name, _loaded)


@pytest.mark.parametrize("prog, argv, option", CASES, ids=[f"{p} {' '.join(a[:1] + a[-2:])}" for p, a, _ in CASES])
def test_bad_argument_ends_before_any_work(prog, argv, option, tmp_path, capsys, no_models):
    t0 = time.perf_counter()
    rc = MAINS[prog]([a.format(tmp=tmp_path) for a in argv])
    seconds = time.perf_counter() - t0
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and err.startswith("error: ") and option in err, err
    assert "Traceback" not in err and "export" not in err
    assert seconds < 2.0, seconds  # no model, no file: parsing only
    assert list(tmp_path.iterdir()) == []  # no output, no export cache, no study, no report


RUNTIME_CASES = [
    ("nvrq", [*SCORE, "--runtime", "openvino", "--device", "cuda"], "--runtime"),
    ("nvrq", [*SCORE, "--runtime", "onnxruntime", "--precision", "bf16"], "--precision"),
    ("nvrq", ["proxy", "imagenet", "{tmp}/in/pairs.csv", "--out", "{tmp}/p.csv", "--runtime", "onnxruntime",
              "--device", "cuda:0"], "--runtime"),
    ("nvrq", ["calibrate-runtime", "{tmp}/in/pairs.csv", "--runtime", "onnxruntime", "--precision", "bf16"],
     "--precision"),
]


@pytest.mark.parametrize("prog, argv, option", RUNTIME_CASES, ids=[" ".join(a[-4:]) for _, a, _ in RUNTIME_CASES])
def test_runtime_combination_is_refused_before_any_work(prog, argv, option, tmp_path, capsys, no_models):
    """An exported runtime on a GPU, or a precision the runtime lacks: refused before the pairs are
    read or the torch weights load (the library checks it first too: nvrq.encoders.load_encoder)."""
    test_bad_argument_ends_before_any_work(prog, argv, option, tmp_path, capsys, no_models)


def test_load_encoder_checks_the_runtime_before_the_weights(monkeypatch):
    import nvrq.encoders.registry as reg
    from data_schema.errors import InputError

    monkeypatch.setattr(reg, "_backend", _loaded)
    with pytest.raises(InputError, match="runtime"):
        reg.load_encoder("efficientnet-lite0", runtime="openvino", device="cuda")
