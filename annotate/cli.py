"""The ``annotate`` command: build, serve, add-rater, export, gvf, simulate (thin shell).

``annotate serve`` runs ``streamlit run annotate/app.py`` bound to 127.0.0.1 unless
``--host`` says otherwise, headless, without usage statistics, file watcher or static file
serving; the study folder reaches the app in the environment variable ``ANNOTATE_STUDY``.
"""

from __future__ import annotations

import argparse
import os
import secrets
import subprocess
import sys
from pathlib import Path

from annotate.results import gvf_table, ratings_table
from annotate.simulate import simulate
from annotate.study import build_study, load_study
from data_schema.errors import run_subcommand
from data_schema.raters import check_rater_name
from data_schema.tables import write_table

__all__ = ["main", "build_parser", "serve_command"]

def serve_command(study: str | Path, *, host: str = "127.0.0.1", port: int = 8501) -> list[str]:
    """The ``streamlit run`` argv that serves ``study`` (set ANNOTATE_STUDY in its env)."""
    app = Path(__file__).with_name("app.py")
    return [sys.executable, "-m", "streamlit", "run", str(app),
            "--server.address", str(host), "--server.port", str(int(port)),
            "--server.headless", "true", "--browser.gatherUsageStats", "false",
            "--server.fileWatcherType", "none", "--server.runOnSave", "false",
            "--server.enableStaticServing", "false", "--client.toolbarMode", "minimal",
            "--global.developmentMode", "false"]


def _base_url(host: str, port: int) -> str:
    return f"http://{host}:{port}/"


def _cmd_build(args) -> int:
    out = build_study(args.study, args.pairs, scene=args.scene, metrics_path=args.metrics,
                      tracks=args.tracks, frames_per_track=args.frames_per_track,
                      offsets=args.offsets, votes_per_item=args.votes_per_item, seed=args.seed,
                      n_training=args.training, n_gold=args.gold, n_repeats=args.repeats,
                      size=args.size, image_format=args.image_format, access=args.access,
                      break_every=args.break_every)
    study = load_study(out)
    counts = ", ".join(f"{v} {k}" for k, v in study.manifest["counts"].items())
    print(f"study {out}: {counts} items")
    print(f"admin page: {_base_url('127.0.0.1', 8501)}?admin={study.admin_token()}")
    return 0


def _cmd_serve(args) -> int:
    study = load_study(args.study)  # fail here, not in the browser
    print(f"serving {study.root} at {_base_url(args.host, args.port)} "
          f"(admin: ?admin={study.admin_token()})", file=sys.stderr)
    env = dict(os.environ, ANNOTATE_STUDY=str(study.root))
    return subprocess.call(serve_command(study.root, host=args.host, port=args.port), env=env)


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
    table = ratings_table(load_study(args.study))
    write_table(table, args.out)
    print(f"{len(table)} votes -> {args.out}", file=sys.stderr)
    return 0


def _cmd_gvf(args) -> int:
    table = gvf_table(ratings_table(load_study(args.study)))
    if args.out:
        write_table(table, args.out)
    else:
        print(table.to_string(index=False))
    return 0


def _cmd_simulate(args) -> int:
    params = simulate(load_study(args.study), raters=args.raters, seed=args.seed)
    print(params.to_string(index=False))
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="annotate", description="Rating studies of render quality.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    b = sub.add_parser("build", help="build a study folder from a pairs table")
    b.add_argument("study")
    b.add_argument("--pairs", required=True, help="pairs table (SPEC section 3)")
    b.add_argument("--scene", help="scene folder the pairs' image paths are relative to "
                   "(default: the pairs table's scene_root column)")
    b.add_argument("--metrics", help="metrics table (pair_id + metric columns) for the export")
    b.add_argument("--tracks", type=int, default=12)
    b.add_argument("--frames-per-track", type=int, default=12)
    b.add_argument("--offsets", default="all", help="'all' or a comma list of metres")
    b.add_argument("--votes-per-item", type=int, default=5)
    b.add_argument("--seed", type=int, default=0)
    b.add_argument("--training", type=int, default=5, help="training items (shown first)")
    b.add_argument("--gold", type=int, default=3, help="hidden gold items of each kind")
    b.add_argument("--repeats", type=int, default=5, help="repeated test items")
    b.add_argument("--size", type=int, default=320, help="display size of each crop (pixels)")
    b.add_argument("--image-format", default="jpg", choices=["jpg", "png"])
    b.add_argument("--access", default="open", choices=["open", "token"])
    b.add_argument("--break-every", type=int, default=50)
    b.set_defaults(func=_cmd_build)
    s = sub.add_parser("serve", help="serve the rater app (Streamlit)")
    s.add_argument("study")
    s.add_argument("--host", default="127.0.0.1")
    s.add_argument("--port", type=int, default=8501)
    s.set_defaults(func=_cmd_serve)
    a = sub.add_parser("add-rater", help="register a rater and print the sign-in link")
    a.add_argument("study")
    a.add_argument("name")
    a.add_argument("--host", default="127.0.0.1")
    a.add_argument("--port", type=int, default=8501)
    a.set_defaults(func=_cmd_add_rater)
    e = sub.add_parser("export", help="write ratings.csv (SPEC section 5)")
    e.add_argument("study")
    e.add_argument("--out", required=True)
    e.set_defaults(func=_cmd_export)
    g = sub.add_parser("gvf", help="per-item good-vote fraction of test items")
    g.add_argument("study")
    g.add_argument("--out")
    g.set_defaults(func=_cmd_gvf)
    m = sub.add_parser("simulate", help="add simulated raters (ids sim-*)")
    m.add_argument("study")
    m.add_argument("--raters", type=int, default=5)
    m.add_argument("--seed", type=int, default=0)
    m.set_defaults(func=_cmd_simulate)
    return p


def main(argv=None) -> int:
    """Entry point of the ``annotate`` console script."""
    return run_subcommand(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
