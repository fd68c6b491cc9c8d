"""The reverse-proxy configuration that puts one public port in front of K rater workers.

Layer: annotate (rating study; serving).

``annotate serve --workers K`` prints it for its ports (:mod:`annotate.workers`). The proxy
must be *sticky*: a Streamlit session lives in one worker, and so do the images its pages
show (``/media/...`` URLs held in that worker's memory), so every request of one browser
must reach one worker, the websocket included.

- nginx: an ``http``-context file for ``/etc/nginx/conf.d/``. Open
  source nginx has no sticky-cookie directive, so the file makes one: a browser without the
  ``nvrq_worker`` cookie gets a random one (``$request_id``), and ``hash ... consistent``
  maps the cookie to a worker; the websocket upgrade is passed on and kept open for a day.
- Caddy: a Caddyfile site block; ``lb_policy cookie`` is Caddy's own
  sticky-cookie policy and websockets pass through by themselves.

Both refuse the Streamlit endpoints raters never use (``/_stcore/metrics``,
``/_stcore/agent/`` and the file uploads ``/_stcore/upload_file/``: the app has no uploader,
as measured) and any request body over 1 kB (raters send none: votes travel on the websocket),
as docs/guides/public-study.md asks of a proxy. TLS is the proxy's
too (that section); these configurations listen on plain HTTP at ``listen`` and leave the
certificate lines to be added there.

>>> print(proxy_conf("caddy", [8501, 8502], listen=8080))
# caddy: one public port for the 2 workers of `annotate serve` (ports 8501-8502)
:8080 {
    request_body {
        max_size 1KB
    }
    respond /_stcore/metrics 404
    respond /_stcore/agent/* 404
    respond /_stcore/upload_file/* 404
    reverse_proxy 127.0.0.1:8501 127.0.0.1:8502 {
        lb_policy cookie nvrq_worker
    }
}
"""

from __future__ import annotations

from collections.abc import Sequence

from data_schema.errors import InputError

__all__ = ["proxy_conf", "PROXIES", "COOKIE", "upstream_host"]

#: The cookie that pins a browser to one worker.
COOKIE = "nvrq_worker"
#: The proxies a configuration can be printed for.
PROXIES = ("nginx", "caddy")


def upstream_host(host: str) -> str:
    """The address the proxy reaches the workers at: a wildcard bind is reached on loopback.

    Parameters
    ----------
    host : str
        The workers' bind address.

    Returns
    -------
    str
        An address (IPv6 in brackets) for the proxy's upstream.

    >>> upstream_host("0.0.0.0"), upstream_host("::"), upstream_host("10.0.0.5"), upstream_host("::1")
    ('127.0.0.1', '[::1]', '10.0.0.5', '[::1]')
    """
    host = str(host)
    if host in ("0.0.0.0", ""):
        return "127.0.0.1"
    if host == "::":
        return "[::1]"
    return f"[{host}]" if ":" in host else host


def _nginx(upstreams: list[str], listen: int, title: str, loopback: bool) -> str:
    """The nginx file (see :func:`proxy_conf`)."""
    servers = "\n".join(f"    server {u};" for u in upstreams)
    return f"""{title}
map $cookie_{COOKIE} $nvrq_worker {{
    ""      $request_id;
    default $cookie_{COOKIE};
}}
map $http_upgrade $nvrq_connection {{
    default upgrade;
    ""      close;
}}
upstream nvrq_raters {{
    hash $nvrq_worker consistent;
{servers}
}}
server {{
    listen {"127.0.0.1:" if loopback else ""}{int(listen)};
    server_name _;
    client_max_body_size 1k;
    location = /_stcore/metrics {{ return 404; }}
    location ^~ /_stcore/agent/ {{ return 404; }}
    location ^~ /_stcore/upload_file/ {{ return 404; }}
    location / {{
        proxy_pass http://nvrq_raters;
        proxy_http_version 1.1;
        proxy_set_header Upgrade $http_upgrade;
        proxy_set_header Connection $nvrq_connection;
        proxy_set_header Host $http_host;
        proxy_set_header X-Forwarded-For $proxy_add_x_forwarded_for;
        proxy_set_header X-Forwarded-Proto $scheme;
        proxy_read_timeout 1d;
        proxy_send_timeout 1d;
        proxy_buffering off;
        add_header Set-Cookie "{COOKIE}=$nvrq_worker; Path=/; HttpOnly; SameSite=Lax" always;
    }}
}}
"""




def _caddy(upstreams: list[str], listen: int, title: str, loopback: bool) -> str:
    """The Caddyfile (see :func:`proxy_conf`)."""
    return (f"{title}\n:{int(listen)} {{\n" + ("    bind 127.0.0.1\n" if loopback else "") +
            "    request_body {\n        max_size 1KB\n    }\n"
            "    respond /_stcore/metrics 404\n    respond /_stcore/agent/* 404\n"
            "    respond /_stcore/upload_file/* 404\n"
            f"    reverse_proxy {' '.join(upstreams)} {{\n        lb_policy cookie {COOKIE}\n    }}\n}}")


def proxy_conf(proxy: str, ports: Sequence[int], *, host: str = "127.0.0.1", listen: int = 80,
               loopback: bool = False) -> str:
    """The configuration of a sticky reverse proxy on ``listen`` for the workers on ``ports``.

    Parameters
    ----------
    proxy : {'nginx', 'caddy'}
        nginx: an ``http``-context file (``map`` blocks, one ``upstream``, one ``server``);
        caddy: a Caddyfile site block.
    ports : sequence of int
        The workers' ports (all on ``host``).
    host : str, optional
        The workers' bind address (a wildcard becomes loopback, :func:`upstream_host`).
    listen : int, optional
        The public port the proxy listens on (default 80).
    loopback : bool, optional
        Listen on 127.0.0.1 only (an open-access study, which is for this machine only:
        :func:`annotate.access.check_serving`); default: every interface.

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    InputError
        Naming ``proxy`` when it is not one of :data:`PROXIES`.
    """
    if proxy not in PROXIES:
        raise InputError(param="proxy", expected="one of {'nginx', 'caddy'}", got=repr(proxy))
    title = (f"# {proxy}: one public port for the {len(ports)} workers of `annotate serve` "
             f"(ports {ports[0]}-{ports[-1]})")
    upstreams = [f"{upstream_host(host)}:{int(p)}" for p in ports]
    return (_nginx if proxy == "nginx" else _caddy)(upstreams, int(listen), title, bool(loopback))
