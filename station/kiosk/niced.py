"""The simulation's heavy, unlocked work in a thread of lower priority than the window.

The kiosk's steps run in a thread of their own (:mod:`station.kiosk.session`), and for
most of a step (the canvas kernel) that thread holds no lock. The rest of a step
(taking the brush's stamps and adding them, the log, the tiles' marks) runs under the
session's lock, which the window takes for every pen sample. The steps used to run
``sim_nice`` steps below the window's priority as a whole: on a busy machine the
scheduler then took the core from the simulation thread while it held the lock, and
the window waited for a thread it had itself pushed back (priority inversion: the
slowest pen samples waited 100 ms to 3.7 s for it on a wet 1920×1080 canvas at load
9-17). A thread cannot take back a priority it gave up (``RLIMIT_NICE`` is 0 for a
kiosk's user), so the niced work goes to a thread of its own: :class:`NicedRunner`
runs what it is handed at the lower priority while the simulation thread, at the
window's priority, waits for it with the lock released; everything under the lock runs
at the window's priority.
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Callable

import numba

log = logging.getLogger(__name__)


class NicedRunner:
    """A daemon thread that runs the callables handed to :meth:`run`, one at a time,
    ``nice`` steps below the priority of the thread that made it, with ``threads``
    numba threads (the count is per launching thread)."""

    def __init__(self, nice: int, threads: int, name: str = "kiosk-kernel") -> None:
        self.nice = max(0, int(nice))
        self.threads = max(1, int(threads))
        self.native_id: int | None = None  # the thread's id (set once it runs)
        self._base = os.getpriority(os.PRIO_PROCESS, 0)
        self._job: Callable[[], None] | None = None
        self._error: BaseException | None = None
        self._closed = False
        self._cv = threading.Condition()
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._serve, name=name, daemon=True)
        self._thread.start()

    def run(self, job: Callable[[], None]) -> None:
        """Run ``job`` in the runner's thread and wait for it; what it raised is raised
        here.  The caller holds no lock that the window needs meanwhile."""
        if threading.current_thread() is self._thread:
            job()
            return
        with self._cv:
            if self._closed:
                raise RuntimeError("the niced runner is closed")
            self._done.clear()
            self._job, self._error = job, None
            self._cv.notify()
        self._done.wait()
        err, self._error = self._error, None
        if err is not None:
            raise err

    def close(self) -> None:
        """End the thread (after the job it runs, if any)."""
        with self._cv:
            self._closed = True
            self._cv.notify()
        self._thread.join()

    def _serve(self) -> None:
        self.native_id = threading.get_native_id()
        numba.set_num_threads(min(self.threads, numba.get_num_threads()))
        if self.nice > 0:
            # before this thread's first parallel loop: the OpenMP workers it starts
            # share its priority
            try:
                os.setpriority(os.PRIO_PROCESS, self.native_id, self._base + self.nice)
            except OSError as exc:  # not allowed here: the work keeps the window's priority
                log.warning("the simulation's kernel thread keeps its priority: %s", exc)
        while True:
            with self._cv:
                while self._job is None and not self._closed:
                    self._cv.wait()
                if self._job is None:
                    return
                job, self._job = self._job, None
            try:
                job()
            except BaseException as exc:  # handed to the caller (run)
                self._error = exc
            self._done.set()
