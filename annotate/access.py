"""Who may rate: the three access modes of a study and the identities they give raters.

- ``open``: a rater is ``?rater=NAME`` (or a name typed in); there is no authentication, so
  an open study is served on a loopback address only (:func:`check_serving`);
- ``token``: per-rater links ``?token=TOKEN`` made by ``annotate add-rater``;
- ``crowd``: every arrival gets a fresh server-issued identity, a token carried in the URL
  the app rewrites the address to (``?token=TOKEN``), so a reload resumes. The token holds
  the rater id and an HMAC of it under the study's secret, so an arrival stores nothing: the
  rater is registered at its first vote. New identities are limited per client address
  (:class:`ArrivalLimiter`; ``annotate serve --arrivals-per-minute``), a study whose test
  items all have their votes refuses new arrivals ("the study is full", no completion link),
  and the participant id must be the whole parameter value (no control character). With a
  ``participant_param`` (e.g. Prolific's ``PROLIFIC_PID``) the panel's participant id is
  recorded and gives one identity per participant: the token and rater id are HMACs of the
  id under the study's secret, so a participant who comes back through the panel's link is
  the same rater; an arrival without the parameter is refused. ``completion_url`` is shown
  to the rater who finishes.

Tokens of token studies (and of crowd raters once registered) are stored as SHA-256 digests,
found through an index and compared in constant time
(:meth:`annotate.store.Store.rater_for_token`); a token or rater id is random or an HMAC,
never derived from items.

>>> check_access("crowd", participant_param="PROLIFIC_PID",
...              completion_url="https://app.prolific.com/submissions/complete?cc=C1")
{'access': 'crowd', 'participant_param': 'PROLIFIC_PID', 'completion_url': 'https://app.prolific.com/submissions/complete?cc=C1'}
>>> is_loopback("127.0.0.1"), is_loopback("::1"), is_loopback("0.0.0.0"), is_loopback("localhost")
(True, True, False, True)
"""

from __future__ import annotations

import base64
import collections
import hashlib
import hmac
import ipaddress
import re
import secrets
import socket
import threading
import time
from urllib.parse import urlsplit

from data_schema.errors import InputError
from data_schema.vocab import Access

__all__ = ["ACCESS_MODES", "CROWD_PREFIX", "check_access", "is_loopback", "check_serving",
           "crowd_identity", "crowd_rater_for_token", "crowd_arrival", "register_crowd_rater",
           "check_participant", "client_address", "ArrivalLimiter", "arrival_limiter", "CrowdRefused", "MSG_FULL"]

#: The access modes of a study (manifest ``access``).
ACCESS_MODES = tuple(Access)
#: Rater ids of crowd identities start with this.
CROWD_PREFIX = "crowd-"
#: Query parameters the app itself reads; a panel's participant parameter must differ.
_APP_PARAMS = {"token", "rater", "admin"}
_PARAM = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]{0,63}")  # the whole value (fullmatch)
_PARTICIPANT = re.compile(r"[A-Za-z0-9_.:@-]{1,64}")  # the whole value (fullmatch)
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def check_access(access: str, *, participant_param: str | None = None,
                 completion_url: str | None = None) -> dict:
    """The access settings of a new study, checked; the manifest's keys.

    Parameters
    ----------
    access : {'open', 'token', 'crowd'}
    participant_param : str, optional
        Crowd only: the query parameter carrying the panel's participant id (1-64 of
        ``A-Z a-z 0-9 _ . -``, not ``token``, ``rater`` or ``admin``).
    completion_url : str, optional
        Crowd only: an absolute ``http(s)://`` URL shown to a rater who has finished.

    Returns
    -------
    dict
        ``{'access': ...}``, plus ``participant_param`` and ``completion_url`` (None when not
        given) for a crowd study.

    Raises
    ------
    InputError
        Naming the parameter that is bad or does not fit the mode.
    """
    if access not in ACCESS_MODES:
        raise InputError(param="access", expected="one of {'open', 'token', 'crowd'}", got=access)
    for name, value in (("participant_param", participant_param), ("completion_url", completion_url)):
        if value is not None and access != Access.CROWD:
            raise InputError(param=name, expected="no value unless `access` is crowd", got=value)
    if access != Access.CROWD:
        return {"access": access}
    if participant_param is not None and (not _PARAM.fullmatch(str(participant_param))
                                          or participant_param in _APP_PARAMS):
        raise InputError(param="participant_param", expected="a query parameter name (letters, digits, "
                         "'_', '.', '-'; not token, rater or admin), e.g. PROLIFIC_PID",
                         got=repr(participant_param))
    if completion_url is not None:
        url = str(completion_url)
        parts = urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.netloc or re.search(r"[\s\x00-\x1f]", url):
            raise InputError(param="completion_url", expected="an absolute http:// or https:// URL",
                             got=repr(url))
    return {"access": access, "participant_param": participant_param, "completion_url": completion_url}


