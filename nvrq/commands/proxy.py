"""``nvrq proxy detection|imagenet|clip|detect PAIRS ... --out PROXY.{csv,parquet}`` (paper Eq. 6-10).

Layer: commands (CLI shell).

Each writes ``pair_id`` and one proxy column (``s_det``, ``imagenet_drop``, ``clip_drop``),
which ``analyze --target`` accepts. ``imagenet`` and ``clip`` also write ``PROXY.timing.csv``
beside it, as ``nvrq score`` does (docs/FORMATS.md §8), for the report's speed chart. ``detect`` writes the DETS table for ``detection`` with a
local Ultralytics YOLO model (optional extra ``[yolo]``). ``nta-iou SCENE --detections DETS``
writes NTA-IoU per projected box and its summary per method and view (:mod:`nvrq.proxies.nta_scene`).
``simulate-detect SCENE`` writes DETS for a synthetic scene with the simulated detector
(:mod:`nvrq.synth.detections`), the demo's offline stand-in for a real detector.
"""

from __future__ import annotations

import time

from data_schema.errors import InputError
from data_schema.text import plural
from nvrq.cli_options import add_pairs_argument, add_scene_root_option
from nvrq.cli_types import add_link_option, add_quiet_option, int_arg, number_arg, show_progress
from nvrq.commands.engine_options import add_engine_args, check_engine_args, run_ray
from nvrq.commands.model_options import add_model_arguments, add_runtime_arguments, prepare_device

__all__ = ["register"]

#: the GT image and box columns the confidence-drop proxies read besides the render's


def _common(p) -> None:
    add_pairs_argument(p)
    p.add_argument(
        "--out", required=True, help="output table (.csv or .parquet): pair_id + the proxy column"
    )
    p.add_argument(
        "--class-map",
        default=None,
        help="class-map JSON (default: the shipped nvrq/proxies/class_maps.json)",
    )


def _model_opts(p) -> None:
    add_scene_root_option(p)
    add_model_arguments(p)
    add_quiet_option(p)
    add_link_option(p)


def _drop_parser(psub, name: str, help_text: str):
    """A confidence-drop proxy's parser with the pairs, output, class-map and model options."""
    p = psub.add_parser(name, help=help_text)
    _common(p)
    _model_opts(p)
    return p


def register(sub) -> None:
    """Add ``proxy`` and its proxies, each a subcommand of its own: ``detection``, ``nta-iou``,
    ``detect``, ``imagenet`` and ``clip``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        ``nvrq``'s subcommands; ``proxy`` adds its own subparsers below it.
    """
    p = sub.add_parser(
        "proxy",
        help="downstream proxies: detection, ImageNet, CLIP (Eq. 6-10) and NTA-IoU, "
             "with detections from YOLO or the simulated detector",
        description="Downstream proxies of render quality: detection confidence, ImageNet and "
                    "CLIP confidence drops (paper Eq. 6-10) and NTA-IoU (docs/FORMATS.md §3b).",
    )
    psub = p.add_subparsers(dest="proxy", metavar="PROXY", required=True)

    d = psub.add_parser("detection", help="s_det: detection confidence on the render box (Eq. 6-8)")
    _common(d)
    d.add_argument(
        "--detections",
        required=True,
        help="DETS table: path (as in images.csv), x0, y0, x1, y1 (continuous pixel-edge "
        "coordinates), score, coco_class",
    )
    d.set_defaults(func=run_detection)

    _nta_parser(psub)
    _simulate_parser(psub)

    y = psub.add_parser(
        "detect", help="write DETS with a local Ultralytics YOLO model (extra [yolo])"
    )
    add_pairs_argument(y)
    y.add_argument("--yolo", required=True, help="local Ultralytics weights file, e.g. yolov8x.pt")
    y.add_argument(
        "--out", required=True, help="DETS table (.csv or .parquet) for `nvrq proxy detection`"
    )
    y.add_argument("--imgsz", type=int_arg(), default=640, help="inference size (default 640)")
    _model_opts(y)
    y.set_defaults(func=run_detect)

    i = _drop_parser(psub, "imagenet", "imagenet_drop: ImageNet top-class confidence drop (Eq. 9)")
    i.add_argument(
        "--classifier",
        default="efficientnet-lite0",
        help="efficientnet-lite0 (default, offline) or a local transformers "
        "image-classifier folder",
    )
    i.add_argument(
        "--weights", default=None, help="a .pth for efficientnet-lite0, or the classifier folder"
    )
    add_runtime_arguments(i, precision=False)
    add_engine_args(i)
    i.set_defaults(func=run_imagenet)

    c = _drop_parser(psub, "clip", "clip_drop: CLIP zero-shot true-category confidence drop (Eq. 10)")
    c.add_argument(
        "--clip", required=True, help="local Hugging Face CLIP folder (CLIPModel + tokenizer)"
    )
    add_runtime_arguments(c, precision=False)
    add_engine_args(c)
    c.set_defaults(func=run_clip)


