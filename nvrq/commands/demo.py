"""``nvrq demo OUT``: from nothing to a report, running the same commands a user would.

Layer: commands (CLI shell).

synth (built-in scene) -> pairs -> score (offline encoder + pixel metrics) -> the same clip
rendered with no artefact (``perfect:0``, its own scene: the viewpoint floor the tent plot draws)
-> annotate build -> simulated raters -> annotate export -> analyze. Each step prints its command line, what it
made and how long it took, so the demo doubles as a walkthrough of the workflow.

``nvrq demo OUT --methods NAME:SCALE,...`` compares reconstruction methods instead
(docs/guides/compare-reconstructions.md): synth renders the clip once per method, and once more
as ``perfect:0`` (no artefact: the viewpoint floor the leaderboard's tents draw and the pairwise
study leaves out) -> pairs -> score ->
``analyze --pairs --compare-methods`` (the leaderboard) -> a pairwise study (build, simulated
raters, export) -> ``analyze`` of its votes (Bradley-Terry and 2AFC agreement). Before the
leaderboard it computes the numbers the field reports: NTA-IoU (``nvrq proxy simulate-detect``,
the simulated detector, then ``nvrq proxy nta-iou``) and FD/KID (``nvrq score-sets``), which
the leaderboard's "Off-path metrics" table shows beside NVRQ-CA and PSNR.
"""

from __future__ import annotations

import shlex
import time
from importlib.metadata import distribution
from pathlib import Path

from data_schema.errors import InputError
from nvrq.cli_options import add_seed_option
from nvrq.cli_types import allow_negative_lists, int_arg, number_arg, parse_wxh
from nvrq.commands.demo_resume import DemoRecord
from nvrq.encoders import get_spec

__all__ = ["register", "run", "demo_steps", "method_steps", "with_floor", "with_lpips"]


def register(sub) -> None:
    """Add ``demo``: the options it passes on to the steps (scene seed and size, offsets,
    encoder, raters) and ``--methods``, which switches to the method comparison.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand parsers of ``nvrq``.
    """
    p = sub.add_parser("demo", help="synthetic scene -> pairs -> scores -> study -> simulated votes -> report",
                       description="Run the whole workflow offline on a built-in synthetic scene.")
    p.add_argument("out", help="output folder (created; empty or absent, or the folder of an interrupted "
                               "demo, which is resumed: finished steps are skipped)")
    add_seed_option(p, "scene seed")
    p.add_argument("--seconds", type=number_arg(low=0, low_open=True), default=6.0, help="clip length in seconds (default 6)")
    p.add_argument("--size", default="960x540", help="image size WxH (default 960x540)")
    p.add_argument("--offsets", default="-3,-2,-1,0,1,2,3", help="render offsets in metres")
    p.add_argument("--encoder", default=get_spec().name,
                   help=f"encoder for nvrq/nvrq_ca (default {get_spec().name}: offline)")
    p.add_argument("--raters", type=int_arg(), default=5, help="simulated raters (default 5)")
    p.add_argument("--methods", default=None, metavar="NAME:SCALE,...",
                   help="compare reconstruction methods: render the clip once per method (artefact "
                        "severity times SCALE) and once with no artefact (perfect:0, the viewpoint "
                        "floor, never rated), rank them (analyze --compare-methods) and run a "
                        "pairwise study, e.g. sharp:0.5,blurry:1.5")
    p.add_argument("--restart", action="store_true",
                   help="start an interrupted demo again from its first step (its folder is emptied) "
                        "instead of resuming it")
    allow_negative_lists(p)
    p.set_defaults(func=run)


#: the demo's simulated raters each rate every item (a human's share is capped by default)
_EVERY_ITEM = ("--items-per-rater", "all")


