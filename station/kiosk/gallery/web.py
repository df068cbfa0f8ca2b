"""The gallery's web app (Bottle): a painting's page under its own link, security
headers, QR codes and the addresses they point to."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from station.kiosk.gallery.replays import ReplayMaker
from station.kiosk.gallery.store import LINK_RE, LOG, META, PNG, PRINT, REPLAY, Gallery, check_id


# -- QR codes ----------------------------------------------------------------------
def qr_matrix(url: str, border: int = 4) -> np.ndarray:
    """The QR code of ``url`` as a uint8 array, 1 = dark module, with a quiet zone."""
    import segno

    qr = segno.make(url, error="m")
    return np.array([list(row) for row in qr.matrix_iter(scale=1, border=border)], np.uint8)


def default_base_url(port: int, host: str = "") -> str:
    """Where a phone reaches the gallery served on ``host:port``: that address when the
    operator named one; for a wildcard (``0.0.0.0``, ``::``, empty) ``http://<this
    machine's LAN address>:port``; loopback when there is no network."""
    if host and host not in ("0.0.0.0", "::", "[::]"):
        return f"http://{host}:{port}"
    addr = "127.0.0.1"
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("192.0.2.1", 9))  # TEST-NET: no packet is sent for a UDP connect
            addr = s.getsockname()[0]
    except OSError:
        pass
    return f"http://{addr}:{port}"


def painting_url(base_url: str, pid: str) -> str:
    return f"{base_url.rstrip('/')}/p/{check_id(pid)}"



# -- the web page ---------------------------------------------------------------------
@dataclass(frozen=True)
class WebOptions:
    """What the gallery's web server shows and how much it takes from one client.

    The defaults suit a public network (a museum's visitor Wi-Fi): paintings only
    through their own links, no index, no session logs.  The limits: a client (one
    IP address) holds at most ``per_client`` connections; a request must arrive
    whole within ``request_timeout_s`` of its first byte (slowloris); an idle
    keep-alive connection is closed after ``idle_timeout_s``; ``threads`` requests
    are served at once (every handler answers at once: replays are made by a worker
    of their own), ``connection_limit`` connections at all.
    """

    index: bool = False  # "/" lists every painting (an operator's option)
    session_logs: bool = False  # serve each painting's session log and metadata
    keep_days: float | None = None  # delete paintings saved more than this many days ago
    per_client: int = 8
    request_timeout_s: float = 10.0
    idle_timeout_s: float = 15.0
    threads: int = 4
    connection_limit: int = 100
    replay_queue: int = 8


SECURITY_HEADERS = (
    # nothing but this page's own images and inline style; no scripts, no frames, no forms
    ("Content-Security-Policy", "default-src 'none'; img-src 'self'; style-src 'unsafe-inline'; "
                                "base-uri 'none'; form-action 'none'; frame-ancestors 'none'"),
    ("X-Frame-Options", "DENY"),
    ("X-Content-Type-Options", "nosniff"),
    # a painting's address is its key: never hand it to another site
    ("Referrer-Policy", "no-referrer"),
    ("Cross-Origin-Resource-Policy", "same-origin"),
    ("Cache-Control", "private, max-age=300"),
)


def secure_headers(app: Callable[..., Any]) -> Callable[..., Any]:
    """WSGI middleware: :data:`SECURITY_HEADERS` on every response the app makes
    (its errors included), replacing any the app set."""
    names = {k.lower() for k, _ in SECURITY_HEADERS}

    def wrapped(environ: dict[str, Any], start_response: Callable[..., Any]) -> Any:
        def start(status: str, headers: list[tuple[str, str]], exc_info: Any = None) -> Any:
            headers = [(k, v) for k, v in headers if k.lower() not in names]
            return start_response(status, headers + list(SECURITY_HEADERS), exc_info)

        return app(environ, start)

    return wrapped


PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="referrer" content="no-referrer">
<title>{{title}}</title>
<style>
body { font-family: sans-serif; background: #f4f1ea; color: #222; margin: 0; padding: 16px; }
h1 { font-size: 1.4em; margin: 0 0 12px 0; }
figure { margin: 0; }
img.canvas { display: block; width: 100%; height: auto; background: white;
             box-shadow: 0 2px 8px #0004; }
.meta { font-size: 0.9em; color: #555; }
a.button { display: inline-block; padding: 10px 14px; margin: 4px 0; background: #2d5d8a;
           color: white; text-decoration: none; border-radius: 6px; }
ul.thumbs { list-style: none; padding: 0; display: flex; flex-wrap: wrap; gap: 12px; }
ul.thumbs img { width: 200px; height: auto; box-shadow: 0 1px 4px #0004; }
</style></head><body>
{{!body}}
</body></html>
"""

# The painting at its own size, never wider than the screen, its aspect kept at any
# width (width and height attributes give the browser the ratio before it loads).
PAINTING = """<h1>Your painting</h1>
<figure style="max-width: {{w}}px">
<img class="canvas" id="painting" src="{{png}}" width="{{w}}" height="{{h}}"
 style="aspect-ratio: {{w}} / {{h}}" alt="the painting">
</figure>
<p>
% if print_png:
<a class="button" id="print" href="{{print_png}}" download="painting-{{stamp}}-2x.png">Download
 the painting ({{2 * w}}×{{2 * h}} px)</a>
% end
<a class="button" href="{{png}}" download="painting-{{stamp}}.png">Screen size
 ({{w}}×{{h}} px)</a></p>
% if replay:
<p><a href="{{replay}}">Watch it being painted</a></p>
% end
% if log:
<p><a href="{{log}}">session log</a></p>
% end
<p class="meta">{{when}} · {{w}}×{{h}} · {{profile}}</p>
% if index:
<p><a href="/">All paintings</a></p>
% end
"""

INDEX = """<h1>Gallery</h1>
<ul class="thumbs">
% for pid in ids:
<li><a href="p/{{pid}}"><img src="p/{{pid}}/painting.png" alt="painting {{pid}}"></a></li>
% end
</ul>
"""

MIMES = {PNG: "image/png", PRINT: "image/png", REPLAY: "image/webp",
         LOG: "application/x-ndjson", META: "application/json"}


def make_app(gallery: Gallery, base_url: str | None = None,
             options: WebOptions | None = None,
             replays: ReplayMaker | None = None) -> Any:
    """The gallery's WSGI app (Bottle, wrapped in :func:`secure_headers`).

    A painting is served only under its own link (``/p/<id>``, :data:`LINK_RE`:
    128 random bits); ``/`` lists them only with ``options.index``; the session log
    and metadata only with ``options.session_logs``.  The replay and the 2× print
    are made on first request by ``replays`` (503 with Retry-After meanwhile).
    ``base_url`` is kept for callers that name the address links point to; the
    page itself carries only relative links.
    """
    import bottle

    opts = options or WebOptions()
    maker = replays or ReplayMaker(gallery, opts.replay_queue)
    app = bottle.Bottle()
    app.config["gallery.base_url"] = base_url
    served = {PNG, PRINT, REPLAY} | ({LOG, META} if opts.session_logs else set())

    def page(title: str, body: str) -> str:
        return str(bottle.template(PAGE, title=title, body=body))

    def checked(pid: str) -> str:
        if not LINK_RE.match(pid) or not gallery.path(pid, PNG).exists():
            bottle.abort(404, "no such painting")
        return pid

    @app.get("/")
    def index() -> str:
        if not opts.index:
            bottle.abort(404, "no index here: a painting is reached through its own link")
        return page("Gallery", bottle.template(
            INDEX, ids=[p for p in gallery.ids() if LINK_RE.match(p)]))

    @app.get("/p/<pid>")
    def painting(pid: str) -> str:
        checked(pid)
        meta = gallery.meta(pid) or {}

        def size(key: str) -> int:
            v = meta.get(key)
            return int(v) if isinstance(v, int) and 0 < v < 1_000_000 else 0

        w, h = size("width"), size("height")
        if not (w and h):  # no usable metadata: the PNG's own size
            from PIL import Image

            with Image.open(gallery.path(pid, PNG)) as im:
                w, h = im.size
        saved = meta.get("saved")
        saved = float(saved) if isinstance(saved, (int, float)) and np.isfinite(saved) else 0.0
        when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(saved))
        # the replay and the print exist, or can still be made from the session log
        makeable = gallery.path(pid, LOG).exists() and gallery.failed(pid) is None
        body = bottle.template(
            PAINTING, png=f"/p/{pid}/{PNG}",
            print_png=f"/p/{pid}/{PRINT}" if makeable or gallery.path(pid, PRINT).exists()
            else "",
            replay=f"/p/{pid}/{REPLAY}" if makeable or gallery.path(pid, REPLAY).exists()
            else "",
            log=f"/p/{pid}/{LOG}" if opts.session_logs else "", w=w, h=h,
            stamp=pid[:15], when=when, profile=str(meta.get("profile", ""))[:40],
            index=opts.index)
        return page("Your painting", body)

    @app.get("/p/<pid>/<name>")
    def files(pid: str, name: str) -> Any:
        checked(pid)
        if name not in served:
            bottle.abort(404, "no such file")
        if name in (REPLAY, PRINT):
            state = maker.state(pid, name)
            if state == "failed":
                # why stays in the gallery (make.log, replay.failed): it names paths
                bottle.abort(404, "this painting's replay cannot be made")
            if state in ("pending", "busy"):
                raise bottle.HTTPError(503, "being made: try again in a minute",
                                       **{"Retry-After": "15"})
        return bottle.static_file(name, root=str(gallery.path(pid)), mimetype=MIMES[name])

    app.config["gallery.replays"] = maker
    return secure_headers(app)

