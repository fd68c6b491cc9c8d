"""``annotate rate-yourself DEMO [--items N] [--port P]``: rate about 20 of the demo's items in
your browser, on this machine, then see how your votes agree with the simulated raters'.

Layer: commands (CLI shell) of ``annotate``.

Builds ``DEMO/yourself`` the first time (:func:`annotate.rate_yourself.build_own_study`), serves
it on 127.0.0.1 (the rater app of ``annotate serve``, as a child process in its own process
group), prints the address, waits until one rater has voted on every item (or Ctrl-C), stops the
server and prints that rater's agreement with the simulated raters
(:func:`annotate.rate_yourself.own_agreement`).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from nvrq.cli_types import int_arg

__all__ = ["register", "run"]


def register(sub) -> None:
    """Add ``annotate rate-yourself``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        ``annotate``'s subparsers.
    """
    from annotate.commands.serve import DEFAULT_PORT

    p = sub.add_parser("rate-yourself", help="rate about 20 of the demo's items in your browser and see "
                       "your agreement with the simulated raters",
                       description="Serve a small good/bad study made from the items the demo's simulated "
                       "raters rated, on this machine only; when you have rated every item, print how "
                       "your votes agree with theirs.")
    p.add_argument("demo", metavar="DEMO", help="the folder nvrq demo wrote (its study/ and pairs.csv)")
    p.add_argument("--items", type=int_arg(low=2), default=20, help="items to rate (default 20)")
    p.add_argument("--port", type=int_arg(low=1, high=65535), default=DEFAULT_PORT,
                   help=f"port on 127.0.0.1 (default {DEFAULT_PORT})")
    p.add_argument("--seed", type=int_arg(low=0), default=0, help="seed of the items chosen (default 0)")
    p.set_defaults(func=run)


def _finished(study, n_items: int):
    """The rater who has voted on every item (or None) and their votes."""
    votes = study.store.votes()
    done = votes.groupby("rater")["item"].nunique()
    done = done[done >= n_items]
    if done.empty:
        return None, None
    rater = str(done.index[0])
    return rater, votes[votes["rater"] == rater]


def run(args) -> int:
    """Build (once) and serve the small study, wait for one rater to finish, print the agreement.

    Parameters
    ----------
    args : argparse.Namespace
        ``demo``, ``items``, ``port``, ``seed``.

    Returns
    -------
    int
        0 once the agreement is printed (130 after Ctrl-C, the server stopped).
    """
    from annotate.commands.serve import check_port_free, serve_command
    from annotate.rate_yourself import OWN_STUDY, agreement_lines, build_own_study, own_agreement
    from annotate.study import load_study

    demo = Path(args.demo)
    own = demo / OWN_STUDY
    check_port_free("127.0.0.1", args.port)
    if not own.is_dir():
        build_own_study(demo, n=args.items, seed=args.seed)
    study = load_study(own)
    simulated = load_study(demo / "study").store.votes()
    simulated = simulated[simulated["rater"].str.startswith("sim-")]
    n_items = len(study.items)
    url = f"http://127.0.0.1:{args.port}/"
    env = dict(os.environ, ANNOTATE_STUDY=str(study.root))
    server = subprocess.Popen(serve_command(study.root, host="127.0.0.1", port=args.port), env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    print(f"Open {url} in your browser, type a name and rate the {n_items} items "
          "(is the render on the right as good as the photograph on the left?).", flush=True)
    print("Your agreement with the simulated raters is printed here when you have rated them all "
          "(Ctrl-C stops).", flush=True)
    try:
        while True:
            rater, votes = _finished(study, n_items)
            if rater is not None:
                break
            if server.poll() is not None:
                print(f"the rating server stopped (status {server.returncode})", file=sys.stderr)
                return 1
            time.sleep(0.5)
    finally:
        if server.poll() is None:
            os.killpg(server.pid, signal.SIGTERM)
            try:
                server.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(server.pid, signal.SIGKILL)
                server.wait(timeout=10)
    mine = votes[["item", "vote"]]
    result = own_agreement(mine, simulated)
    print(f"\nThank you, {rater}.")
    for line in agreement_lines(result, n_raters=simulated["rater"].nunique()):
        print(line)
    return 0
