"""The gallery's web server: Waitress with the limits it lacks (connections per
client, a whole-request deadline), in a background thread."""

from __future__ import annotations

import threading
import time

from station.kiosk.gallery.replays import ReplayMaker
from station.kiosk.gallery.store import Gallery, GalleryError
from station.kiosk.gallery.web import SECURITY_HEADERS, WebOptions, make_app


def _guarded_server_class() -> type:
    """Waitress's TCP server with the limits of :class:`WebOptions` waitress lacks: a
    cap on connections per client address, and a deadline for a whole request (its
    ``channel_timeout`` only closes connections idle that long, which a client
    sending a byte every few seconds never is).  The responses waitress makes itself
    (a malformed request line, oversized headers, bad chunking, a body too long, its
    500) carry :data:`SECURITY_HEADERS` like the app's."""
    from waitress.channel import HTTPChannel
    from waitress.server import TcpWSGIServer
    from waitress.task import ErrorTask

    names = {k.lower() for k, _ in SECURITY_HEADERS}

    class SecureErrorTask(ErrorTask):  # type: ignore[misc]  # waitress is untyped
        def build_response_header(self) -> bytes:
            # its execute() writes the body at once: the header is built from here
            theirs: list[tuple[str, str]] = list(getattr(self, "response_headers", []))
            self.response_headers = [(k, v) for k, v in theirs
                                     if k.lower() not in names] + list(SECURITY_HEADERS)
            return bytes(super().build_response_header())

    class Channel(HTTPChannel):  # type: ignore[misc]  # waitress is untyped
        error_task_class = SecureErrorTask
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
