"""Several rater-app processes on one study: ``annotate serve --workers K``.

Layer: annotate (rating study; serving).

One Streamlit process runs its scripts on one core (the GIL), so past about a hundred
concurrent raters the votes queue. ``K`` workers serve the same study folder on the
consecutive ports ``port, port + 1, ..., port + K - 1``; they share nothing but the study's
files. Everything that must agree between them lives in the SQLite vote store (WAL mode,
safe for several processes on one machine): claims are taken inside ``BEGIN IMMEDIATE``
transactions, so no item is handed out beyond its quota whichever worker a rater uses, and
progress and the admin page read the same rows. What a worker keeps in memory never
changes while it runs (the study's items, crops and the raters' stored plans).

One public port in front of the workers is a reverse proxy's job (see
:mod:`annotate.proxy_conf`): a rater's websocket and the images of that session must reach
the worker holding the session.

Process rules (:func:`supervise`): the workers run in the caller's process group, so a
signal to the group stops everything; SIGTERM, SIGINT or SIGHUP to the supervisor is passed
on to the workers and waited for; on Linux each worker also gets SIGTERM when the
supervisor dies (``PR_SET_PDEATHSIG``), so not even a SIGKILL to the supervisor leaves a
server behind. A worker that exits on its own after it had run for :data:`MIN_UPTIME_S` is
started again on its port, at most :data:`MAX_RESTARTS` times in all, with one line on
stderr each time (before, one killed worker stopped every other); the raters it
served reconnect there (their votes are in the store: a vote is acknowledged only once it
is committed, so none is lost). A worker that exits sooner (it could not start: a bad
port, a broken study) or once the restarts are spent stops the others, with one line
naming it, and its status is returned.
"""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import time
from collections.abc import Sequence

__all__ = ["worker_ports", "supervise", "STOP_SIGNALS", "MAX_RESTARTS", "MIN_UPTIME_S"]

#: Signals the supervisor passes on to its workers before it exits.
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)
#: Restarts of exited workers, over all workers, before the supervisor gives up.
MAX_RESTARTS = 5
#: Seconds a worker must have run for its exit to be restarted (sooner: it cannot start).
MIN_UPTIME_S = 5.0
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def worker_ports(port: int, workers: int) -> list[int]:
    """The ports of ``workers`` processes starting at ``port``.

    Parameters
    ----------
    port : int
        The first port.
    workers : int
        Number of processes.

    Returns
    -------
    list of int

    >>> worker_ports(8501, 3)
    [8501, 8502, 8503]
    """
    return list(range(int(port), int(port) + int(workers)))


def _die_with_parent(parent: int) -> None:
    """In the forked worker before exec: SIGTERM when ``parent`` dies (Linux; else nothing)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the process group still stops them
        return
    if os.getppid() != parent:  # the parent died before prctl took effect
        os.kill(os.getpid(), signal.SIGTERM)


def _status(rc: int) -> int:
    """An exit status as a shell gives it: a signal ``S`` as ``128 + S``."""
    return rc if rc >= 0 else 128 - rc


def _how(rc: int) -> str:
    if rc < 0:
        try:
            return f"was killed by {signal.Signals(-rc).name}"
        except ValueError:
            return f"was killed by signal {-rc}"
    return f"exited with status {rc}"


def supervise(argvs: Sequence[Sequence[str]], *, env: dict, poll_s: float = 0.2,
              grace_s: float = 20.0, names: Sequence[str] | None = None,
              max_restarts: int = MAX_RESTARTS, min_uptime_s: float = MIN_UPTIME_S) -> int:
    """Run one process per argv until a stop signal, restarting one that exits (module
    docstring).

    Parameters
    ----------
    argvs : sequence of argv lists
        The workers' command lines (e.g. :func:`annotate.commands.serve.serve_command`).
    env : dict
        Their environment. Their output goes to the supervisor's stderr (stdout is the
        caller's, e.g. for the proxy configuration).
    poll_s : float, optional
        How often the supervisor looks for an exited worker (seconds).
    grace_s : float, optional
        How long a stopped worker may take before it is killed (seconds).
    names : sequence of str, optional
        What the stderr lines call each worker (default ``worker 1``, ``worker 2``, ...).
    max_restarts : int, optional
        Restarts in all before an exit stops every worker.
    min_uptime_s : float, optional
        A worker that exits sooner after its start is not restarted.

    Returns
    -------
    int
        0 after a stop signal; else the exit status of the worker whose exit stopped the
        others (a signal ``S`` as ``128 + S``).
    """
    parent = os.getpid()
    names = list(names) if names is not None else [f"worker {i + 1}" for i in range(len(argvs))]
    stop: list[int] = []
    previous = {s: signal.signal(s, lambda signum, _frame: stop.append(signum)) for s in STOP_SIGNALS}
    procs: list[subprocess.Popen] = []
    started: list[float] = []

    def start(argv) -> subprocess.Popen:
        return subprocess.Popen(list(argv), env=env, stdout=sys.stderr.fileno(),
                                preexec_fn=lambda: _die_with_parent(parent))

    try:
        for argv in argvs:
            procs.append(start(argv))
            started.append(time.monotonic())
        restarts, status = 0, None
        while not stop and status is None:
            for i, p in enumerate(procs):
                rc = p.poll()
                if rc is None or stop:
                    continue
                ran = time.monotonic() - started[i]
                if ran >= min_uptime_s and restarts < max_restarts:
                    restarts += 1
                    print(f"annotate serve: {names[i]} {_how(rc)} after {ran:.0f} s; restarting "
                          f"it (restart {restarts} of {max_restarts})", file=sys.stderr, flush=True)
                    procs[i], started[i] = start(argvs[i]), time.monotonic()
                    continue
                why = (f"its restarts are spent: {max_restarts}" if ran >= min_uptime_s
                       else f"within {min_uptime_s:g} s of its start")
                print(f"annotate serve: {names[i]} {_how(rc)} ({why}); stopping every worker "
                      f"(exit status {_status(rc)})", file=sys.stderr, flush=True)
                status = _status(rc)
                break
            else:
                time.sleep(poll_s)
        return 0 if status is None else status
    finally:
        _stop_all(procs, grace_s=grace_s)
        for s, handler in previous.items():
            signal.signal(s, handler)


def _stop_all(procs: list[subprocess.Popen], *, grace_s: float) -> None:
    """SIGTERM to every worker still running, then SIGKILL to any left after ``grace_s``."""
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    deadline = time.monotonic() + grace_s
    for p in procs:
        try:
            p.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
    sys.stdout.flush()
