"""``annotate serve STUDY [--host H] [--port P] [--public-url BASE] [--workers K]``: serve the rater app (Streamlit).

Layer: commands (CLI shell) of ``annotate``.

``annotate serve`` *becomes* ``streamlit run annotate/serve_app.py`` (the rater app of
:mod:`annotate.app`, imported once per process; the process is replaced, so
a signal to ``annotate serve`` reaches the server itself and nothing outlives it), bound to
127.0.0.1 unless ``--host`` says otherwise, headless, without usage statistics, file
watcher, static file serving, file uploads (``server.maxUploadSize`` 0: the app has no
uploader) or error details in the browser, and without Streamlit's full
garbage collection after every script run (about 40 ms of CPU per vote, holding the GIL: it
alone saturated a core at 25 raters) and without "magic" (Streamlit recompiles the script
with it for every new session, clearing its script cache: about 50 ms of CPU per rater
signing in; the app has no bare expressions to show); the study folder reaches the app in
the environment variable ``ANNOTATE_STUDY``. A port in use is refused up front, and so is
an open-access study on an address others can reach (:func:`annotate.access.check_serving`).

``--workers K`` (K > 1) runs K such servers on the ports ``--port`` .. ``--port + K - 1``
under a supervisor (:mod:`annotate.workers`: they stop with it and with its process group;
a worker that dies is started again on its port, at most ``MAX_RESTARTS`` times, each
restart one line on stderr; past that, or when a worker cannot start, every worker stops
with one line naming it and its exit status)
and prints to stdout the configuration of a sticky reverse proxy (``--proxy``, nginx or
Caddy, :mod:`annotate.proxy_conf`) that serves them all on ``--proxy-port``.

The address options and the app's URL are shared with ``add-rater`` and ``build``, which
print sign-in and admin links: ``--public-url`` (the address raters use, e.g. a TLS reverse
proxy's) is the base of every printed link, else the bound address (this machine's name for a
wildcard bind). ``serve`` records the base it serves at in ``STUDY/served-at.json``, which
``add-rater`` uses when given no address option (its links once named port 8501 whatever
port was served), and writes the admin page's full link to ``STUDY/admin-link.txt`` (mode
0600) for the operator to copy; it prints the full link only to a terminal, never to a
redirected stderr (a log others may read), where it names the file instead. ``build``
prints the admin token once, and it stays in ``STUDY/secrets.json``.
"""

from __future__ import annotations

import ipaddress
import json
import os
import socket
import sys
from pathlib import Path
from urllib.parse import urlsplit

from annotate.access import check_serving
from annotate.commands import add_study_argument
from annotate.proxy_conf import PROXIES, proxy_conf
from annotate.workers import supervise, worker_ports
from data_schema.errors import InputError
from data_schema.vocab import Access
from nvrq.cli_types import int_arg

__all__ = ["register", "run", "serve_command", "check_port_free", "base_url", "add_address_options", "links",
           "add_worker_options", "serve_workers", "served_base", "record_served", "DEFAULT_HOST",
           "DEFAULT_PORT", "SERVED_AT", "ADMIN_LINK"]

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
            "--runner.postScriptGC", "false", "--runner.magicEnabled", "false",
            "--server.maxUploadSize", "0"]


