"""The clip the end-to-end workflow tests share: a synthetic clip rendered by two methods and
scored through the commands a user runs (``nvrq synth``, ``nvrq pairs``, ``nvrq score``)."""

from __future__ import annotations

from pathlib import Path

from nvrq.cli import main as nvrq_main

__all__ = ["METHODS", "ok", "scored_clip"]

#: the clip's two methods: artefact scales 0.5 (``sharp``) and 1.5 (``blurry``)
METHODS = "sharp:0.5,blurry:1.5"


def ok(rc: int) -> None:
    """A command's exit status must be 0."""
    assert rc == 0


def scored_clip(d: Path, *, offsets: str, metrics: str, methods: str = METHODS, seconds: int = 1,
                size: str = "640x360", min_visible: str | None = "0", seed: int = 0) -> None:
    """``d/scene``: ``seconds`` (default 1 s) at 5 fps, ``size`` (default 640x360), ``methods``
    (default :data:`METHODS`) at the lateral ``offsets`` (metres, comma-separated), ``seed``;
    ``d/pairs.csv`` of it (``--min-visible``: default 0, the paper's protocol, so that these
    small clips keep enough objects to rank; None: the command's default rule) and
    ``d/metrics.csv`` of ``metrics`` (efficientnet-lite0 on torch)."""
    ok(nvrq_main(["synth", str(d / "scene"), "--seconds", str(seconds), "--fps", "5", "--size", size,
                  f"--offsets={offsets}", "--methods", methods, "--seed", str(seed), "--quiet"]))
    rule = [] if min_visible is None else ["--min-visible", min_visible]
    ok(nvrq_main(["pairs", str(d / "scene"), "--out", str(d / "pairs.csv"), *rule]))
    ok(nvrq_main(["score", str(d / "pairs.csv"), "--out", str(d / "metrics.csv"), "--metrics", metrics,
                  "--encoder", "efficientnet-lite0", "--runtime", "torch", "--quiet"]))
