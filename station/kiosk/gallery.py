"""The gallery: finished paintings on disk, a web page each, QR codes, replays.

On disk, one directory per painting under the gallery root::

    <root>/<id>/painting.png    the canvas (sRGB PNG)
    <root>/<id>/session.jsonl   the session log (replays the painting exactly)
    <root>/<id>/meta.json       id, times, size, profile, backend, counts, why saved
    <root>/<id>/replay.webp     the creation replayed from the log
    <root>/<id>/painting-2x.png the painting at 2 px per cell (sub-cell render: a print)
    <root>/<id>/make.log        what the process making those two said

The replay and the print come from one replay of the session log, made by
``station gallery make`` in a process of its own at the lowest CPU priority
(:meth:`Gallery.prepare`, started by the kiosk when it saves a painting): the
replay simulates the whole painting again, which inside the kiosk's process
would take the cores and the interpreter lock from the next visitor's
strokes.  A replay asked for before it is made is made then, by the same
command.

The web stack is Bottle (one-module WSGI framework: routing, escaping
templates, static files with ETag/Range) served by Waitress (a pure-Python
production WSGI server) with the limits it lacks added (:class:`WebOptions`:
connections per client, a whole-request deadline).  The page is meant for a
public network: served on loopback unless the operator names an address; a
painting only through its own link, whose id carries 128 random bits
(:data:`LINK_RE`); no index and no session logs unless enabled; security
headers on every response (:func:`secure_headers`).  The page shows the
painting at its aspect at any width and offers the 2× print as a download; it
carries no QR code (the kiosk shows that, pointing here).  Replays asked for
before they exist are made by :class:`ReplayMaker` (one worker, a bounded
queue, a negative cache), never by the request itself.

Ids are checked against :data:`ID_RE` before they touch the file system, so
no URL reaches outside the gallery root.  Paintings are written 0700/0600 like
the session logs; :meth:`Gallery.expire` deletes those older than the
operator's retention setting.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import queue
import re
import secrets
import shutil
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from station.backends.factory import make_backend
from station.canvas.palette import default_palette
from station.canvas.profiles import get_profile
from station.errors import BadInput, StationError
from station.events import Command
from station.render.km import to_srgb8
from station.render.upscale import render_scaled
from station.sessionlog import read_session
from station.sim.player import SessionPlayer

# A painting's id is its directory's name and its link: UTC time and 128 random bits,
# so its address is its key (nobody finds a painting they were not given).  Ids of
# older galleries (24 random bits) still name their directories but are not served.
ID_RE = re.compile(r"^[0-9]{8}-[0-9]{6}-(?:[0-9a-f]{6}|[0-9a-f]{32})$")
LINK_RE = re.compile(r"^[0-9]{8}-[0-9]{6}-[0-9a-f]{32}$")
LINK_BITS = 128
PNG, LOG, META, REPLAY = "painting.png", "session.jsonl", "meta.json", "replay.webp"
PRINT = "painting-2x.png"
MAKE_LOG = "make.log"  # what `station gallery make` said (empty when all went well)
FAILED = "replay.failed"  # the replay cannot be made: why (the negative cache)
PRINT_SCALE = 2
MAKE_TIMEOUT_S = 600.0  # a replay asked for by the web page waits at most this long


class GalleryError(StationError):
    """The gallery directory cannot be used."""


def new_id(now: float | None = None) -> str:
    """A painting id: UTC time (sortable) and 128 random bits (its link cannot be
    guessed: the only way to a painting is to be given its address)."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime(time.time() if now is None else now))
    return f"{stamp}-{secrets.token_hex(LINK_BITS // 8)}"


def check_id(pid: str) -> str:
    if not isinstance(pid, str) or not ID_RE.match(pid):
        raise BadInput(f"painting id {str(pid)[:80]!r} is not of the form "
                       "YYYYMMDD-HHMMSS-<32 hex digits>")
    return pid


