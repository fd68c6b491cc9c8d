"""Access modes (annotate/access.py): crowd identities in the app, open studies kept on
loopback, and the links the commands print (issue 30, findings 1 and 4).

Expected values come from the definitions: a token's digest is SHA-256 of the token
(hashlib), an identity has >= 128 bits (the token's URL-safe base64 length x 6), and the
admin token is the one in the study's secrets.json.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
from streamlit.testing.v1 import AppTest

import annotate
from annotate.access import check_access, check_serving, crowd_identity, is_loopback
from data_schema.errors import InputError

APP = str(Path(annotate.__file__).with_name("app.py"))
PROLIFIC = "https://app.prolific.com/submissions/complete?cc=C0DE1"
SECRETS = ("toy", "trk-", "+1.00", "-1.00", "offset", "front", "gold", "repeat", "training")


@pytest.fixture(autouse=True)
def _instant_presses(monkeypatch):
    """AppTest presses a moment after drawing; the double-press guard would drop them."""
    monkeypatch.setenv("ANNOTATE_MIN_RESPONSE_MS", "0")


def _served(make_study, monkeypatch, **kw):
    s = make_study(**kw)
    monkeypatch.setenv("ANNOTATE_STUDY", str(s.root))
    return s


def _app(**query) -> AppTest:
    at = AppTest.from_file(APP, default_timeout=20)
    at.query_params.update(query)
    return at.run()


def _vote_all(at: AppTest) -> int:
    """Press Start, then Good on every item until done; the number of votes."""
    at.button(key="start").click().run()
    n = 0
    while True:
        good = [b for b in at.button if b.key and b.key.startswith("vote_good-")]
        if not good:
            return n
        good[0].click().run()
        n += 1


def test_crowd_arrival_gets_a_fresh_hashed_identity_in_its_url(make_study, monkeypatch):
    s = _served(make_study, monkeypatch, access="crowd")
    a, b = _app(), _app()
    ta, tb = a.query_params["token"], b.query_params["token"]
    ra, rb = a.session_state["rater"], b.session_state["rater"]
    assert ta != tb and ra != rb and ra.startswith("crowd-")
    assert len(ta) * 6 >= 128  # URL-safe base64: 6 bits per character
    assert a.button(key="start")  # straight to the instructions, no name asked
    assert s.store.raters() == []  # nothing stored before the first vote (issue 38, item 29)
    a.button(key="start").click().run()
    next(b for b in a.button if b.key and b.key.startswith("vote_good-")).click().run()
    # stored at the first vote, as SHA-256 only: the token itself is nowhere in the store
    with sqlite3.connect(s.root / "votes.sqlite") as con:
        rows = dict(con.execute("SELECT rater, token_sha256 FROM raters").fetchall())
    assert rows[ra] == hashlib.sha256(ta.encode()).hexdigest()
    dump = b"".join(p.read_bytes() for p in s.root.glob("votes.sqlite*"))
    assert ta.encode() not in dump
    for secret in SECRETS:
        assert secret not in ta + ra
    # a reload (a new session with the rewritten URL) is the same rater
    again = _app(token=ta)
    assert again.session_state["rater"] == ra and again.query_params["token"] == ta
    # a name in the URL does not pick an identity on a crowd study
    assert _app(rater="mallory").session_state["rater"] != "mallory"
    assert "mallory" not in s.store.raters()


def test_crowd_participant_param_gives_one_identity_per_participant(make_study, monkeypatch):
    s = _served(make_study, monkeypatch, access="crowd", participant_param="PROLIFIC_PID",
                completion_url=PROLIFIC)
    p1 = _app(PROLIFIC_PID="5f3a0c0ffee0000000000001", STUDY_ID="s1", SESSION_ID="x1")
    p1b = _app(PROLIFIC_PID="5f3a0c0ffee0000000000001", STUDY_ID="s1", SESSION_ID="x2")
    p2 = _app(PROLIFIC_PID="5f3a0c0ffee0000000000002")
    assert p1.session_state["rater"] == p1b.session_state["rater"] != p2.session_state["rater"]
    assert p1.query_params["token"] == p1b.query_params["token"] != p2.query_params["token"]
    # the address carries the identity and the panel's id (issue 38: nothing is stored before
    # the first vote, so a reload before it must still say whose id this is), nothing else
    assert set(p1.query_params) == {"token", "PROLIFIC_PID"}
    assert s.store.participants().empty and s.store.raters() == []
    for at in (p1, p2):  # each votes once: now both are stored with their panel ids
        at.button(key="start").click().run()
        next(b for b in at.button if b.key and b.key.startswith("vote_good-")).click().run()
    got = s.store.participants().set_index("participant")["rater"].to_dict()
    assert got == {"5f3a0c0ffee0000000000001": p1.session_state["rater"],
                   "5f3a0c0ffee0000000000002": p2.session_state["rater"]}
    # without the panel's parameter, or with a malformed one: no identity
    for query in ({}, {"PROLIFIC_PID": "<script>"}):
        at = _app(**query)
        assert "rater" not in at.session_state and "token" not in at.query_params
        assert at.info and "panel" in at.info[0].value
    assert len(s.store.raters()) == 2
    # the participant finishes: the completion URL is offered
    while good := [b for b in p1.button if b.key and b.key.startswith("vote_good-")]:
        good[0].click().run()  # (Start and the first vote were pressed above)
    # every item but the pool's gold not drawn for this rater (issue 38 item 31)
    shown = len(s.items) - len(s.keys("gold")) + s.gold_per_rater
    assert len(s.store.votes(p1.session_state["rater"])) == shown
    link = [b for b in p1.get("link_button") if b.proto.id and "completion" in b.proto.id]
    assert link and link[0].proto.url == PROLIFIC
    # the export maps the crowd raters of ratings.csv to the panel's participant ids
    import pandas as pd

    from annotate.cli import main

    out, who = s.root.parent / "ratings.csv", s.root.parent / "participants.csv"
    assert main(["export", str(s.root), "--out", str(out), "--participants", str(who.with_suffix(".txt"))]) == 2
    assert not out.exists()  # refused before anything is written
    assert main(["export", str(s.root), "--out", str(out), "--participants", str(who)]) == 0
    table = pd.read_csv(who, dtype=str)
    assert table.columns.tolist() == ["rater_id", "participant", "arrived_at"]
    assert dict(zip(table["participant"], table["rater_id"], strict=True)) == got
    assert set(pd.read_csv(out)["rater_id"]) == set(got.values())  # both voted (p2 once)


def test_check_access_names_the_bad_parameter():
    cases = [({"access": "public"}, "access"),
             ({"access": "token", "participant_param": "PROLIFIC_PID"}, "participant_param"),
             ({"access": "open", "completion_url": PROLIFIC}, "completion_url"),
             ({"access": "crowd", "participant_param": "token"}, "participant_param"),
             ({"access": "crowd", "participant_param": "a b"}, "participant_param"),
             ({"access": "crowd", "completion_url": "javascript:alert(1)"}, "completion_url"),
             ({"access": "crowd", "completion_url": "/done"}, "completion_url")]
    for kw, param in cases:
        with pytest.raises(InputError) as err:
            check_access(kw.pop("access"), **kw)
        assert err.value.param == param, kw


def test_open_study_is_served_on_loopback_only():
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.0.2.7") and not is_loopback("::")
    check_serving("open", host="127.0.0.1")
    check_serving("open", host="localhost", public_url="http://localhost:8501/")
    for kw, param in (({"host": "0.0.0.0"}, "host"), ({"host": "192.0.2.7"}, "host"),
                      ({"host": "127.0.0.1", "public_url": "https://study.example.org/"}, "public_url")):
        with pytest.raises(InputError) as err:
            check_serving("open", **kw)
        assert err.value.param == param
    for access in ("token", "crowd"):
        check_serving(access, host="0.0.0.0", public_url="https://study.example.org/")


def test_crowd_identity_is_an_hmac_of_the_participant():
    import base64
    import hmac

    rater, token = crowd_identity("k", "P1")
    # by hand: the rater id is HMAC-SHA256(secret, "crowd|rater|P1")'s first 8 bytes; the token
    # is those 8 bytes and the first 16 of HMAC-SHA256(secret, "crowd|token|" + rater id),
    # URL-safe base64 (issue 38: checked without the store, 128-bit MAC)
    raw = hmac.new(b"k", b"crowd|rater|P1", hashlib.sha256).digest()[:8]
    assert rater == "crowd-" + raw.hex()
    mac = hmac.new(b"k", f"crowd|token|{rater}".encode(), hashlib.sha256).digest()[:16]
    assert token == base64.urlsafe_b64encode(raw + mac).decode() and len(token) == 32
    assert crowd_identity("k") != crowd_identity("k")  # no participant: fresh each time


# ---- the commands: refusal, printed links ---------------------------------------------------
def _cli(*argv, timeout=60):
    """``annotate ARGV`` in its own process group (a server that starts is killed)."""
    proc = subprocess.Popen([sys.executable, "-m", "annotate.cli", *map(str, argv)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        return None, out, err
    return proc.returncode, out, err


def test_serve_refuses_an_open_study_on_a_public_host_in_one_line(make_study):
    s = make_study()
    for extra in (["--host", "0.0.0.0"], ["--public-url", "https://study.example.org/"]):
        rc, _, err = _cli("serve", s.root, "--port", "1", *extra, timeout=30)
        lines = err.strip().splitlines()
        assert rc == 2 and len(lines) == 1, (extra, rc, err)
        assert extra[0] in lines[0] and ("loopback" in lines[0] or "public address" in lines[0]), lines
        assert "Traceback" not in err


def test_add_rater_links_use_a_real_host_or_the_public_url(make_study):
    import socket

    s = make_study(access="token")
    rc, out, _ = _cli("add-rater", s.root, "ann", "--host", "0.0.0.0", "--port", "8600")
    assert rc == 0 and out.startswith(f"http://{socket.getfqdn()}:8600/?token="), out
    rc, out, _ = _cli("add-rater", s.root, "bea", "--public-url", "https://study.example.org/x")
    assert rc == 0 and out.startswith("https://study.example.org/x/?token="), out
    rc, out, err = _cli("add-rater", make_study().root, "cy", "--host", "0.0.0.0")
    assert rc == 2 and "--host" in err, err  # an open study's link would be refused by serve


def _serve_says(root, *extra, until: str) -> str:
    """What ``annotate serve ROOT EXTRA`` prints on stderr up to its first line holding ``until``."""
    from tests.e2e.browser_support import free_port

    proc = subprocess.Popen([sys.executable, "-m", "annotate.cli", "serve", str(root), "--port",
                             str(free_port()), *extra], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        lines, deadline = [], time.time() + 60
        while not any(until in x for x in lines):
            assert time.time() < deadline and proc.poll() is None, lines
            lines.append(proc.stderr.readline())
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        proc.stderr.close()
    return "".join(lines)


def test_serve_does_not_print_the_admin_token(make_study):
    s = make_study()
    text = _serve_says(s.root, until="admin")
    assert s.admin_token() not in text and str(s.root / "secrets.json") in text
    assert "http://127.0.0.1:" in text  # the real host and port


def test_build_prints_the_admin_token_once_and_serve_points_to_the_secrets_file(toy_inputs, tmp_path):
    scene, pairs = toy_inputs
    root = tmp_path / "study"
    rc, out, err = _cli("build", root, "--pairs", pairs, "--scene", scene, "--tracks", "1",
                        "--frames-per-track", "1", "--training", "1", "--gold", "1", "--repeats", "1",
                        "--size", "48", "--access", "crowd", "--participant-param", "PROLIFIC_PID",
                        "--completion-url", PROLIFIC, "--public-url", "https://study.example.org",
                        timeout=120)
    admin = json.loads((root / "secrets.json").read_text())["admin_token"]
    assert rc == 0, err
    assert f"https://study.example.org/?admin={admin}" in out
    # serve: the public base in every link, the secrets file named, the token never printed
    text = _serve_says(root, "--public-url", "https://study.example.org/", until="finished raters")
    assert admin not in text
    assert "admin page: https://study.example.org/?admin=" in text and str(root / "secrets.json") in text
    assert "participants' link: https://study.example.org/?PROLIFIC_PID=" in text
    assert PROLIFIC in text


def test_crowd_arrival_when_the_store_fails_says_so_and_registers_nobody(make_study, monkeypatch):
    from annotate.store import Store

    s = _served(make_study, monkeypatch, access="crowd")

    def locked(*args, **kwargs):
        raise sqlite3.OperationalError("database is locked")

    monkeypatch.setattr(Store, "add_rater", locked)
    monkeypatch.setattr(Store, "item_loads", locked)  # an arrival reads (is the study full?)
    at = _app()
    assert "rater" not in at.session_state and "token" not in at.query_params
    assert at.info and "not available" in at.info[0].value
    monkeypatch.undo()
    assert s.store.raters() == []