def check_port_free(host: str, port: int) -> None:
    """Refuse an address where nothing may listen (in use, or not an address here).

    Parameters
    ----------
    host : str
        The address the server will bind: IPv6 when it holds a colon, else IPv4.
    port : int
        The TCP port tried there (with ``SO_REUSEADDR``, as the server binds).

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


def base_url(host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, *, public_url: str | None = None) -> str:
    """The rater app's URL, e.g. ``http://127.0.0.1:8501/``: the base of every printed link.

    Parameters
    ----------
    host : str, optional
        The app's bind address (default 127.0.0.1). A wildcard (``0.0.0.0``, ``::``) binds
        every interface and is no address to open: this machine's name stands for it.
    port : int, optional
        The app's port (default 8501).
    public_url : str, optional
        The address raters use (e.g. ``https://study.example.org/``, a reverse proxy's);
        an absolute http(s) URL, used as it is (with a final ``/``) instead of host and port.

    Returns
    -------
    str
        ``public_url``, else ``http://HOST:PORT/`` (an IPv6 address in brackets).

    Raises
    ------
    InputError
        Naming ``public_url`` when it is not an absolute http(s) URL without query or fragment.

    >>> base_url("::1", 8502), base_url(public_url="https://study.example.org")
    ('http://[::1]:8502/', 'https://study.example.org/')
    """
    if public_url is not None:
        parts = urlsplit(str(public_url))
        if parts.scheme not in ("http", "https") or not parts.netloc or parts.query or parts.fragment:
            raise InputError(param="public_url", expected="an absolute http:// or https:// URL without "
                             "query, e.g. https://study.example.org/", got=public_url)
        return str(public_url).rstrip("/") + "/"
    host = str(host).strip("[]")
    try:
        addr = ipaddress.ip_address(host)
    except ValueError:
        addr = None
    if addr is not None and addr.is_unspecified:
        host = socket.getfqdn()
    elif addr is not None and addr.version == 6:
        host = f"[{host}]"
    return f"http://{host}:{port}/"


def add_address_options(p, *, defaults: bool = True) -> None:
    """Add the rater app's address options, ``--host``, ``--port`` and ``--public-url``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser of ``serve``, or of ``add-rater`` (its sign-in links).
    defaults : bool, optional
        Default ``--host``/``--port`` to 127.0.0.1:8501 (``serve``); False: None, so
        ``add-rater`` can tell an option given from the address the study was served at.
    """
    p.add_argument("--host", default=DEFAULT_HOST if defaults else None,
                   help=f"address the rater app listens on (default {DEFAULT_HOST}: this machine only)")
    p.add_argument("--port", type=int_arg(high=65535), default=DEFAULT_PORT if defaults else None,
                   help=f"port of the rater app (default {DEFAULT_PORT})")
    p.add_argument("--public-url", metavar="BASE", help="the address raters use (e.g. a TLS reverse "
                   "proxy's https://study.example.org/): the base of every printed link (default: "
                   "http://HOST:PORT/; add-rater: the address the study was last served at)")


#: The file in a study folder where ``serve`` records the address it serves at (no secret).
SERVED_AT = "served-at.json"
#: The file in a study folder holding the admin page's full link (mode 0600, owner only).
ADMIN_LINK = "admin-link.txt"


def served_base(study_root: Path) -> str | None:
    """The base URL ``annotate serve`` last recorded for the study (None if never served).

    Parameters
    ----------
    study_root : pathlib.Path

    Returns
    -------
    str or None
    """
    try:
        return str(json.loads((Path(study_root) / SERVED_AT).read_text())["base"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def record_served(study, base: str) -> Path:
    """Record ``base`` (for ``add-rater``'s links) and write the admin page's full link to
    ``STUDY/admin-link.txt``, readable by its owner only (mode 0600), for the operator to
    copy; the path of that file.

    Parameters
    ----------
    study : annotate.study.Study
    base : str
        The public base URL in use.

    Returns
    -------
    pathlib.Path
    """
    from data_schema.tables import atomic_write_text  # pandas: not for --help

    atomic_write_text(study.root / SERVED_AT, json.dumps({"base": base}))
    path = study.root / ADMIN_LINK
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(f"{base}?admin={study.admin_token()}\n")
    os.chmod(path, 0o600)
    return path


def links(study, base: str) -> list[str]:
    """What ``serve`` says on starting: where, the admin page (the token named, not printed)
    and, for a crowd study, the participants' link and completion URL.

    Parameters
    ----------
    study : annotate.study.Study
    base : str
        The app's public base URL (:func:`base_url`).

    Returns
    -------
    list of str
        One line each.
    """
    out = [f"serving {study.root} at {base}",
           f"admin page: {base}?admin=ADMIN_TOKEN (the full link, to copy: {study.root / ADMIN_LINK}, "
           f"readable by you only; ADMIN_TOKEN is admin_token in {study.root / 'secrets.json'})"]
    if study.manifest.access == Access.CROWD:
        param = study.manifest.participant_param
        out.append(f"participants' link: {base}" + (f"?{param}=PARTICIPANT_ID (the panel fills in "
                                                    f"{param})" if param else " (each arrival gets its own identity)"))
        if study.manifest.completion_url:
            out.append(f"finished raters are shown: {study.manifest.completion_url}")
    return out


def register(sub) -> None:
    """Add ``serve`` with its address (:func:`add_address_options`) and worker
    (:func:`add_worker_options`) options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``annotate`` subcommands; ``serve`` is added.
    """
    s = sub.add_parser("serve", help="serve the rater app (Streamlit)")
    add_study_argument(s)
    add_address_options(s)
    add_worker_options(s)
    s.set_defaults(func=run)


def add_worker_options(p) -> None:
    """Add ``--workers``, ``--proxy`` and ``--proxy-port`` (docs/guides/several-workers.md).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The ``serve`` parser.
    """
    p.add_argument("--workers", type=int_arg(high=64), default=1,
                   help="server processes on consecutive ports from --port (default 1)")
    p.add_argument("--proxy", choices=PROXIES, default="nginx",
                   help="reverse proxy whose configuration --workers prints (default nginx)")
    p.add_argument("--proxy-port", type=int_arg(high=65535), default=80,
                   help="public port of that proxy configuration (default 80)")
    p.add_argument("--arrivals-per-minute", type=int_arg(low=0, high=100000), default=20,
                   metavar="N", help="crowd study: new identities a minute per client address "
                   "(bursts of 10; behind a proxy, its X-Forwarded-For; 0: no limit; default 20)")


def serve_workers(study_root: Path, args, env: dict, *, loopback: bool) -> int:
    """Print the proxy configuration for ``args.workers`` servers (listening on loopback only
    when ``loopback``: an open study), then supervise them.

    Parameters
    ----------
    study_root : Path
        The study folder.
    args : argparse.Namespace
        The parsed options of ``annotate serve``.
    env : dict
        The servers' environment.
    loopback : bool
        Servers listen on 127.0.0.1 only.

    Returns
    -------
    int
        The exit status of the supervised servers.
    """
    ports = worker_ports(args.port, args.workers)
    print(proxy_conf(args.proxy, ports, host=args.host, listen=args.proxy_port, loopback=loopback),
          flush=True)
    print(f"{args.workers} workers: " + ", ".join(base_url(args.host, p) for p in ports)
          + f"; one public port is the proxy's (configuration above, {args.proxy})",
          file=sys.stderr, flush=True)
    return supervise([serve_command(study_root, host=args.host, port=p) for p in ports], env=env,
                     names=[f"the worker on port {p}" for p in ports])


def run(args) -> int:
    """Replace this process with the Streamlit server of ``args.study`` (see the module
    docstring), or supervise ``--workers`` servers behind a printed proxy configuration.

    Parameters
    ----------
    args : argparse.Namespace
        ``study``, the address (``host``, ``port``, ``public_url``), the workers (``workers``,
        ``proxy``, ``proxy_port``) and ``arrivals_per_minute``.

    Returns
    -------
    int
        With ``--workers`` above 1, the supervised servers' exit status; one server replaces
        this process and never returns (its exit status is the server's).
    """
    from annotate.study import load_study

    study = load_study(args.study)  # fail here, not in the browser
    is_open = study.manifest.access == Access.OPEN
    if args.workers > 1:  # raters come through the proxy: its port (loopback only when open)
        base = base_url("127.0.0.1" if is_open else "0.0.0.0", args.proxy_port, public_url=args.public_url)
    else:
        base = base_url(args.host, args.port, public_url=args.public_url)
    check_serving(study.manifest.access, host=args.host, public_url=args.public_url)
    if args.port + args.workers - 1 > 65535:
        raise InputError("--workers", None, f"at most {65536 - args.port} workers from --port {args.port}",
                         args.workers)
    for port in worker_ports(args.port, args.workers):
        check_port_free(args.host, port)
    for line in links(study, base):
        print(line, file=sys.stderr, flush=True)
    record_served(study, base)
    if sys.stderr.isatty():  # a person's terminal, not a log file: the link to click
        print(f"admin link (not logged): {base}?admin={study.admin_token()}", file=sys.stderr,
              flush=True)
    env = dict(os.environ, ANNOTATE_STUDY=str(study.root),
               ANNOTATE_ARRIVALS_PER_MINUTE=str(args.arrivals_per_minute))
    if args.workers > 1:
        return serve_workers(study.root, args, env, loopback=is_open)
    argv = serve_command(study.root, host=args.host, port=args.port)
    sys.stdout.flush()
    os.execve(argv[0], argv, env)  # replaced: signals and exit status are the server's own
    return 1  # not reached