def is_loopback(host: str) -> bool:
    """True when ``host`` (an address or a name) reaches only this machine.

    Parameters
    ----------
    host : str
        An IP address (brackets allowed) or a host name, resolved with ``getaddrinfo``.

    Returns
    -------
    bool
        True when the address, or every address the name resolves to, is a loopback one;
        False when the name does not resolve.
    """
    host = str(host).strip("[]")
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        pass
    try:
        found = {info[4][0] for info in socket.getaddrinfo(host, None)}
    except OSError:
        return False
    return bool(found) and all(ipaddress.ip_address(a.split("%")[0]).is_loopback for a in found)


def check_serving(access: str, *, host: str, public_url: str | None = None) -> None:
    """Refuse to serve an open study where others can reach it.

    An open study has no authentication (anyone who reaches it votes under any name), so its
    server binds a loopback address and no public URL points to it.

    Parameters
    ----------
    access : str
        The study's access mode (``"open"``, ``"token"`` or ``"crowd"``); only ``"open"`` is
        checked.
    host : str
        The address the server binds.
    public_url : str or None
        The public URL that points to the server, if any.

    Raises
    ------
    InputError
        Naming ``host`` or ``public_url``.
    """
    if access != Access.OPEN:
        return
    hint = "(an open study has no sign-in: rebuild it as a token or crowd study to serve others)"
    if not is_loopback(host):
        raise InputError(param="host", expected=f"a loopback address such as 127.0.0.1 {hint}", got=host)
    if public_url is not None and not is_loopback(urlsplit(str(public_url)).hostname or ""):
        raise InputError(param="public_url", expected=f"no public address {hint}", got=public_url)


def _crowd_mac(secret: str, purpose: str, value: str) -> bytes:
    return hmac.new(str(secret).encode(), f"crowd|{purpose}|{value}".encode(), hashlib.sha256).digest()


def crowd_identity(secret: str, participant: str | None = None) -> tuple[str, str]:
    """``(rater id, token)`` of a crowd arrival.

    Without ``participant`` the rater id is a fresh random value; with it, an HMAC-SHA256 of
    the participant id under ``secret`` (the study's secret), so the same participant always
    gets the same identity. The token carries the rater id and an HMAC of it under
    ``secret`` (:func:`crowd_rater_for_token` checks it without the store), so an arrival
    needs nothing stored until its first vote (measured: 4,000 arrivals that never voted
    filled the store and the server's memory). The token cannot be computed without the
    secret, but the server hands it to anyone who arrives with that participant id: with
    ``participant``, the panel's participant id is the credential (keep it as private as the
    panel does), and arbitrary ids make new identities, as fresh arrivals without it do.

    Parameters
    ----------
    secret : str
        The study's secret, the HMAC key.
    participant : str or None
        The panel's participant id; None for a fresh random identity.

    Returns
    -------
    tuple of str
        ``crowd-`` + 16 hex digits (64 bits), and a URL-safe token of 32 characters (the
        rater id and a 128-bit HMAC).

    >>> a, b = crowd_identity("s", "p1"), crowd_identity("s", "p1")
    >>> a == b, a != crowd_identity("s", "p2"), a != crowd_identity("t", "p1")
    (True, True, True)
    >>> len(a[1]), a[0].startswith("crowd-"), crowd_rater_for_token("s", a[1]) == a[0]
    (32, True, True)
    """
    if participant is None:
        raw = secrets.token_bytes(8)
    else:
        raw = _crowd_mac(secret, "rater", participant)[:8]
    rater = CROWD_PREFIX + raw.hex()
    token = base64.urlsafe_b64encode(raw + _crowd_mac(secret, "token", rater)[:16]).decode()
    return rater, token


