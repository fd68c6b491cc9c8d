"""``annotate serve STUDY [--host H] [--port P]``: serve the rater app (Streamlit).

``annotate serve`` *becomes* ``streamlit run annotate/app.py`` (the process is replaced, so
a signal to ``annotate serve`` reaches the server itself and nothing outlives it), bound to
127.0.0.1 unless ``--host`` says otherwise, headless, without usage statistics, file
watcher, static file serving or error details in the browser, and without Streamlit's full
garbage collection after every script run (about 40 ms of CPU per vote, holding the GIL: it
alone saturated a core at 25 raters); the study folder reaches the app in the environment
variable ``ANNOTATE_STUDY``. A port in use is refused up front.

The address options and the app's URL are shared with ``add-rater`` and ``build``, which
print sign-in and admin links.
"""

from __future__ import annotations

import os
import socket
import sys
from pathlib import Path

from data_schema.errors import InputError
from nvrq.commands.args import int_arg

__all__ = ["register", "run", "serve_command", "check_port_free", "base_url", "add_address_options",
           "DEFAULT_HOST", "DEFAULT_PORT"]

#: Where the rater app listens unless ``--host`` / ``--port`` say otherwise.
DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8501
#: The Streamlit script of the rater app.
APP = Path(__file__).parents[1] / "app.py"


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
            "--runner.postScriptGC", "false"]


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
    p.add_argument("--host", default=DEFAULT_HOST,
                   help=f"address the rater app listens on (default {DEFAULT_HOST}: this machine only)")
    p.add_argument("--port", type=int_arg(high=65535), default=DEFAULT_PORT,
                   help=f"port of the rater app (default {DEFAULT_PORT})")


def register(sub) -> None:
    """Add ``serve`` to the ``annotate`` subcommands ``sub``."""
    s = sub.add_parser("serve", help="serve the rater app (Streamlit)")
    s.add_argument("study", metavar="STUDY", help="study folder made by 'annotate build'")
    add_address_options(s)
    s.set_defaults(func=run)


def run(args) -> int:
    """Replace this process with the Streamlit server of ``args.study`` (see the module docstring)."""
    from annotate.study import load_study

    study = load_study(args.study)  # fail here, not in the browser
    check_port_free(args.host, args.port)
    print(f"serving {study.root} at {base_url(args.host, args.port)} "
          f"(admin: ?admin={study.admin_token()})", file=sys.stderr, flush=True)
    env = dict(os.environ, ANNOTATE_STUDY=str(study.root))
    argv = serve_command(study.root, host=args.host, port=args.port)
    sys.stdout.flush()
    os.execve(argv[0], argv, env)  # replaced: signals and exit status are the server's own
    return 1  # not reached
