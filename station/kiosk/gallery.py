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
production WSGI server); both install from wheels.  The page of a painting
shows the image, its replay, and a QR code of its own address; the kiosk shows
the same QR code so a visitor takes the painting home with a phone.

Ids are checked against :data:`ID_RE` before they touch the file system, so
no URL reaches outside the gallery root.
"""

from __future__ import annotations

import json
import os
import re
import secrets
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

ID_RE = re.compile(r"^[0-9]{8}-[0-9]{6}-[0-9a-f]{6}$")
PNG, LOG, META, REPLAY = "painting.png", "session.jsonl", "meta.json", "replay.webp"
PRINT = "painting-2x.png"
MAKE_LOG = "make.log"  # what `station gallery make` said (empty when all went well)
PRINT_SCALE = 2
MAKE_TIMEOUT_S = 600.0  # a replay asked for by the web page waits at most this long


class GalleryError(StationError):
    """The gallery directory cannot be used."""


def new_id(now: float | None = None) -> str:
    """A painting id: UTC time and 24 random bits (sortable, not guessable in bulk)."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime(time.time() if now is None else now))
    return f"{stamp}-{secrets.token_hex(3)}"


def check_id(pid: str) -> str:
    if not ID_RE.match(pid):
        raise BadInput(f"painting id {pid!r} is not of the form YYYYMMDD-HHMMSS-xxxxxx")
    return pid


@dataclass
class Gallery:
    """Paintings under ``root`` (created if missing)."""

    root: Path

    def __post_init__(self) -> None:
        self.root = Path(self.root)
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise GalleryError(f"cannot create gallery directory {self.root}: "
                               f"{exc.strerror}") from None

    def path(self, pid: str, name: str = "") -> Path:
        return self.root / check_id(pid) / name

    def save(self, pid: str, srgb8: np.ndarray, log_source: str | os.PathLike[str] | None,
             meta: dict[str, Any]) -> Path:
        """Write (or overwrite) painting ``pid``: PNG, a copy of the log, metadata."""
        from PIL import Image

        d = self.path(pid)
        d.mkdir(parents=True, exist_ok=True)
        tmp = d / (PNG + ".tmp")
        Image.fromarray(np.ascontiguousarray(srgb8, np.uint8)).save(tmp, format="PNG")
        os.replace(tmp, d / PNG)
        if log_source is not None and Path(log_source).exists():
            data = Path(log_source).read_bytes()
            (d / (LOG + ".tmp")).write_bytes(data)
            os.replace(d / (LOG + ".tmp"), d / LOG)
        (d / REPLAY).unlink(missing_ok=True)  # stale once the painting changed
        (d / PRINT).unlink(missing_ok=True)
        meta = {**meta, "id": pid, "saved": time.time()}
        (d / (META + ".tmp")).write_text(json.dumps(meta, indent=1, sort_keys=True))
        os.replace(d / (META + ".tmp"), d / META)
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

    def replay(self, pid: str) -> Path:
        """The replay animation of ``pid`` (made from its session log on first use, by
        ``station gallery make`` at the lowest priority; see the module docstring)."""
        out = self.path(pid, REPLAY)
        if not out.exists():
            if not self.path(pid, LOG).exists():
                raise GalleryError(f"painting {pid} has no session log to replay")
            with _replay_lock:
                if not out.exists():
                    proc = self.prepare(pid)
                    try:
                        proc.wait(MAKE_TIMEOUT_S)
                    except subprocess.TimeoutExpired:
                        proc.kill()
                        raise GalleryError(f"the replay of painting {pid} took over "
                                           f"{MAKE_TIMEOUT_S:.0f} s") from None
                    if not out.exists():
                        try:
                            err = self.path(pid, MAKE_LOG).read_text(errors="replace").strip()
                        except OSError:
                            err = ""
                        raise GalleryError(f"cannot replay painting {pid}: "
                                           f"{err.splitlines()[-1] if err else 'failed'}")
        return out

    def prepare(self, pid: str) -> subprocess.Popen[bytes]:
        """Start ``station gallery make`` for ``pid`` (the replay and the print) in a
        process of its own; it lowers its own priority.  Not waited for."""
        d = self.path(pid)  # a bad id raises here, before any process starts
        with open(d / MAKE_LOG, "wb") as err:  # what went wrong, for the page and people
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
            tmp = d / (PRINT + ".tmp")
            Image.fromarray(img).save(tmp, format="PNG")
            os.replace(tmp, d / PRINT)

        export_replay(log, d / REPLAY, frames=frames, width=width, final=print_png)
        return [d / REPLAY, d / PRINT]


_replay_lock = threading.Lock()


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


def qr_svg(url: str, scale: int = 6) -> str:
    import io

    import segno

    buf = io.BytesIO()
    segno.make(url, error="m").save(buf, kind="svg", scale=scale, xmldecl=False,
                                    svgns=True, nl=False)
    return buf.getvalue().decode()


