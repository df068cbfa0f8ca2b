"""Every response the gallery sends carries the security headers (issue 25 item 1),
including those waitress makes itself for requests it cannot parse: raw malformed
requests over a socket."""

from __future__ import annotations

import socket
from pathlib import Path

from station.kiosk.gallery import SECURITY_HEADERS, Gallery, GalleryServer

RAW = {
    "malformed request line": (b"GARBAGE\r\n\r\n", 400),
    "oversized headers": (b"GET / HTTP/1.1\r\nHost: x\r\nX-Pad: " + b"a" * 9000 + b"\r\n\r\n",
                          431),
    "bad chunking": (b"POST /p/x HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
                     b"zz\r\nhello\r\n0\r\n\r\n", 400),
    "body too long": (b"POST /p/x HTTP/1.1\r\nHost: x\r\nContent-Length: 5000\r\n\r\n"
                      + b"a" * 5000, 413),
    "bad header": (b"GET / HTTP/1.1\r\nHost: x\r\nno colon here\r\n\r\n", 400),
}


def _raw(port: int, data: bytes) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=20) as s:
        s.sendall(data)
        out = b""
        while b"\r\n\r\n" not in out:
            chunk = s.recv(65536)
            if not chunk:
                break
            out += chunk
    return out


def test_waitress_own_error_responses_carry_the_security_headers(tmp_path: Path) -> None:
    server = GalleryServer(Gallery(tmp_path / "g"), "127.0.0.1", 0).start()
    try:
        heads = {case: _raw(server.port, data).split(b"\r\n\r\n", 1)[0].decode("latin-1")
                 for case, (data, _) in RAW.items()}
    finally:
        server.stop()
    for case, head in heads.items():
        _check(case, head, RAW[case][1])


def _check(case: str, head: str, status: int) -> None:
    lines = head.split("\r\n")
    # HTTP/1.0 where waitress could not read the request's version
    assert lines[0].split()[:2] in (["HTTP/1.1", str(status)], ["HTTP/1.0", str(status)]), (
        case, head)
    headers = {k.strip().lower(): v.strip() for k, _, v in
               (ln.partition(":") for ln in lines[1:])}
    for name, value in SECURITY_HEADERS:
        assert headers.get(name.lower()) == value, (case, name, head)
    assert sum(ln.lower().startswith("content-security-policy:") for ln in lines) == 1
