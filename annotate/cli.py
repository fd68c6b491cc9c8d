"""The ``annotate`` command: build, serve, add-rater, export, gvf, simulate (thin shell).

``annotate serve`` *becomes* ``streamlit run annotate/app.py`` (the process is replaced, so
a signal to ``annotate serve`` reaches the server itself and nothing outlives it), bound to
127.0.0.1 unless ``--host`` says otherwise, headless, without usage statistics, file
watcher, static file serving or error details in the browser, and without Streamlit's full
garbage collection after every script run (about 40 ms of CPU per vote, holding the GIL: it
alone saturated a core at 25 raters); the study folder reaches the app in the environment
variable ``ANNOTATE_STUDY``. A port in use is refused up front.
"""

from __future__ import annotations

import argparse
import os
import secrets
import socket
import sqlite3
import sys
from pathlib import Path

from annotate.results import gvf_table, ratings_table, votes_table
from annotate.simulate import simulate
from annotate.study import build_study, load_study, unplaced_votes
from data_schema.cliargs import (
    DeprecatedFileOption,
    DeprecatedSize,
    add_link_option,
    allow_negative_lists,
    flags_in_errors,
    int_arg,
    parse_wxh,
)
from data_schema.errors import ArgumentParser, InputError, run_cli
from data_schema.outputs import check_output_file, check_output_folder
from data_schema.raters import check_rater_name
from data_schema.tables import no_follow_links, write_table

__all__ = ["main", "build_parser", "serve_command", "check_port_free"]

def serve_command(study: str | Path, *, host: str = "127.0.0.1", port: int = 8501) -> list[str]:
    """The ``streamlit run`` argv that serves ``study`` (set ANNOTATE_STUDY in its env)."""
    app = Path(__file__).with_name("app.py")
    return [sys.executable, "-m", "streamlit", "run", str(app),
            "--server.address", str(host), "--server.port", str(int(port)),
            "--server.headless", "true", "--browser.gatherUsageStats", "false",
            "--server.fileWatcherType", "none", "--server.runOnSave", "false",
            "--server.enableStaticServing", "false", "--client.toolbarMode", "minimal",
            "--client.showErrorDetails", "none", "--global.developmentMode", "false",
            "--runner.postScriptGC", "false"]


def check_port_free(host: str, port: int) -> None:
    """InputError when nothing may listen on ``host:port`` (in use, or not an address here)."""
    with socket.socket(socket.AF_INET6 if ":" in str(host) else socket.AF_INET) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server binds
        try:
            sock.bind((str(host), int(port)))
        except OSError as err:
            raise InputError("--port", None, f"a free port on {host}",
                             f"{port} ({err.strerror or err})") from None


def _base_url(host: str, port: int) -> str:
    return f"http://{host}:{port}/"


def _cmd_build(args) -> int:
    check_output_folder(args.study, kind="study", option="STUDY",
                        inputs=[args.pairs, *args.metrics_tables, args.scene])
    width, height = parse_wxh(args.size, option="--size")
    if width != height:
        raise InputError("--size", None, "a square WxH (display crops are square), e.g. 320x320", args.size)
    out = build_study(args.study, args.pairs, scene=args.scene, metrics_path=args.metrics_tables or None,
                      tracks=args.tracks, frames_per_track=args.frames_per_track,
                      offsets=args.offsets, votes_per_item=args.votes_per_item, seed=args.seed,
                      n_training=args.training, n_gold=args.gold, n_repeats=args.repeats,
                      size=width, image_format=args.image_format, access=args.access,
                      break_every=args.break_every, design=args.design, methods=args.methods)
    study = load_study(out)
    counts = ", ".join(f"{v} {k}" for k, v in study.manifest["counts"].items())
    print(f"study {out}: {counts} items")
    print(f"admin page: {_base_url('127.0.0.1', 8501)}?admin={study.admin_token()}")
    return 0


def _cmd_serve(args) -> int:
    study = load_study(args.study)  # fail here, not in the browser
    check_port_free(args.host, args.port)
    print(f"serving {study.root} at {_base_url(args.host, args.port)} "
          f"(admin: ?admin={study.admin_token()})", file=sys.stderr, flush=True)
    env = dict(os.environ, ANNOTATE_STUDY=str(study.root))
    argv = serve_command(study.root, host=args.host, port=args.port)
    sys.stdout.flush()
    os.execve(argv[0], argv, env)  # replaced: signals and exit status are the server's own
    return 1  # not reached


def _cmd_add_rater(args) -> int:
    study = load_study(args.study)
    name = check_rater_name(args.name)
    base = _base_url(args.host, args.port)
    if study.manifest["access"] == "token":
        token = secrets.token_urlsafe(18)
        study.store.add_rater(name, plan=study.new_plan(name), token=token)
        print(f"{base}?token={token}")
    else:
        study.plan_for(name)
        print(f"{base}?rater={name}")
    return 0


def _cmd_export(args) -> int:
    check_output_file(args.out, inputs=[args.study])
    study = load_study(args.study)
    table = votes_table(study)
    lost = unplaced_votes(study)
    write_table(table, args.out)
    print(f"{len(table)} votes -> {args.out}", file=sys.stderr)
    if lost:
        print(f"warning: {sum(lost.values())} votes not exported: "
              + "; ".join(f"{n} {why}" for why, n in lost.items()), file=sys.stderr)
    return 0