def default_base_url(port: int) -> str:
    """``http://<this machine's LAN address>:port`` (what a phone on the same network
    reaches); loopback when there is no network."""
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
PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{{title}}</title>
<style>
body { font-family: sans-serif; background: #f4f1ea; color: #222; margin: 0; padding: 16px; }
h1 { font-size: 1.4em; margin: 0 0 12px 0; }
.painting { display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }
img.canvas { max-width: 100%; background: white; box-shadow: 0 2px 8px #0004; }
.qr { background: white; padding: 4px; }
.meta { font-size: 0.9em; color: #555; }
ul.thumbs { list-style: none; padding: 0; display: flex; flex-wrap: wrap; gap: 12px; }
ul.thumbs img { width: 200px; box-shadow: 0 1px 4px #0004; }
</style></head><body>
{{!body}}
</body></html>
"""

PAINTING = """<h1>Your painting</h1>
<div class="painting">
<img class="canvas" id="painting" src="{{png}}" width="{{w}}" height="{{h}}" alt="the painting">
<div>
<div class="qr" id="qr">{{!svg}}</div>
<p><a href="{{png}}" download="painting-{{pid}}.png">Download the painting (PNG)</a></p>
% if print_png:
<p><a href="{{print_png}}" download="painting-{{pid}}-print.png" id="print">Download a print
({{2 * w}}×{{2 * h}} px)</a></p>
% end
<p><a href="{{replay}}">Watch it being painted</a> ·
<a href="{{log}}">session log</a></p>
<p class="meta">{{when}} · {{w}}×{{h}} · {{profile}}</p>
</div></div>
<p><a href="{{index}}">All paintings</a></p>
"""

INDEX = """<h1>Gallery</h1>
<ul class="thumbs">
% for pid in ids:
<li><a href="p/{{pid}}"><img src="p/{{pid}}/painting.png" alt="painting {{pid}}"></a></li>
% end
</ul>
"""


def make_app(gallery: Gallery, base_url: str | None = None) -> Any:
    """The Bottle WSGI app of a gallery.  ``base_url`` is the address QR codes point
    to (default: the address the request came to)."""
    import bottle

    app = bottle.Bottle()

    def base() -> str:
        url: str = (base_url or bottle.request.urlparts.scheme + "://" +
                    bottle.request.urlparts.netloc).rstrip("/")
        return url

    def page(title: str, body: str) -> str:
        html: str = bottle.template(PAGE, title=title, body=body)
        return html

    def checked(pid: str) -> str:
        if not ID_RE.match(pid) or not gallery.path(pid, PNG).exists():
            bottle.abort(404, "no such painting")
        return pid

    @app.get("/")
    def index() -> str:
        return page("Gallery", bottle.template(INDEX, ids=gallery.ids()))

    @app.get("/p/<pid>")
    def painting(pid: str) -> str:
        checked(pid)
        meta = gallery.meta(pid) or {}
        url = painting_url(base(), pid)
        when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(float(meta.get("saved", 0))))
        body = bottle.template(
            PAINTING, pid=pid, png=f"/p/{pid}/{PNG}", replay=f"/p/{pid}/{REPLAY}",
            print_png=f"/p/{pid}/{PRINT}" if gallery.path(pid, PRINT).exists() else "",
            log=f"/p/{pid}/{LOG}", svg=qr_svg(url), w=int(meta.get("width", 0)) or "",
            h=int(meta.get("height", 0)) or "", when=when, profile=meta.get("profile", ""),
            index="/")
        return page("Your painting", body)

    @app.get("/p/<pid>/<name>")
    def files(pid: str, name: str) -> Any:
        checked(pid)
        if name == REPLAY:
            try:
                gallery.replay(pid)
            except (GalleryError, BadInput) as exc:
                bottle.abort(404, str(exc))
        if name not in (PNG, LOG, REPLAY, META, PRINT):
            bottle.abort(404, "no such file")
        mime = {PNG: "image/png", LOG: "application/x-ndjson", REPLAY: "image/webp",
                META: "application/json", PRINT: "image/png"}[name]
        return bottle.static_file(name, root=str(gallery.path(pid)), mimetype=mime)

    return app


class GalleryServer:
    """The gallery app on Waitress in a background thread (``stop()`` ends it)."""

    def __init__(self, gallery: Gallery, host: str = "0.0.0.0", port: int = 8080,
                 base_url: str | None = None) -> None:
        from waitress.server import create_server

        self.app = make_app(gallery, base_url)
        try:
            self.server = create_server(self.app, host=host, port=port, threads=2,
                                        ident="station-gallery")
        except OSError as exc:
            raise GalleryError(f"cannot serve the gallery on {host}:{port}: "
                               f"{exc.strerror}") from None
        self.port = int(self.server.effective_port)
        self._stopping = False
        self.thread = threading.Thread(target=self._run, name="gallery", daemon=True)

    def _run(self) -> None:
        try:
            self.server.run()
        except (OSError, ValueError):
            # stop() closed the socket under the loop's select (EBADF): waitress has no
            # other way to end a loop run in a thread
            if not self._stopping:
                raise

    def start(self) -> GalleryServer:
        self.thread.start()
        return self

    def stop(self) -> None:
        self._stopping = True
        self.server.close()
        self.thread.join(5.0)
