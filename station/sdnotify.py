"""systemd's notify protocol without libsystemd: readiness and the watchdog.

A unit with ``Type=notify`` waits for ``READY=1`` on the datagram socket named
by ``$NOTIFY_SOCKET``; with ``WatchdogSec=`` it restarts a process that has not
sent ``WATCHDOG=1`` for that long (``$WATCHDOG_USEC``, for ``$WATCHDOG_PID``).
The station's long-running processes call :func:`ready` when their loop runs
and :func:`alive` from that loop (the bus's :meth:`publish_status` and
``tick`` do, so the sim, the drivers and the kiosk feed it by running; the
supervisor and the bus proxy call it themselves).  A hung loop stops feeding,
and systemd restarts the process: the feeding is never done by a thread of its
own, which would keep a hung process alive.

Without ``$NOTIFY_SOCKET`` (not under systemd) every call is a cheap no-op.
"""

from __future__ import annotations

import os
import socket
import threading
import time


class Notifier:
    """The notify socket of this process (read from the environment once)."""

    def __init__(self, environ: dict[str, str] | None = None) -> None:
        env = os.environ if environ is None else environ
        addr = env.get("NOTIFY_SOCKET", "")
        if addr.startswith("@"):  # the abstract namespace
            addr = "\0" + addr[1:]
        self.address = addr if addr[:1] in ("/", "\0") else ""
        usec = env.get("WATCHDOG_USEC", "")
        pid = env.get("WATCHDOG_PID", "")
        mine = not pid or (pid.isdigit() and int(pid) == os.getpid())
        self.watchdog_s = int(usec) / 1e6 if usec.isdigit() and int(usec) > 0 and mine \
            else None
        self.sent_ready = False
        self.auto_ready = True  # the first alive() says READY=1 (a supervisor says it itself)
        self.pings = 0
        self._last_ping = 0.0
        self._lock = threading.Lock()

    @property
    def enabled(self) -> bool:
        return bool(self.address)

    def send(self, message: str) -> bool:
        """Send one notification; False (never an exception, never a wait) when it
        cannot go: a full queue at the other end must not stop the loop it watches."""
        if not self.address:
            return False
        try:
            with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC |
                               socket.SOCK_NONBLOCK) as s:
                s.connect(self.address)
                s.sendall(message.encode("utf-8", "replace"))
            return True
        except OSError:
            return False

    def ready(self, status: str | None = None) -> None:
        """``READY=1`` (once), with a status line."""
        with self._lock:
            if self.sent_ready:
                return
            self.sent_ready = True
        text = "READY=1" + (f"\nSTATUS={status.splitlines()[0][:200]}" if status else "")
        self.send(text)

    def alive(self) -> None:
        """Called from a process's loop: ready if not yet, and ``WATCHDOG=1`` at most
        four times per watchdog period (a datagram per call would cost the bus)."""
        if not self.address:
            return
        if not self.sent_ready and self.auto_ready:
            self.ready()
        if self.watchdog_s is None:
            return
        now = time.monotonic()
        if now - self._last_ping >= self.watchdog_s / 4:
            self._last_ping = now
            self.pings += 1
            self.send("WATCHDOG=1")

    def stopping(self) -> None:
        self.send("STOPPING=1")

    def status(self, text: str) -> None:
        self.send(f"STATUS={text.splitlines()[0][:200] if text else ''}")


_notifier: Notifier | None = None


def notifier() -> Notifier:
    """This process's :class:`Notifier`."""
    global _notifier
    if _notifier is None:
        _notifier = Notifier()
    return _notifier


def ready(status: str | None = None) -> None:
    notifier().ready(status)


def alive() -> None:
    notifier().alive()


def stopping() -> None:
    notifier().stopping()


def child_environ(env: dict[str, str]) -> dict[str, str]:
    """``env`` without the notify variables: a child is not the unit's main process
    (``NotifyAccess=main``) and must not speak for it."""
    return {k: v for k, v in env.items()
            if k not in ("NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID")}
