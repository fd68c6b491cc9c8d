"""Seconds to answer ``--help``: every command and subcommand of ``nvrq``, ``annotate`` and ``analyze``.

Each ``python -m PACKAGE.cli [COMMAND ...] --help`` runs as a fresh process (what a user's
shell starts), interleaved over ``--rounds`` rounds, beside a bare ``python -c pass`` (the
interpreter's own start-up) in the same rounds. Printed per command: the median wall and
CPU (user + system of the child) seconds, and which packages the slowest answer imported
(tests/test_import_layers.py::test_help_imports_no_heavy_package pins that none of torch,
matplotlib, streamlit, SciPy or scikit-learn is among them).

Target (issue 29 item 10): every ``--help`` in under 1 s. On a shared machine the wall time
moves with the other processes; the CPU time much less.

    python benchmarks/bench_cli_help.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CLIS = {"nvrq": "nvrq.cli", "annotate": "annotate.cli", "analyze": "analysis.cli"}


def commands(prog: str) -> list[list[str]]:
    """``[]`` (the program itself) and the path of every (nested) subcommand of ``prog``."""
    import importlib

    parser = importlib.import_module(CLIS[prog]).build_parser()

    def walk(p, path):
        yield path
        for a in p._actions:
            if isinstance(a, argparse._SubParsersAction):
                for name, sub in a.choices.items():
                    yield from walk(sub, [*path, name])

    return list(walk(parser, []))


def timed_run(argv: list[str]) -> tuple[float, float]:
    """(wall, CPU) seconds of the child process ``argv``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                          cwd=ROOT, timeout=120)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0 or ("--help" in argv and "usage:" not in proc.stdout):
        raise SystemExit(f"{' '.join(argv)} failed: {proc.stderr[-500:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def imported(module: str, path: list[str]) -> list[str]:
    """Top-level third-party packages a ``--help`` of ``path`` imports (the heavy ones we watch)."""
    watch = ("numpy", "pandas", "pyarrow", "cv2", "scipy", "sklearn", "matplotlib", "torch", "streamlit",
             "tqdm", "rich", "jinja2")
    code = (f"import contextlib, io, sys, {module} as m\n"
            f"with contextlib.redirect_stdout(io.StringIO()): m.main({[*path, '--help']!r})\n"
            f"print(','.join(w for w in {watch!r} if w in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=120)
    return out.stdout.strip().split(",") if out.stdout.strip() else []


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds (default 3)")
    ap.add_argument("--programs", default="nvrq,annotate,analyze", help="comma list (default all three)")
    args = ap.parse_args(argv)
    cases = {("python -c pass",): [sys.executable, "-c", "pass"]}
    for prog in args.programs.split(","):
        for path in commands(prog):
            cases[(prog, *path)] = [sys.executable, "-m", CLIS[prog], *path, "--help"]
    secs = {k: [] for k in cases}
    for _ in range(args.rounds):
        for k, cmd in cases.items():
            secs[k].append(timed_run(cmd))
    print(f"--help of {len(cases) - 1} commands, median of {args.rounds} interleaved rounds (wall / CPU s):")
    for k, v in secs.items():
        wall, cpu = np.median([w for w, _ in v]), np.median([c for _, c in v])
        print(f"  {' '.join(k):32s} {wall:6.2f} / {cpu:5.2f}")
    helps = {k: v for k, v in secs.items() if k[0] != "python -c pass"}
    worst = max(helps, key=lambda k: np.median([w for w, _ in helps[k]]))
    worst_wall = np.median([w for w, _ in helps[worst]])
    worst_cpu = max(np.median([c for _, c in v]) for v in helps.values())
    print(f"slowest: {' '.join(worst)} --help, {worst_wall:.2f} s wall (imports: "
          f"{', '.join(imported(CLIS[worst[0]], list(worst[1:]))) or 'none watched'}); "
          f"largest CPU {worst_cpu:.2f} s")
    print(f"target (every --help < 1 s wall): {'met' if worst_wall < 1.0 else 'not met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
