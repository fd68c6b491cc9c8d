"""An attacker's upload to ``/_stcore/upload_file/SESSION/FILE`` of a served rater app (issue 38,
item 28): a websocket session without sign-in, the XSRF cookie of the page, then PUTs."""

from __future__ import annotations

import asyncio
import http.client
import uuid
from urllib.parse import urlsplit

__all__ = ["session_id", "xsrf_cookie", "put_upload", "rss_mb"]


def xsrf_cookie(base: str, *, context=None) -> tuple[str, str]:
    """(cookie header to send back, XSRF token) as the app's page hands them to any visitor."""
    u = urlsplit(base)
    con = (http.client.HTTPSConnection(u.hostname, u.port, context=context, timeout=30)
           if u.scheme == "https" else http.client.HTTPConnection(u.hostname, u.port, timeout=30))
    con.request("GET", "/_stcore/health")  # the health check sets the XSRF cookie
    resp = con.getresponse()
    resp.read()
    cookies = [v.split(";", 1)[0] for k, v in resp.getheaders() if k.lower() == "set-cookie"]
    con.close()
    token = next((c.split("=", 1)[1] for c in cookies if c.startswith("_streamlit_xsrf=")), "")
    return "; ".join(cookies), token


async def _session_id(ws_url: str, ssl=None) -> tuple[object, str]:
    import websockets
    from streamlit.proto.BackMsg_pb2 import BackMsg
    from streamlit.proto.ForwardMsg_pb2 import ForwardMsg

    ws = await websockets.connect(ws_url, subprotocols=["streamlit"], max_size=None,
                                  open_timeout=60, ssl=ssl)
    msg = BackMsg()
    msg.rerun_script.query_string = ""
    await ws.send(msg.SerializeToString())
    while True:
        fm = ForwardMsg()
        fm.ParseFromString(await asyncio.wait_for(ws.recv(), timeout=60))
        if fm.WhichOneof("type") == "new_session":
            return ws, fm.new_session.initialize.session_id


def session_id(base: str, *, ssl=None):
    """Open a bare websocket session (no sign-in); (loop, websocket, its session id)."""
    scheme = "wss" if base.startswith("https") else "ws"
    ws_url = scheme + ":" + base.split(":", 1)[1].rstrip("/") + "/_stcore/stream"
    loop = asyncio.new_event_loop()
    ws, sid = loop.run_until_complete(_session_id(ws_url, ssl))
    return loop, ws, sid


def put_upload(base: str, sid: str, size: int, *, cookie: str, xsrf: str, context=None,
               chunked: bool = False, name_len: int = 5) -> int:
    """PUT one multipart file of ``size`` bytes as the file uploader would; the HTTP status.

    ``chunked``: without a Content-Length (the body's size hidden); ``name_len``: the length
    of the file name (a long name is stored with an empty file)."""
    u = urlsplit(base)
    boundary = uuid.uuid4().hex
    name = ("a" * max(name_len - 4, 1)) + ".bin"
    body = (f"--{boundary}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"{name}\"\r\n"
            f"Content-Type: application/octet-stream\r\n\r\n").encode() + b"\0" * size + \
        f"\r\n--{boundary}--\r\n".encode()
    con = (http.client.HTTPSConnection(u.hostname, u.port, context=context, timeout=60)
           if u.scheme == "https" else http.client.HTTPConnection(u.hostname, u.port, timeout=60))
    try:
        con.request("PUT", f"/_stcore/upload_file/{sid}/{uuid.uuid4()}",
                    body=iter([body[i:i + 65536] for i in range(0, len(body), 65536)]) if chunked
                    else body, encode_chunked=chunked, headers={
                        "Content-Type": f"multipart/form-data; boundary={boundary}",
                        "Cookie": cookie, "X-Xsrftoken": xsrf})
        resp = con.getresponse()
        resp.read()
        return resp.status
    except (ConnectionError, http.client.HTTPException):  # refused mid-body: not stored
        return 0
    finally:
        con.close()


def rss_mb(pid: int) -> float:
    """Resident memory of process ``pid`` in MB (Linux /proc)."""
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")