def _cmd_gvf(args) -> int:
    if args.out:
        check_output_file(args.out, inputs=[args.study])
    study = load_study(args.study)
    if study.design != "binary":
        raise InputError(Path(args.study) / "manifest.json", "design", "a good/bad (binary) study "
                         "for a good-vote fraction; export a pairwise study's votes with "
                         "'annotate export'", study.design)
    table = gvf_table(ratings_table(study))
    if args.out:
        write_table(table, args.out)
    else:
        print(table.to_string(index=False))
    return 0


def _cmd_simulate(args) -> int:
    params = simulate(load_study(args.study), raters=args.raters, seed=args.seed)
    print(params.to_string(index=False))
    return 0


def _add_address(p) -> None:
    """The rater app's address options (``serve`` and the sign-in links of ``add-rater``)."""
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int_arg(high=65535), default=8501)


def build_parser() -> ArgumentParser:
    p = ArgumentParser(prog="annotate", description="Rating studies of render quality.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    b = sub.add_parser("build", help="build a study folder from a pairs table")
    b.add_argument("study", metavar="STUDY", help="new study folder (absent or empty)")
    b.add_argument("--pairs", required=True, help="pairs table (docs/FORMATS.md §3)")
    b.add_argument("--scene", help="scene folder the pairs' image paths are relative to "
                   "(default: the pairs table's scene_root column)")
    b.add_argument("--metrics-table", dest="metrics_tables", action="append", default=[], metavar="FILE",
                   help="metrics table (pair_id + metric columns) for the export; repeatable")
    b.add_argument("--metrics", dest="metrics_tables", action=DeprecatedFileOption, new="--metrics-table",
                   help=argparse.SUPPRESS)
    b.add_argument("--tracks", type=int_arg(), default=12)
    b.add_argument("--frames-per-track", type=int_arg(), default=12)
    b.add_argument("--offsets", default="all", help="'all' or a comma list of metres, e.g. -1,0,1")
    b.add_argument("--votes-per-item", type=int_arg(), default=5)
    b.add_argument("--seed", type=int_arg(low=0), default=0)
    b.add_argument("--training", type=int_arg(low=0), default=5, help="training items (shown first)")
    b.add_argument("--gold", type=int_arg(low=0), default=3, help="hidden gold items of each kind")
    b.add_argument("--repeats", type=int_arg(low=0), default=5, help="repeated test items")
    b.add_argument("--size", default="320x320", action=DeprecatedSize, metavar="WxH",
                   help="display size of each crop, a square WxH in pixels (default 320x320)")
    b.add_argument("--image-format", default="jpg", choices=["jpg", "png"])
    b.add_argument("--access", default="open", choices=["open", "token"])
    b.add_argument("--break-every", type=int_arg(), default=50)
    b.add_argument("--design", default="binary", choices=["binary", "pairwise"],
                   help="binary: good/bad votes on (GT, render); pairwise: which of two methods' "
                   "renders is closer to the GT (the pairs need a method column)")
    b.add_argument("--methods", help="pairwise: comma list of the methods to compare "
                   "(default: every method of the pairs table)")
    add_link_option(b)
    allow_negative_lists(b)
    b.set_defaults(func=_cmd_build)
    s = sub.add_parser("serve", help="serve the rater app (Streamlit)")
    s.add_argument("study")
    _add_address(s)
    s.set_defaults(func=_cmd_serve)
    a = sub.add_parser("add-rater", help="register a rater and print the sign-in link")
    a.add_argument("study")
    a.add_argument("name")
    _add_address(a)
    a.set_defaults(func=_cmd_add_rater)
    e = sub.add_parser("export", help="write ratings.csv (docs/FORMATS.md §5; a pairwise "
                       "study's votes: §12)")
    e.add_argument("study")
    e.add_argument("--out", required=True)
    e.set_defaults(func=_cmd_export)
    g = sub.add_parser("gvf", help="per-item good-vote fraction of test items")
    g.add_argument("study")
    g.add_argument("--out")
    g.set_defaults(func=_cmd_gvf)
    m = sub.add_parser("simulate", help="add simulated raters (ids sim-*)")
    m.add_argument("study")
    m.add_argument("--raters", type=int_arg(), default=5)
    m.add_argument("--seed", type=int_arg(low=0), default=0)
    m.set_defaults(func=_cmd_simulate)
    return p


#: Library parameter names that differ from this CLI's argparse dests.
_ALIASES = {"n_training": "training", "n_gold": "gold", "n_repeats": "repeats",
            "metrics_path": "metrics_tables", "scene_root": "scene"}


def _main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with flags_in_errors(parser, args, _ALIASES), no_follow_links(getattr(args, "no_follow_links", False)):
            return args.func(args)
    except sqlite3.Error as exc:  # a damaged vote store: one line naming it
        raise InputError(Path(args.study) / "votes.sqlite", None, "a readable SQLite vote store",
                         f"{type(exc).__name__}: {exc}") from None


def main(argv=None) -> int:
    """Entry point of the ``annotate`` console script."""
    return run_cli(_main, argv)


if __name__ == "__main__":
    sys.exit(main())