def _write_private(path: Path, data: bytes) -> None:
    """Write ``path`` whole (a temporary renamed over it), readable by its owner only:
    a painting and its log are a visitor's, like the session logs (0600)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.unlink(missing_ok=True)  # a stale one may carry wider bits
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)


@dataclass
class Gallery:
    """Paintings under ``root`` (created 0700 if missing; one the operator made is
    used as it is)."""

    root: Path

    def __post_init__(self) -> None:
        self.root = Path(self.root)
        try:
            self.root.mkdir(mode=0o700, parents=True, exist_ok=True)
        except OSError as exc:
            raise GalleryError(f"cannot create gallery directory {self.root}: "
                               f"{exc.strerror}") from None

    def path(self, pid: str, name: str = "") -> Path:
        return self.root / check_id(pid) / name

    def save(self, pid: str, srgb8: np.ndarray, log_source: str | os.PathLike[str] | None,
             meta: dict[str, Any]) -> Path:
        """Write (or overwrite) painting ``pid``: PNG, a copy of the log, metadata; the
        directory 0700, the files 0600."""
        from PIL import Image

        d = self.path(pid)
        d.mkdir(mode=0o700, parents=True, exist_ok=True)
        buf = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(srgb8, np.uint8)).save(buf, format="PNG")
        _write_private(d / PNG, buf.getvalue())
        if log_source is not None and Path(log_source).exists():
            _write_private(d / LOG, Path(log_source).read_bytes())
        for stale in (REPLAY, PRINT, FAILED):  # made from the painting before it changed
            (d / stale).unlink(missing_ok=True)
        meta = {**meta, "id": pid, "saved": time.time()}
        _write_private(d / META, json.dumps(meta, indent=1, sort_keys=True).encode())
        return d

    def meta(self, pid: str) -> dict[str, Any] | None:
        try:
            data = json.loads(self.path(pid, META).read_text())
        except (OSError, ValueError):
            return None
        return data if isinstance(data, dict) else None

    def ids(self) -> list[str]:
        """Painting ids, newest first."""
        out = [p.name for p in self.root.iterdir() if ID_RE.match(p.name) and
               (p / PNG).exists()]
        return sorted(out, reverse=True)

    def failed(self, pid: str) -> str | None:
        """Why ``pid``'s replay cannot be made (the negative cache), or None."""
        try:
            return self.path(pid, FAILED).read_text(errors="replace")[:500].strip() or "failed"
        except OSError:
            return None

    def mark_failed(self, pid: str, why: str) -> None:
        """Remember that ``pid``'s replay cannot be made, so no request tries again
        until the painting is saved anew."""
        line = (why.strip().splitlines() or ["failed"])[-1][:500]
        _write_private(self.path(pid, FAILED), (line + "\n").encode())

    def expire(self, keep_days: float, now: float | None = None) -> list[str]:
        """Delete the paintings saved more than ``keep_days`` days ago (the operator's
        retention setting); returns their ids."""
        if not (keep_days > 0 and np.isfinite(keep_days)):
            raise BadInput(f"must be a number of days > 0, not {keep_days!r}", "--keep-days")
        cutoff = (time.time() if now is None else now) - keep_days * 86400.0
        gone = []
        for pid in self.ids():
            meta = self.meta(pid) or {}
            saved = meta.get("saved")
            if not isinstance(saved, (int, float)) or not np.isfinite(saved):
                try:  # no readable time in its metadata: the PNG's
                    saved = self.path(pid, PNG).stat().st_mtime
                except OSError:
                    continue
            if saved < cutoff:
                shutil.rmtree(self.path(pid), ignore_errors=True)
                gone.append(pid)
        return gone

    def prepare(self, pid: str) -> subprocess.Popen[bytes]:
        """Start ``station gallery make`` for ``pid`` (the replay and the print) in a
        process of its own; it lowers its own priority.  Not waited for."""
        d = self.path(pid)  # a bad id raises here, before any process starts
        fd = os.open(d / MAKE_LOG, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with open(fd, "wb") as err:  # what went wrong, for the page and people
            return subprocess.Popen(
                [sys.executable, "-m", "station", "gallery", "make", "--root",
                 str(self.root), pid], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=err, start_new_session=True)

    def make(self, pid: str, frames: int = 48, width: int = 400) -> list[Path]:
        """Replay ``pid``'s log once: write its replay animation and its print; returns
        the files written."""
        log = self.path(pid, LOG)
        if not log.exists():
            raise GalleryError(f"painting {pid} has no session log to replay")
        d = self.path(pid)

        def print_png(canvas: Any, renderer: str) -> None:
            from PIL import Image


            img = to_srgb8(render_scaled(canvas.state(), renderer, PRINT_SCALE))
            buf = io.BytesIO()
            Image.fromarray(img).save(buf, format="PNG")
            _write_private(d / PRINT, buf.getvalue())

        export_replay(log, d / REPLAY, frames=frames, width=width, final=print_png)
        os.chmod(d / REPLAY, 0o600)
        return [d / REPLAY, d / PRINT]


class ReplayMaker:
    """Replays asked for by the web page, made once each by one worker thread.

    A request never waits for a replay and never holds a lock while one is made:
    it learns the replay is ready, is being made (a bounded queue; full, it is
    told to come back), or cannot be made (the :data:`FAILED` file: a negative
    cache, so a storm of requests for a broken painting starts one ``gallery
    make``, not one each).  At most one ``gallery make`` runs at a time, for at
    most ``timeout_s``.
    """

    def __init__(self, gallery: Gallery, queue_max: int = 8,
                 timeout_s: float = MAKE_TIMEOUT_S) -> None:
        self.gallery = gallery
        self.timeout_s = timeout_s
        self.started = 0  # `gallery make` processes started (for tests and status)
        self._queue: queue.Queue[str | None] = queue.Queue(maxsize=queue_max)
        self._pending: set[str] = set()
        self._lock = threading.Lock()  # guards _pending only, never held across work
        self._proc: subprocess.Popen[bytes] | None = None
        self._thread = threading.Thread(target=self._run, name="gallery-replays",
                                        daemon=True)
        self._thread.start()

    def state(self, pid: str, name: str = REPLAY) -> str:
        """``ready``, ``failed``, ``pending`` (queued now or before) or ``busy``."""
        if self.gallery.path(pid, name).exists():
            return "ready"
        if self.gallery.failed(pid) is not None:
            return "failed"
        if not self.gallery.path(pid, LOG).exists():
            return "failed"
        with self._lock:
            if pid in self._pending:
                return "pending"
            try:
                self._queue.put_nowait(pid)
            except queue.Full:
                return "busy"
            self._pending.add(pid)
        return "pending"

    def _run(self) -> None:
        while (pid := self._queue.get()) is not None:
            try:
                self._make(pid)
            finally:
                with self._lock:
                    self._pending.discard(pid)

    def _make(self, pid: str) -> None:
        if self.gallery.path(pid, REPLAY).exists() or self.gallery.failed(pid) is not None:
            return
        try:
            proc = self._proc = self.gallery.prepare(pid)
        except (OSError, BadInput) as exc:
            self.gallery.mark_failed(pid, f"cannot start gallery make: {exc}")
            return
        self.started += 1
        try:
            proc.wait(self.timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            self.gallery.mark_failed(pid, f"the replay took over {self.timeout_s:.0f} s")
            return
        finally:
            self._proc = None
        if not self.gallery.path(pid, REPLAY).exists() and self.gallery.failed(pid) is None:
            try:
                err = self.gallery.path(pid, MAKE_LOG).read_text(errors="replace")[-4000:]
            except OSError:
                err = ""
            self.gallery.mark_failed(pid, err or f"gallery make exited {proc.returncode}")

    def stop(self) -> None:
        proc = self._proc
        if proc is not None:
            proc.kill()
        while True:  # what still waits is dropped: it is made on its next request
            try:
                self._queue.put_nowait(None)
                break
            except queue.Full:
                with contextlib.suppress(queue.Empty):
                    self._queue.get_nowait()
        self._thread.join(2.0)


# -- replay animation ------------------------------------------------------------
def replay_frames(log_path: str | os.PathLike[str], frames: int = 48, width: int = 400,
                  backend: str = "auto",
                  final: Callable[[Any, str], None] | None = None) -> Iterator[np.ndarray]:
    """sRGB8 frames of a session log replayed on a canvas backend: about ``frames``
    evenly spaced in painting time, then the final canvas; scaled to ``width`` px.
    ``final(canvas, renderer)`` is called with the finished canvas (a print of it)."""
    from PIL import Image


    header, records = read_session(log_path)
    canvas, _ = make_backend(backend, header.width, header.height, header.profile, header.seed)
    sim = header.extra.get("sim") if isinstance(header.extra.get("sim"), dict) else {}
    rate = sim.get("rate") if isinstance(sim, dict) else None
    player = SessionPlayer(canvas, header.width, header.height, header.profile,
                           rate=float(rate) if isinstance(rate, (int, float)) else None,
                           pigments=default_palette())
    waits = sum(float(r.args.get("seconds", 0.0)) for r in records
                if isinstance(r, Command) and r.cmd == "wait")
    last_t = records[-1].t if records else 0.0
    total = max(1, int((last_t + waits) * player.rate))
    every = max(1, total // max(frames, 1))
    height = max(1, round(width * header.height / header.width))
    shots: list[np.ndarray] = []

    def shot() -> np.ndarray:
        img = Image.fromarray(to_srgb8(canvas.render()))
        return np.asarray(img.resize((width, height), Image.Resampling.LANCZOS))

    def on_step(p: SessionPlayer) -> None:
        if p.counters.steps % every == 0:
            shots.append(shot())

    shots.append(shot())
    player.play(records, on_step=on_step)
    shots.append(shot())
    if final is not None:

        final(canvas, get_profile(player.profile).renderer)
    close = getattr(canvas, "close", None)
    if close is not None:
        close()
    yield from shots


def export_replay(log_path: str | os.PathLike[str], out: str | os.PathLike[str],
                  frames: int = 48, width: int = 400, frame_ms: int = 80,
                  hold_ms: int = 2000, final: Callable[[Any, str], None] | None = None
                  ) -> int:
    """Write the replay of a session log as an animated WebP or GIF (by suffix);
    returns the number of frames.  The last frame (the painting) is held.  ``final``:
    see :func:`replay_frames`."""
    from PIL import Image

    arrays: list[np.ndarray] = []
    durations: list[int] = []
    for f in replay_frames(log_path, frames, width, final=final):
        if arrays and np.array_equal(arrays[-1], f):  # nothing changed: show it longer
            durations[-1] += frame_ms
        else:
            arrays.append(f)
            durations.append(frame_ms)
    durations[-1] = max(durations[-1], hold_ms)
    imgs = [Image.fromarray(a) for a in arrays]
    out = Path(out)
    tmp = out.with_name(out.name + ".tmp")
    fmt = "GIF" if out.suffix.lower() == ".gif" else "WEBP"
    extra: dict[str, Any] = {"lossless": False, "quality": 85} if fmt == "WEBP" else {}
    imgs[0].save(tmp, format=fmt, save_all=True, append_images=imgs[1:], duration=durations,
                 loop=0, **extra)
    os.replace(tmp, out)
    return len(imgs)


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


def _guarded_server_class() -> type:
    """Waitress's TCP server with the limits of :class:`WebOptions` waitress lacks: a
    cap on connections per client address, and a deadline for a whole request (its
    ``channel_timeout`` only closes connections idle that long, which a client
    sending a byte every few seconds never is)."""
    from waitress.channel import HTTPChannel
    from waitress.server import TcpWSGIServer

    class Channel(HTTPChannel):  # type: ignore[misc]  # waitress is untyped
        started = 0.0  # when the request now arriving began

        def received(self, data: bytes) -> bool:
            if self.request is None:
                self.started = time.monotonic()
            return bool(super().received(data))

    class Server(TcpWSGIServer):  # type: ignore[misc]  # waitress is untyped
        channel_class = Channel
        per_client = 8
        request_timeout_s = 10.0
        refused = 0  # connections refused for the per-client cap
        timed_out = 0  # connections closed for the request deadline

        def handle_accept(self) -> None:
            try:
                v = self.accept()
                if v is None:
                    return
                conn, addr = v
            except OSError:
                return
            host = addr[0] if isinstance(addr, tuple) else addr
            mine = sum(1 for ch in list(self.active_channels.values())
                       if isinstance(ch.addr, tuple) and ch.addr[0] == host)
            if mine >= self.per_client:
                self.refused += 1
                conn.close()
                return
            self.set_socket_options(conn)
            self.channel_class(self, conn, self.fix_addr(addr), self.adj, map=self._map)

        def maintenance(self, now: float) -> None:
            super().maintenance(now)
            cutoff = time.monotonic() - self.request_timeout_s
            for ch in list(self.active_channels.values()):
                if ch.request is not None and not ch.requests and ch.started < cutoff:
                    self.timed_out += 1
                    ch.will_close = True

    return Server


class GalleryServer:
    """The gallery app on Waitress in a background thread (``stop()`` ends it).

    Loopback unless the operator names another address; see :class:`WebOptions`
    for what it serves and its limits.  Behind a reverse proxy (TLS, a public
    name) see docs/gallery.md.
    """

    def __init__(self, gallery: Gallery, host: str = "127.0.0.1", port: int = 8080,
                 base_url: str | None = None, options: WebOptions | None = None) -> None:
        from waitress.adjustments import Adjustments

        self.options = opts = options or WebOptions()
        self.gallery = gallery
        if opts.keep_days is not None:
            gallery.expire(opts.keep_days)
        self.replays = ReplayMaker(gallery, opts.replay_queue)
        self.app = make_app(gallery, base_url, opts, self.replays)
        adj = Adjustments(
            host=host, port=port, threads=opts.threads, ident="station-gallery",
            connection_limit=opts.connection_limit, channel_timeout=opts.idle_timeout_s,
            cleanup_interval=1, max_request_header_size=8192, max_request_body_size=1024,
            backlog=128, asyncore_use_poll=True, expose_tracebacks=False)
        try:
            self.server = _guarded_server_class()(self.app, adj=adj)
        except OSError as exc:
            self.replays.stop()
            raise GalleryError(f"cannot serve the gallery on {host}:{port}: "
                               f"{exc.strerror}") from None
        self.server.per_client = opts.per_client
        self.server.request_timeout_s = opts.request_timeout_s
        self.port = int(self.server.effective_port)
        self._stopping = threading.Event()
        self.thread = threading.Thread(target=self._run, name="gallery", daemon=True)
        self._expiry = threading.Thread(target=self._expire, name="gallery-expiry",
                                        daemon=True)

    def _run(self) -> None:
        try:
            self.server.run()
        except (OSError, ValueError):
            # stop() closed the socket under the loop's select (EBADF): waitress has no
            # other way to end a loop run in a thread
            if not self._stopping.is_set():
                raise

    def _expire(self) -> None:
        keep = self.options.keep_days
        while keep is not None and not self._stopping.wait(3600.0):
            self.gallery.expire(keep)

    def start(self) -> GalleryServer:
        self.thread.start()
        self._expiry.start()
        return self

    def stop(self) -> None:
        self._stopping.set()
        self.replays.stop()
        self.server.close()
        self.thread.join(5.0)