def crowd_rater_for_token(secret: str, token: str) -> str | None:
    """The crowd rater a token of :func:`crowd_identity` names, if its HMAC is right (compared
    in constant time), else None. Costs one HMAC, never a store lookup.

    Parameters
    ----------
    secret : str
        The study's secret, the HMAC key.
    token : str
        A token as :func:`crowd_identity` makes it (32 URL-safe base64 characters).

    Returns
    -------
    str or None
        The rater id (``crowd-`` + 16 hex digits), or None when the token is malformed or
        its HMAC does not match.

    >>> rater, token = crowd_identity("s")
    >>> crowd_rater_for_token("s", token) == rater, crowd_rater_for_token("t", token)
    (True, None)
    >>> crowd_rater_for_token("s", token[:-2] + "AA"), crowd_rater_for_token("s", "x" + chr(10))
    (None, None)
    """
    try:
        raw = base64.urlsafe_b64decode(str(token).encode("ascii"))
    except (ValueError, UnicodeEncodeError):
        return None
    if len(raw) != 24 or len(str(token)) != 32:
        return None
    rater = CROWD_PREFIX + raw[:8].hex()
    return rater if hmac.compare_digest(raw[8:], _crowd_mac(secret, "token", rater)[:16]) else None


class CrowdRefused(Exception):
    """A crowd arrival that gets no identity; the message is for the person arriving."""


#: What a crowd arrival at a study whose test items all have their votes is told.
MSG_FULL = ("This study is full: every image pair has all the answers it needs, so there is "
            "nothing left to rate. Thank you for your interest. Please return the study on "
            "your panel's page (no completion code is given).")
MSG_TOO_MANY = ("Too many new sign-ins from your network just now. Please wait a minute and "
                "open the link again.")


def check_participant(participant) -> str:
    """The panel's participant id if it is one the study accepts (1-64 of ``A-Z a-z 0-9
    _ . : @ -``, the whole value: no control character, no trailing newline), else
    :class:`CrowdRefused`.

    Parameters
    ----------
    participant : object
        The participant id from the arrival's URL query; converted with ``str``.

    Returns
    -------
    str
        The participant id, unchanged.

    Raises
    ------
    CrowdRefused
        When the id is not one the study accepts.

    >>> check_participant("5f1e@x")
    '5f1e@x'
    >>> try:
    ...     check_participant("5f1e" + chr(10))  # a trailing newline (%0A)
    ... except CrowdRefused as why:
    ...     print(str(why)[:30])
    This link is not valid: the pa
    """
    text = str(participant)
    if not _PARTICIPANT.fullmatch(text) or _CONTROL.search(text):
        raise CrowdRefused("This link is not valid: the participant id is not one the study "
                           "accepts. Please open the study from your panel's page.")
    return text


def crowd_arrival(study, query: dict, *, limiter=None, client: str = "") -> tuple[str, str, str | None]:
    """The crowd identity of an arrival with URL query ``query``: ``(rater id, token,
    participant id or None)``. Nothing is stored: the rater is registered at its first vote
    (:func:`register_crowd_rater`).

    Parameters
    ----------
    study : annotate.study.Study
    query : dict
        The arrival's URL query parameters.
    limiter : ArrivalLimiter, optional
        Tokenless arrivals allowed per client address (None: no limit).
    client : str
        The client's address (:func:`client_address`).

    Returns
    -------
    tuple
        Rater id, token, participant id (None without the study's participant parameter).

    Raises
    ------
    CrowdRefused
        The study wants a participant id and the URL has none, or not a valid one; the
        study is full; too many arrivals from ``client`` just now.
    """
    param = study.manifest.participant_param
    participant = None
    if param is not None:
        participant = query.get(param)
        if not participant:
            raise CrowdRefused("Please open this study from the link on your panel's page.")
        participant = check_participant(participant)
    rater, token = crowd_identity(study.admin_token(), participant)
    if participant is not None and study.store.plan(rater) is not None:
        return rater, token, participant  # a participant coming back: never refused
    if limiter is not None and not limiter.allow(client):
        raise CrowdRefused(MSG_TOO_MANY)
    if study.is_full():
        raise CrowdRefused(MSG_FULL)
    while participant is None and study.store.plan(rater) is not None:  # never a taken id
        rater, token = crowd_identity(study.admin_token())
    return rater, token, participant