def with_floor(methods: str) -> str:
    """``methods`` (``NAME:SCALE,...``) with ``perfect:0``, the render with no artefact, appended
    unless a method is already named ``perfect``: the viewpoint floor the leaderboard draws and
    the pairwise study leaves out (:data:`data_schema.methods.REFERENCE_METHODS`).

    Parameters
    ----------
    methods : str
        The ``--methods`` value.

    Returns
    -------
    str

    >>> with_floor("sharp:0.5,blurry:1.5")
    'sharp:0.5,blurry:1.5,perfect:0'
    """
    from data_schema.methods import PERFECT_METHOD, parse_methods

    if any(name == PERFECT_METHOD for name, _ in parse_methods(methods, option="--methods")):
        return methods
    return f"{methods},{PERFECT_METHOD}:0"


def with_lpips(metrics: str, *, after: str) -> str:
    """``metrics`` with ``lpips`` inserted after ``after`` when its weights are installed
    (README "Learned metrics"), else ``metrics`` as given.

    Parameters
    ----------
    metrics : str
        A comma-separated metric list holding ``after``.
    after : str
        The metric ``lpips`` follows.

    Returns
    -------
    str

    >>> with_lpips("psnr,ssim,nvrq", after="ssim") in ("psnr,ssim,nvrq", "psnr,ssim,lpips,nvrq")
    True
    """
    from nvrq.metrics.learned.lpips import available

    if not available("lpips"):
        return metrics
    names = metrics.split(",")
    names.insert(names.index(after) + 1, "lpips")
    return ",".join(names)


def method_steps(out: Path, args) -> list[tuple[str, list[str]]]:
    """The ``--methods`` demo as (program, argv) steps, in order: one scene rendered per method
    (and ``perfect:0``, the viewpoint floor: :func:`with_floor`), its leaderboard, then a pairwise
    study of the methods (``perfect`` left out).

    Parameters
    ----------
    out : Path
        The demo's output folder: ``scene``, ``pairs.csv``, ``metrics.csv`` (and
        ``crop_features.npz``, the crops' embeddings score-sets reuses), ``leaderboard``,
        ``study``, ``votes.csv`` and ``pairwise`` go in it.
    args : argparse.Namespace
        ``nvrq demo``'s options; ``methods`` holds two or more ``NAME:SCALE``.

    Returns
    -------
    list of (str, list of str)
        One ``(program, argv)`` per step; program in ``{'nvrq', 'annotate', 'analyze'}``.
    """
    scene, pairs, metrics = out / "scene", out / "pairs.csv", out / "metrics.csv"
    study, votes = out / "study", out / "votes.csv"
    dets, nta, sets = out / "dets.csv", out / "nta.csv", out / "sets.csv"
    crops = out / "crop_features.npz"
    return [
        ("nvrq", ["synth", str(scene), "--seed", str(args.seed), "--seconds", str(args.seconds),
                  "--size", args.size, "--offsets", args.offsets, "--methods", with_floor(args.methods)]),
        ("nvrq", ["pairs", str(scene), "--out", str(pairs)]),
        # the crops' embeddings are kept for score-sets, which takes them (and the pairs) instead
        # of embedding the same crops again
        ("nvrq", ["score", str(pairs), "--out", str(metrics), "--metrics",
                  with_lpips("psnr,ssim,nvrq,nvrq_ca", after="ssim"), "--encoder", args.encoder,
                  "--save-crop-features", str(crops)]),
        # the numbers the field reports: NTA-IoU (on the simulated detector's boxes: no detector
        # ships offline) and FD/KID of frames and object crops per method and offset
        ("nvrq", ["proxy", "simulate-detect", str(scene), "--out", str(dets), "--seed", str(args.seed)]),
        ("nvrq", ["proxy", "nta-iou", str(scene), "--detections", str(dets), "--out", str(nta)]),
        ("nvrq", ["score-sets", str(scene), "--out", str(sets), "--encoder", args.encoder,
                  "--save-features", str(out / "features.npz"), "--pairs", str(pairs),
                  "--crop-features", str(crops)]),
        ("analyze", ["--pairs", str(pairs), "--metrics-table", str(metrics), "--compare-methods",
                     "--by", "class,offset", "--nta", str(nta), "--sets", str(sets), "--out", str(out / "leaderboard")]),
        ("annotate", ["build", str(study), "--pairs", str(pairs), "--metrics-table", str(metrics),
                      "--design", "pairwise", "--seed", str(args.seed), *_EVERY_ITEM]),
        ("annotate", ["simulate", str(study), "--raters", str(args.raters), "--seed", str(args.seed)]),
        ("annotate", ["export", str(study), "--out", str(votes)]),
        ("analyze", [str(votes), "--metrics-table", str(metrics), "--out", str(out / "pairwise")]),
    ]


