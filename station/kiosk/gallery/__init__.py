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
The package by job: :mod:`.store` (the directories, ids, files), :mod:`.animation`
(the replay from a log), :mod:`.replays` (the web page's replay worker),
:mod:`.web` (the WSGI app, headers, QR codes, links), :mod:`.server` (Waitress
with its limits).
"""

from station.kiosk.gallery.animation import export_replay, replay_frames
from station.kiosk.gallery.replays import ReplayMaker
from station.kiosk.gallery.server import GalleryServer
from station.kiosk.gallery.store import (
    FAILED,
    ID_RE,
    LINK_BITS,
    LINK_RE,
    LOG,
    MAKE_LOG,
    MAKE_TIMEOUT_S,
    META,
    PNG,
    PRINT,
    PRINT_SCALE,
    REPLAY,
    Gallery,
    GalleryError,
    check_id,
    new_id,
)
from station.kiosk.gallery.web import (
    SECURITY_HEADERS,
    WebOptions,
    default_base_url,
    make_app,
    painting_url,
    qr_matrix,
    secure_headers,
)

__all__ = [
    "FAILED", "ID_RE", "LINK_BITS", "LINK_RE", "LOG", "MAKE_LOG", "MAKE_TIMEOUT_S", "META",
    "PNG", "PRINT", "PRINT_SCALE", "REPLAY", "SECURITY_HEADERS", "Gallery", "GalleryError",
    "GalleryServer", "ReplayMaker", "WebOptions", "check_id", "default_base_url",
    "export_replay", "make_app", "new_id", "painting_url", "qr_matrix", "replay_frames",
    "secure_headers",
]