def register_crowd_rater(study, rater: str, *, token: str, participant: str | None = None) -> None:
    """Store crowd rater ``rater`` (its plan, token digest and participant id), at its first
    vote; a no-op for a rater stored already.

    Parameters
    ----------
    study : annotate.study.Study
    rater, token : str
        From :func:`crowd_arrival`.
    participant : str, optional
        The panel's participant id.

    Returns
    -------
    None
    """
    study.store.add_rater(rater, plan=study.plan_for(rater, register=False), token=token)
    if participant is not None:
        study.store.record_participant(rater, participant)


class ArrivalLimiter:
    """New crowd identities per client address: at most ``burst`` at once, refilled at
    ``per_minute`` a minute (a token bucket per address; at most ``max_clients`` addresses
    remembered, the least recently seen forgotten first).

    Parameters
    ----------
    per_minute : float
        Arrivals a minute per address, in the long run (> 0).
    burst : int
        Arrivals an address may make at once (a shared network's few colleagues).
    max_clients : int
        Addresses remembered.

    >>> lim = ArrivalLimiter(per_minute=60, burst=2, clock=lambda: 0.0)
    >>> [lim.allow("a") for _ in range(3)], lim.allow("b")
    ([True, True, False], True)
    """

    def __init__(self, per_minute: float, burst: int = 10, max_clients: int = 10000, *, clock=None):
        self.rate = float(per_minute) / 60.0
        self.burst = float(burst)
        self.max_clients = int(max_clients)
        self._clock = clock or time.monotonic
        self._buckets: collections.OrderedDict[str, tuple[float, float]] = collections.OrderedDict()
        self._lock = threading.Lock()

    def allow(self, client: str) -> bool:
        """Whether one more arrival from ``client`` is allowed now (and count it if so).

        Parameters
        ----------
        client : str
            The client's address.

        Returns
        -------
        bool
        """
        now = self._clock()
        with self._lock:
            level, at = self._buckets.pop(client, (self.burst, now))
            level = min(self.burst, level + (now - at) * self.rate)
            ok = level >= 1.0
            self._buckets[client] = (level - 1.0 if ok else level, now)
            while len(self._buckets) > self.max_clients:
                self._buckets.popitem(last=False)
        return ok


_LIMITERS: dict[tuple[float, int], ArrivalLimiter] = {}
_LIMITERS_LOCK = threading.Lock()


def arrival_limiter(per_minute: float, *, burst: int = 10) -> ArrivalLimiter | None:
    """The process's :class:`ArrivalLimiter` for these settings (one per process, kept in
    this module: the app's script is executed again on every run); None when
    ``per_minute`` <= 0 (no limit).

    Parameters
    ----------
    per_minute : float
    burst : int

    Returns
    -------
    ArrivalLimiter or None
    """
    if per_minute <= 0:
        return None
    with _LIMITERS_LOCK:
        key = (float(per_minute), int(burst))
        found = _LIMITERS.get(key)
        if found is None:
            found = _LIMITERS[key] = ArrivalLimiter(per_minute=per_minute, burst=burst)
    return found


def client_address(ip: str | None, forwarded_for: str | None) -> str:
    """The address a rate limit counts an arrival under: the connection's address, or, for a
    connection from this machine (a reverse proxy on loopback, docs/guides/public-study.md),
    the last address of its ``X-Forwarded-For`` header (the one the proxy saw).

    Parameters
    ----------
    ip : str or None
        The connection's remote address, if known.
    forwarded_for : str or None
        The connection's ``X-Forwarded-For`` header, if any.

    Returns
    -------
    str
        The address, or ``"loopback"`` for a loopback connection without a forwarded address.

    >>> client_address("203.0.113.9", "10.0.0.1"), client_address(None, "1.2.3.4, 198.51.100.7")
    ('203.0.113.9', '198.51.100.7')
    >>> client_address("127.0.0.1", None)
    'loopback'
    """
    if isinstance(ip, str) and ip and not is_loopback(ip):
        return ip
    last = (forwarded_for or "").split(",")[-1].strip()
    return last or "loopback"