def _nta_parser(psub) -> None:
    from nvrq.choices import NTA_PROTOCOLS

    n = psub.add_parser("nta-iou", help="NTA-IoU: detections of the renders against the boxes the scene "
                        "projects into them (protocols nvrq, recondreamer, drivedreamer4d)")
    n.add_argument("scene", help="scene folder (scene.json + images.csv, with renders)")
    n.add_argument("--detections", required=True,
                   help="DETS table of the renders (as `nvrq proxy detect` writes): path (as in images.csv), "
                   "x0, y0, x1, y1 (pixel edges), score, coco_class")
    n.add_argument("--out", required=True, help="per-box table (.csv or .parquet); the summary per method "
                   "and view goes beside it as OUT.summary.csv")
    n.add_argument("--protocol", default="nvrq", choices=NTA_PROTOCOLS,
                   help="nvrq (default: one-to-one, class map, own resolution, boxes clipped), recondreamer "
                   "or drivedreamer4d (the peers' scripts; docs/FORMATS.md)")
    n.add_argument("--class-map", default=None,
                   help="class-map JSON (default: the shipped nvrq/proxies/class_maps.json)")
    n.add_argument("--min-side", type=number_arg(low=0), default=1.0,
                   help="nvrq protocol: the shorter side (pixels) a clipped box needs (default 1)")
    n.add_argument("--bootstrap", type=int_arg(low=0), default=1000,
                   help="bootstrap replicates over tracks of the summary's interval (default 1000; 0: none)")
    n.add_argument("--seed", type=int_arg(low=0), default=0, help="bootstrap seed (default 0)")
    n.add_argument("--min-clusters", type=int_arg(low=2), default=5,
                   help="the fewest tracks of an interval (default 5, as analyze --compare-methods)")
    add_link_option(n)
    n.set_defaults(func=run_nta)


def _simulate_parser(psub) -> None:
    s = psub.add_parser("simulate-detect", help="write DETS for a synthetic scene with the simulated "
                        "detector (offline; the demo's stand-in for a real one)")
    s.add_argument("scene", help="scene folder written by `nvrq synth` (with its degradation.csv)")
    s.add_argument("--out", required=True, help="DETS table (.csv or .parquet) for `nvrq proxy nta-iou`")
    s.add_argument("--seed", type=int_arg(low=0), default=0, help="random seed (default 0)")
    s.add_argument("--class-map", default=None,
                   help="class-map JSON (default: the shipped nvrq/proxies/class_maps.json)")
    add_link_option(s)
    s.set_defaults(func=run_simulate_detect)


