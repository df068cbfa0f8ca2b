"""A stop request that a signal handler may raise: ``threading.Event`` without its lock.

``threading.Event.set`` takes the event's (non-reentrant) lock.  A SIGINT or SIGTERM
handler runs in the main thread between two bytecodes, and when that thread is itself
inside ``Event.wait`` -- between entering the condition and releasing its lock, or
while re-acquiring it on the way out -- ``set`` waits for a lock its own thread holds:
the process hangs for good.  CI caught a ``station driver --wait`` that ignored SIGINT
this way (killed after 60 s).

:class:`StopSignal` keeps the flag in a plain attribute and wakes waiters through a
self-pipe: ``os.write`` on a non-blocking pipe is async-signal-safe, and ``select`` on
its read end returns as soon as the handler has run (PEP 475 retries the select after
the handler, and the pipe is readable by then).
"""

from __future__ import annotations

import os
import select
import signal
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Protocol


class StopSignal:
    """A one-way flag: :meth:`set` once (from any thread or a signal handler), then
    :meth:`is_set` is true and every :meth:`wait` returns at once.  Never cleared."""

    def __init__(self) -> None:
        self._flag = False
        self._r, self._w = os.pipe()
        os.set_blocking(self._w, False)
        os.set_inheritable(self._r, False)
        os.set_inheritable(self._w, False)

    def set(self) -> None:
        if self._flag:
            return
        self._flag = True
        try:
            os.write(self._w, b"\0")
        except (BlockingIOError, OSError):  # already woken, or closed at exit
            pass

    def is_set(self) -> bool:
        return self._flag

    def wait(self, timeout: float | None = None) -> bool:
        """Until set or ``timeout`` seconds (None: for ever); whether it is set."""
        deadline = None if timeout is None else time.monotonic() + max(0.0, timeout)
        while not self._flag:
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                break
            try:
                select.select([self._r], [], [], left)
            except (OSError, ValueError):  # closed meanwhile: fall back to a short sleep
                time.sleep(min(0.05, left) if left is not None else 0.05)
        return self._flag

    def handler(self, signum: int, frame: FrameType | None) -> None:
        """A signal handler that raises the stop (async-signal-safe)."""
        self.set()

    def close(self) -> None:
        for fd in (self._r, self._w):
            try:
                os.close(fd)
            except OSError:
                pass
        self._r = self._w = -1

    def __del__(self) -> None:
        if getattr(self, "_r", -1) >= 0:
            self.close()


@contextmanager
def stop_on_signals(stop: StopSignal,
                    signals: Iterable[signal.Signals] = (signal.SIGINT, signal.SIGTERM),
                    ) -> Iterator[StopSignal]:
    """Route ``signals`` to ``stop`` for the block; the previous handlers come back after."""
    old = {sig: signal.signal(sig, stop.handler) for sig in signals}
    try:
        yield stop
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


class StopFlag(Protocol):
    """What a loop that can be stopped reads: a :class:`StopSignal` or a
    ``threading.Event`` set from another thread."""

    def is_set(self) -> bool: ...
