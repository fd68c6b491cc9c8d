"""Who may rate: the three access modes of a study and the identities they give raters.

- ``open``: a rater is ``?rater=NAME`` (or a name typed in); there is no authentication, so
  an open study is served on a loopback address only (:func:`check_serving`);
- ``token``: per-rater links ``?token=TOKEN`` made by ``annotate add-rater``;
- ``crowd``: every arrival gets a fresh server-issued identity, a 144-bit token carried in
  the URL the app rewrites the address to (``?token=TOKEN``), so a reload resumes. With a
  ``participant_param`` (e.g. Prolific's ``PROLIFIC_PID``) the panel's participant id is
  recorded and gives one identity per participant: the token and rater id are HMACs of the
  id under the study's secret, so a participant who comes back through the panel's link is
  the same rater; an arrival without the parameter is refused. ``completion_url`` is shown
  to the rater who finishes.

Tokens of both token and crowd studies are stored as SHA-256 digests and compared in constant
time (:meth:`annotate.store.Store.rater_for_token`); a token or rater id is random or an HMAC,
never derived from items.

>>> check_access("crowd", participant_param="PROLIFIC_PID",
...              completion_url="https://app.prolific.com/submissions/complete?cc=C1")
{'access': 'crowd', 'participant_param': 'PROLIFIC_PID', 'completion_url': 'https://app.prolific.com/submissions/complete?cc=C1'}
>>> is_loopback("127.0.0.1"), is_loopback("::1"), is_loopback("0.0.0.0"), is_loopback("localhost")
(True, True, False, True)
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import ipaddress
import re
import secrets
import socket
from urllib.parse import urlsplit

from data_schema.errors import InputError

__all__ = ["ACCESS_MODES", "CROWD_PREFIX", "check_access", "is_loopback", "check_serving",
           "crowd_identity", "crowd_arrival", "CrowdRefused"]

#: The access modes of a study (manifest ``access``).
ACCESS_MODES = ("open", "token", "crowd")
#: Rater ids of crowd identities start with this.
CROWD_PREFIX = "crowd-"
#: Query parameters the app itself reads; a panel's participant parameter must differ.
_APP_PARAMS = {"token", "rater", "admin"}
_PARAM = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]{0,63}$")
_PARTICIPANT = re.compile(r"^[A-Za-z0-9_.:@-]{1,64}$")


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
        if value is not None and access != "crowd":
            raise InputError(param=name, expected="no value unless `access` is crowd", got=value)
    if access != "crowd":
        return {"access": access}
    if participant_param is not None and (not _PARAM.match(str(participant_param))
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
    """True when ``host`` (an address or a name) reaches only this machine."""
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

    Raises
    ------
    InputError
        Naming ``host`` or ``public_url``.
    """
    if access != "open":
        return
    hint = "(an open study has no sign-in: rebuild it as a token or crowd study to serve others)"
    if not is_loopback(host):
        raise InputError(param="host", expected=f"a loopback address such as 127.0.0.1 {hint}", got=host)
    if public_url is not None and not is_loopback(urlsplit(str(public_url)).hostname or ""):
        raise InputError(param="public_url", expected=f"no public address {hint}", got=public_url)


def crowd_identity(secret: str, participant: str | None = None) -> tuple[str, str]:
    """``(rater id, token)`` of a crowd arrival.

    Without ``participant`` both are fresh random values; with it, both are HMAC-SHA256 of
    the participant id under ``secret`` (the study's secret), so the same participant always
    gets the same identity. The token cannot be computed without the secret, but the server
    hands it to anyone who arrives with that participant id: with ``participant``, the panel's
    participant id is the credential (keep it as private as the panel does), and arbitrary ids
    make new identities, as fresh arrivals without it do.

    Returns
    -------
    tuple of str
        ``crowd-`` + 16 hex digits (64 bits), and a 144-bit URL-safe token (24 characters).

    >>> a, b = crowd_identity("s", "p1"), crowd_identity("s", "p1")
    >>> a == b, a != crowd_identity("s", "p2"), a != crowd_identity("t", "p1")
    (True, True, True)
    >>> len(a[1]), a[0].startswith("crowd-")
    (24, True)
    """
    if participant is None:
        return CROWD_PREFIX + secrets.token_hex(8), secrets.token_urlsafe(18)

    def mac(purpose: str) -> bytes:
        return hmac.new(str(secret).encode(), f"crowd|{purpose}|{participant}".encode(),
                        hashlib.sha256).digest()

    token = base64.urlsafe_b64encode(mac("token")[:18]).decode()
    return CROWD_PREFIX + mac("rater")[:8].hex(), token


class CrowdRefused(Exception):
    """A crowd arrival that gets no identity; the message is for the person arriving."""


def crowd_arrival(study, query: dict) -> tuple[str, str]:
    """Give the arrival with URL query ``query`` its crowd identity; ``(rater id, token)``.

    Registers the rater (with its plan and token digest) on first arrival; with the study's
    participant parameter, records the participant id.

    Raises
    ------
    CrowdRefused
        The study wants a participant id and the URL has none, or not a valid one.
    """
    param = study.manifest.get("participant_param")
    participant = None
    if param is not None:
        participant = query.get(param)
        if not participant:
            raise CrowdRefused("Please open this study from the link on your panel's page.")
        if not _PARTICIPANT.match(str(participant)):
            raise CrowdRefused("This link is not valid: the participant id is not one the study "
                               "accepts. Please open the study from your panel's page.")
    rater, token = crowd_identity(study.admin_token(), participant)
    while participant is None and study.store.plan(rater) is not None:  # a fresh one, never a taken id
        rater, token = crowd_identity(study.admin_token())
    study.store.add_rater(rater, plan=study.new_plan(rater), token=token)  # the same again: a no-op
    if participant is not None:
        study.store.record_participant(rater, participant)
    return rater, token