def run_nta(args) -> int:
    from data_schema.methods import METHOD_COLUMN
    from data_schema.outputs import check_output_file
    from data_schema.scene import load_scene
    from data_schema.tables import write_table
    from nvrq.proxies import load_class_maps
    from nvrq.proxies.detection import read_detections
    from nvrq.proxies.nta_iou import get_protocol
    from nvrq.proxies.nta_scene import nta_summary, nta_table

    _check_out(args.out)
    summary_path = nta_summary_path(args.out)
    check_output_file(summary_path, inputs=[args.scene, args.detections], option="--out (its .summary.csv)")
    protocol = get_protocol(args.protocol)
    maps = load_class_maps(args.class_map)
    scene = load_scene(args.scene, check_images=False)
    dets = read_detections(args.detections)
    table = nta_table(scene, dets, protocol, class_map=maps["coco"], min_side=args.min_side,
                      where=str(args.detections))
    summary = nta_summary(table, n_boot=args.bootstrap, seed=args.seed, min_clusters=args.min_clusters)
    write_table(table, args.out)
    write_table(summary, summary_path)
    if len(table) and table["d_score"].isna().all():
        print(f"note: no detection of {args.detections} matched a projected box (none given, none past the "
              "score filter, or none overlapping): every box is a miss (IoU 0)")
    pooled = "every method and view" if METHOD_COLUMN in table.columns and table[METHOD_COLUMN].nunique() > 1 \
        else "every view"
    print(f"NTA-IoU ({protocol.name}) {table['iou'].mean():.4f}: the mean IoU of {plural(len(table), 'box', 'boxes')}, "
          f"{pooled} pooled (the recorded view included); per box: {args.out}; per method and view: "
          f"{summary_path}")
    return 0


def run_simulate_detect(args) -> int:
    """Run ``nvrq proxy simulate-detect`` (:func:`nvrq.synth.detections.simulate_detections`).

    Parameters
    ----------
    args : argparse.Namespace
        ``scene``, ``out``, ``seed``, ``class_map``.

    Returns
    -------
    int
        0 (bad input raises :class:`~data_schema.errors.InputError`, exit 2).
    """
    from data_schema.outputs import check_output_file
    from data_schema.scene import load_scene
    from data_schema.tables import write_table
    from nvrq.proxies import load_class_maps
    from nvrq.synth.detections import simulate_detections

    _check_out(args.out)
    check_output_file(args.out, inputs=[args.scene], option="--out")
    maps = load_class_maps(args.class_map)
    scene = load_scene(args.scene, check_images=False)
    dets = simulate_detections(scene, seed=args.seed, class_map=maps["coco"])
    write_table(dets, args.out)
    print(f"{len(dets)} simulated detections on {dets['path'].nunique()} renders -> {args.out}")
    return 0


def nta_summary_path(out):
    """``x/NTA.csv`` -> ``x/NTA.summary.csv`` (the per-method-and-view table of ``nvrq proxy nta-iou``)."""
    from pathlib import Path

    path = Path(out)
    return path.with_name(path.stem + ".summary.csv")


def _check_out(out) -> None:
    if not str(out).lower().endswith((".csv", ".parquet")):
        raise InputError(out, None, "an output file ending in .csv or .parquet", out)


def _read_pairs(path, extra=()):
    from data_schema.tables import RENDER_BOX_COLUMNS, TableKind, read_table

    need = ("pair_id", "label_class", "render_path", *RENDER_BOX_COLUMNS, *extra)
    return read_table(path, required=need, kind=TableKind.PAIRS)


def run_detection(args) -> int:
    from data_schema.tables import write_table
    from nvrq.proxies import load_class_maps
    from nvrq.proxies.detection import detection_confidence, read_detections

    _check_out(args.out)
    maps = load_class_maps(args.class_map)
    pairs = _read_pairs(args.pairs)
    dets = read_detections(args.detections)
    out = detection_confidence(pairs, dets, coco_map=maps["coco"], where=str(args.pairs))
    write_table(out, args.out)
    return 0


