"""The web page's replays: made once each by one worker, a bounded queue and a
negative cache (never per request, never under a lock a page waits on)."""

from __future__ import annotations

import contextlib
import queue
import subprocess
import threading

from station.errors import BadInput
from station.kiosk.gallery.store import LOG, MAKE_LOG, MAKE_TIMEOUT_S, REPLAY, Gallery


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

