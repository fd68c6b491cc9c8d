"""``annotate serve STUDY [--host H] [--port P] [--workers K]``: serve the rater app (Streamlit).

``annotate serve`` *becomes* ``streamlit run annotate/serve_app.py`` (the rater app of
:mod:`annotate.app`, imported once per process; the process is replaced, so
a signal to ``annotate serve`` reaches the server itself and nothing outlives it), bound to
127.0.0.1 unless ``--host`` says otherwise, headless, without usage statistics, file
watcher, static file serving or error details in the browser, and without Streamlit's full
garbage collection after every script run (about 40 ms of CPU per vote, holding the GIL: it
alone saturated a core at 25 raters) and without "magic" (Streamlit recompiles the script
with it for every new session, clearing its script cache: about 50 ms of CPU per rater
signing in; the app has no bare expressions to show); the study folder reaches the app in the environment
variable ``ANNOTATE_STUDY``. A port in use is refused up front.

``--workers K`` (K > 1) runs K such servers on the ports ``--port`` .. ``--port + K - 1``
under a supervisor (:mod:`annotate.workers`: they stop with it and with its process group)
and prints to stdout the configuration of a sticky reverse proxy (``--proxy``, nginx or
Caddy, :mod:`annotate.proxy_conf`) that serves them all on ``--proxy-port``.

The address options and the app's URL are shared with ``add-rater`` and ``build``, which
print sign-in and admin links.
"""

from __future__ import annotations

import os
import socket
import sys
from pathlib import Path

from annotate.proxy_conf import PROXIES, proxy_conf
from annotate.study import load_study
from annotate.workers import supervise, worker_ports
from data_schema.errors import InputError
from nvrq.commands.args import int_arg

__all__ = ["register", "run", "serve_command", "check_port_free", "base_url", "add_address_options",
           "add_worker_options", "serve_workers", "DEFAULT_HOST", "DEFAULT_PORT"]

#: Where the rater app listens unless ``--host`` / ``--port`` say otherwise.
DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8501
#: The Streamlit script of the rater app (it calls annotate.app.main).
APP = Path(__file__).parents[1] / "serve_app.py"


def serve_command(study: str | Path, *, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT) -> list[str]:
    """The ``streamlit run`` argv that serves ``study``.

    Parameters
    ----------
    study : str or Path
        The study folder (the caller passes it to the app as ``ANNOTATE_STUDY`` in its env).
    host : str, optional
        Address to bind (default 127.0.0.1: this machine only).
    port : int, optional
        Port to listen on (default 8501).

    Returns
    -------
    list of str
        The argv, starting with this Python interpreter.
    """
    return [sys.executable, "-m", "streamlit", "run", str(APP),
            "--server.address", str(host), "--server.port", str(int(port)),
            "--server.headless", "true", "--browser.gatherUsageStats", "false",
            "--server.fileWatcherType", "none", "--server.runOnSave", "false",
            "--server.enableStaticServing", "false", "--client.toolbarMode", "minimal",
            "--client.showErrorDetails", "none", "--global.developmentMode", "false",
            "--runner.postScriptGC", "false", "--runner.magicEnabled", "false"]


def check_port_free(host: str, port: int) -> None:
    """Refuse an address where nothing may listen (in use, or not an address here).

    Parameters
    ----------
    host : str
        IPv4 or IPv6 address.
    port : int
        TCP port.

    Raises
    ------
    InputError
        Naming ``--port`` when binding ``host:port`` fails.
    """
    with socket.socket(socket.AF_INET6 if ":" in str(host) else socket.AF_INET) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server binds
        try:
            sock.bind((str(host), int(port)))
        except OSError as err:
            raise InputError("--port", None, f"a free port on {host}",
                             f"{port} ({err.strerror or err})") from None


def base_url(host: str = DEFAULT_HOST, port: int = DEFAULT_PORT) -> str:
    """The rater app's URL, e.g. ``http://127.0.0.1:8501/``.

    Parameters
    ----------
    host : str, optional
        The app's address (default 127.0.0.1).
    port : int, optional
        The app's port (default 8501).

    Returns
    -------
    str
        ``http://HOST:PORT/``.
    """
    return f"http://{host}:{port}/"


def add_address_options(p) -> None:
    """Add the rater app's address options, ``--host`` and ``--port``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser of ``serve``, or of ``add-rater`` (its sign-in links).
    """
    p.add_argument("--host", default=DEFAULT_HOST)
    p.add_argument("--port", type=int_arg(high=65535), default=DEFAULT_PORT)


def register(sub) -> None:
    """Add ``serve`` to the ``annotate`` subcommands ``sub``."""
    s = sub.add_parser("serve", help="serve the rater app (Streamlit)")
    s.add_argument("study")
    add_address_options(s)
    add_worker_options(s)
    s.set_defaults(func=run)


def add_worker_options(p) -> None:
    """Add ``--workers``, ``--proxy`` and ``--proxy-port`` (README "Serve with several workers")."""
    p.add_argument("--workers", type=int_arg(high=64), default=1,
                   help="server processes on consecutive ports from --port (default 1)")
    p.add_argument("--proxy", choices=PROXIES, default="nginx",
                   help="reverse proxy whose configuration --workers prints (default nginx)")
    p.add_argument("--proxy-port", type=int_arg(high=65535), default=80,
                   help="public port of that proxy configuration (default 80)")


def serve_workers(study_root: Path, args, env: dict) -> int:
    """Print the proxy configuration for ``args.workers`` servers, then supervise them."""
    ports = worker_ports(args.port, args.workers)
    print(proxy_conf(args.proxy, ports, host=args.host, listen=args.proxy_port), flush=True)
    print(f"{args.workers} workers: " + ", ".join(base_url(args.host, p) for p in ports)
          + f"; one public port is the proxy's (configuration above, {args.proxy})",
          file=sys.stderr, flush=True)
    return supervise([serve_command(study_root, host=args.host, port=p) for p in ports], env=env)


def run(args) -> int:
    """Replace this process with the Streamlit server of ``args.study`` (see the module docstring)."""
    study = load_study(args.study)  # fail here, not in the browser
    if args.port + args.workers - 1 > 65535:
        raise InputError("--workers", None, f"at most {65536 - args.port} workers from --port {args.port}",
                         args.workers)
    for port in worker_ports(args.port, args.workers):
        check_port_free(args.host, port)
    print(f"serving {study.root} at {base_url(args.host, args.port)} "
          f"(admin: ?admin={study.admin_token()})", file=sys.stderr, flush=True)
    env = dict(os.environ, ANNOTATE_STUDY=str(study.root))
    if args.workers > 1:
        return serve_workers(study.root, args, env)
    argv = serve_command(study.root, host=args.host, port=args.port)
    sys.stdout.flush()
    os.execve(argv[0], argv, env)  # replaced: signals and exit status are the server's own
    return 1  # not reached