def run_detect(args) -> int:
    from data_schema.tables import write_table
    from nvrq.proxies.yolo import run_yolo

    _check_out(args.out)
    pairs = _read_pairs(args.pairs)
    prepare_device(args)
    dets = run_yolo(
        pairs,
        args.yolo,
        scene_root=args.scene,
        device=args.device,
        imgsz=args.imgsz,
        progress=show_progress(args),
        where=str(args.pairs),
    )
    write_table(dets, args.out)
    return 0


def _run_drop(args, kind: str, score) -> int:
    """One confidence-drop proxy: Ray engine, or ``score(pairs, maps, timings) -> (table, model)``
    here, written to ``--out`` with its timing file beside it, as ``nvrq score`` writes one
    (``PROXY.timing.csv``, docs/FORMATS.md §8), so the report's speed chart places the proxy."""
    from data_schema.tables import GT_BOX_COLUMNS, timing_path, write_table
    from nvrq.proxies import load_class_maps
    from nvrq.scoring.driver import runtime_timing, timing_table

    if args.engine == "ray":
        return _ray_proxy(args, kind)
    _check_out(args.out)
    maps = load_class_maps(args.class_map) if kind == "clip" else None
    pairs = _read_pairs(args.pairs, ("gt_path", *GT_BOX_COLUMNS))
    times: dict = {}
    t0 = time.perf_counter()
    out, model = score(pairs, maps, times)
    column = [c for c in out.columns if c != "pair_id"]
    timing = timing_table(column, times, n_pairs=len(pairs), wall=time.perf_counter() - t0,
                          model_columns=column)
    write_table(out, args.out)
    tpath = write_table(runtime_timing(timing, model, column), timing_path(args.out))
    print(f"-> {args.out}, {tpath}")
    return 0


def run_imagenet(args) -> int:
    from nvrq.proxies.classifier_drop import imagenet_drop, load_classifier

    def score(pairs, _maps, timings):
        prepare_device(args)
        clf = load_classifier(args.classifier, weights=args.weights, device=args.device,
                              **_runtime_kwargs(args))
        return imagenet_drop(pairs, clf, scene_root=args.scene, batch_size=args.batch_size,
                             progress=show_progress(args), where=str(args.pairs), timings=timings), clf

    return _run_drop(args, "imagenet", score)


def run_clip(args) -> int:
    from nvrq.proxies.clip_drop import clip_drop, load_clip, true_category_index

    def score(pairs, maps, timings):
        # unknown classes fail before the model loads
        true_category_index(pairs["label_class"], maps["clip_category"],
                            list(maps["clip_prompts"]), where=str(args.pairs))
        prepare_device(args)
        clip = load_clip(args.clip, prompts=maps["clip_prompts"], device=args.device,
                         **_runtime_kwargs(args))
        return clip_drop(pairs, clip, category_map=maps["clip_category"], scene_root=args.scene,
                         batch_size=args.batch_size, progress=show_progress(args),
                         where=str(args.pairs), timings=timings), clip

    return _run_drop(args, "clip", score)


def _runtime_kwargs(args) -> dict:
    return {"runtime": args.runtime, "threads": args.threads, "cache_dir": args.cache_dir}


def _ray_proxy(args, kind: str) -> int:
    """``--engine ray``: the same proxy per crop batch on a Ray cluster (nvrq.engines.scorers)."""
    from nvrq.engines.scorers import ClipScorer, ImagenetScorer
    from nvrq.proxies import load_class_maps

    check_engine_args(args)
    if kind == "imagenet":
        scorer = ImagenetScorer(args.classifier, weights=args.weights, device=args.device,
                                batch_size=args.batch_size, runtime=args.runtime, cache_dir=args.cache_dir)
    else:
        maps = load_class_maps(args.class_map)
        scorer = ClipScorer(args.clip, prompts=tuple(maps["clip_prompts"].items()),
                            category_map=tuple(maps["clip_category"].items()), device=args.device,
                            batch_size=args.batch_size, runtime=args.runtime, cache_dir=args.cache_dir)
    return run_ray(args, scorer)