def demo_steps(out: Path, args) -> list[tuple[str, list[str]]]:
    """The demo as (program, argv) steps, in order (:func:`method_steps` with ``--methods``).

    Parameters
    ----------
    out : Path
        Where the steps write: the scene, pairs and metrics (also scored on torch eager),
        the viewpoint floor (``floor_scene``, ``floor_pairs.csv``, ``floor_metrics.csv``), the
        binary study, ``ratings.csv`` and ``report``.
    args : argparse.Namespace
        ``nvrq demo``'s options (``seed``, ``seconds``, ``size``, ``offsets``, ``encoder``,
        ``raters``, ``methods``).

    Returns
    -------
    list of (str, list of str)
        The steps, each a program name and the arguments it is run with.
    """
    if args.methods:
        return method_steps(out, args)
    scene, pairs, metrics = out / "scene", out / "pairs.csv", out / "metrics.csv"
    study, ratings, report = out / "study", out / "ratings.csv", out / "report"
    torch_metrics = out / "metrics_torch.csv"  # the same encoder on torch eager: a second speed point
    # the viewpoint floor: the same clip rendered with no artefact, in a scene of its own (so the
    # study, the ratings and every number of the demo's renders stay as they are), scored by the
    # full-reference and encoder metrics; the report's tent plot draws it dashed
    floor_scene, floor_pairs, floor_metrics = out / "floor_scene", out / "floor_pairs.csv", out / "floor_metrics.csv"
    # full-reference (LPIPS when its weights are installed), then no-reference (paper Table 1's
    # classical rows), then the encoder metrics
    metric_list = with_lpips("psnr,ssim,ms_ssim,gmsd,brisque,niqe,piqe,entropy,nvrq,nvrq_ca", after="gmsd")
    return [
        ("nvrq", ["synth", str(scene), "--seed", str(args.seed), "--seconds", str(args.seconds),
                  "--size", args.size, "--offsets", args.offsets]),
        ("nvrq", ["pairs", str(scene), "--out", str(pairs)]),
        ("nvrq", ["score", str(pairs), "--out", str(metrics), "--metrics", metric_list,
                  "--encoder", args.encoder]),
        ("nvrq", ["score", str(pairs), "--out", str(torch_metrics), "--metrics", "nvrq",
                  "--encoder", args.encoder, "--runtime", "torch", "--column-tag", "torch"]),
        ("nvrq", ["synth", str(floor_scene), "--seed", str(args.seed), "--seconds", str(args.seconds),
                  "--size", args.size, "--offsets", args.offsets, "--methods", "perfect:0"]),
        ("nvrq", ["pairs", str(floor_scene), "--out", str(floor_pairs)]),
        ("nvrq", ["score", str(floor_pairs), "--out", str(floor_metrics), "--metrics",
                  "psnr,ssim,ms_ssim,gmsd,nvrq,nvrq_ca", "--encoder", args.encoder]),
        ("annotate", ["build", str(study), "--pairs", str(pairs), "--metrics-table", str(metrics),
                      "--seed", str(args.seed), *_EVERY_ITEM]),
        ("annotate", ["simulate", str(study), "--raters", str(args.raters), "--seed", str(args.seed)]),
        ("annotate", ["export", str(study), "--out", str(ratings)]),
        ("analyze", [str(ratings), "--timing", str(out / "metrics.timing.csv"), "--metrics-table", str(torch_metrics),
                     "--floor-pairs", str(floor_pairs), "--floor-metrics", str(floor_metrics), "--out", str(report)]),
    ]


