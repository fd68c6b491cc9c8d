"""``nvrq synth OUT [--seed N] [--seconds S] [--fps F] [--offsets ...] [--cameras ...] [--size WxH]``."""

from __future__ import annotations

import re

from data_schema.errors import InputError
from data_schema.tables import parse_offsets
from nvrq.synth import generate_scene

__all__ = ["register", "run", "parse_size", "allow_negative_lists"]


def allow_negative_lists(parser) -> None:
    """Let ``parser`` take values such as ``-3,-2,-1`` (argparse would read them as options).

    argparse treats an argument that starts with ``-`` as an option unless it matches the
    parser's negative-number pattern; this widens that pattern to comma-separated numbers.
    """
    parser._negative_number_matcher = re.compile(r"^-\d*\.?\d+(,\s*[-+]?\d*\.?\d+)*$")


def parse_size(text: str) -> tuple[int, int]:
    """``"1280x720"`` -> ``(1280, 720)``.

    >>> parse_size("640x360")
    (640, 360)
    """
    parts = str(text).lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise InputError("--size", None, "WxH in pixels, e.g. 1280x720", text)
    return int(parts[0]), int(parts[1])


def register(sub) -> None:
    p = sub.add_parser(
        "synth",
        help="write a synthetic driving clip with known degradation",
        description="Procedural driving clip (scene folder per SPEC section 2) with GT "
        "images, renders at lateral offsets and degradation.csv.",
    )
    p.add_argument("out", help="output scene folder")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--seconds", type=float, default=10.0, help="clip length (default 10)")
    p.add_argument("--fps", type=float, default=10.0, help="frame rate (default 10)")
    p.add_argument(
        "--offsets", default="-3,-2,-1,0,1,2,3", help="render offsets in metres (left > 0)"
    )
    p.add_argument(
        "--cameras", default="pinhole", help="comma list from {pinhole, ftheta} (default pinhole)"
    )
    p.add_argument("--size", default="1280x720", help="image size WxH (default 1280x720)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    allow_negative_lists(p)
    p.set_defaults(func=run)


def run(args) -> int:
    cameras = tuple(c.strip() for c in args.cameras.split(",") if c.strip())
    out = generate_scene(
        args.out,
        seed=args.seed,
        seconds=args.seconds,
        fps=args.fps,
        offsets=parse_offsets(args.offsets, field="--offsets"),
        cameras=cameras,
        size=parse_size(args.size),
        progress=not args.quiet,
    )
    print(f"wrote {out}")
    return 0