def _entry(program: str):
    """The ``main(argv)`` of the console script ``program`` as this distribution installs it.

    The demo runs each stage through its public command, found by name in the package
    metadata (``[project.scripts]``), so ``nvrq`` never imports ``annotate`` or ``analysis``.
    """
    scripts = distribution("nvrq").entry_points.select(group="console_scripts", name=program)
    if not scripts:
        raise InputError(program, None, "an installed console script (pip install -e .)", "none")
    return next(iter(scripts)).load()


def run(args) -> int:
    """Check the options the steps pass on, then run the steps one after another, printing
    each command line and its time, and say where the report is.

    Parameters
    ----------
    args : argparse.Namespace
        ``out`` (empty or absent, or an interrupted demo's folder: resumed,
        :mod:`nvrq.commands.demo_resume`), ``restart`` and the options of :func:`demo_steps`.

    Returns
    -------
    int
        0 when every step succeeded, else the first failing step's exit status (the steps
        after it are not run).

    Raises
    ------
    KeyboardInterrupt
        After Ctrl-C, with the command that resumes the demo (printed by ``run_cli``).
    """
    from data_schema.methods import parse_methods
    from data_schema.tables import parse_offsets

    out = Path(args.out)
    # the arguments the steps pass on are checked before the first step (numbers when parsed)
    parse_wxh(args.size, option="--size")
    parse_offsets(args.offsets, field="--offsets")
    get_spec(args.encoder)
    if args.methods is not None:
        names = [name for name, _ in parse_methods(args.methods, option="--methods")]
        if len(names) < 2:
            raise InputError(param="--methods", expected="at least two NAME:SCALE methods to compare", got=args.methods)
    record = DemoRecord.open(out, args, restart=getattr(args, "restart", False))
    t_all = time.perf_counter()
    steps = demo_steps(out, args)
    first = record.resume_at(steps)
    if first > 1:
        print(f"Resuming the demo in {out}: " + (f"steps 1-{first - 1} of {len(steps)} finished before, "
              f"step {first} starts again." if first <= len(steps) else "every step finished before."))
    again = f"nvrq demo {shlex.quote(str(out))} with the same options"
    for i, (program, argv) in enumerate(steps, 1):
        if i < first:
            continue
        print(f"\n[{i}/{len(steps)}] $ {program} {shlex.join(argv)}", flush=True)
        t0 = time.perf_counter()
        record.begin(i)
        try:
            rc = _entry(program)(argv)
        except KeyboardInterrupt:
            rc = 130
        if rc == 130:  # Ctrl-C (the step's own command turns it into status 130)
            raise KeyboardInterrupt(f"step {i} of {len(steps)} did not finish; run {again} to resume "
                                    "it there, or add --restart to start again")
        if rc:
            print(f"step {i} failed with status {rc}; once its input is fixed, {again} resumes at this step")
            return rc
        record.finish(i)
        print(f"[{i}/{len(steps)}] done in {time.perf_counter() - t0:.1f} s", flush=True)
    print(f"\nDemo finished in {time.perf_counter() - t_all:.0f} s.")
    if args.methods:
        print(f"Leaderboard: {out / 'leaderboard' / 'report.html'}")
        print(f"Pairwise study: {out / 'pairwise' / 'report.html'}")
        print(f"Vote yourself:  annotate serve {out / 'study'}")
        return 0
    print(f"Report: {out / 'report' / 'report.html'}")
    print(f"Vote yourself:  annotate rate-yourself {shlex.quote(str(out))}   (about 20 items in your "
          "browser on this machine, then your agreement with the simulated raters)")
    return 0
