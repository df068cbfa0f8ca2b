"""The canvas backend as the kiosk's session sees it: a step's kernel run with the
session's lock released (:class:`KernelUnlocked`), and the live arrays shared by a
deferred undo checkpoint until the canvas next changes (:class:`SharedState`)."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable
from typing import Any, Protocol

from station.canvas.state import CanvasState


class StepLock(Protocol):
    """The session's side of a step: its lock, and whether a kernel runs now."""

    inflight: bool
    lock: threading.Condition

    def offload(self, job: Callable[[], None]) -> None:
        """Run ``job`` (the lock released) where the step's kernel runs."""

    def add_unlocked(self, job: Callable[[], None]) -> None:
        """Run ``job`` (a step's brush sources' add) with the lock released."""


class KernelUnlocked:
    """A backend whose ``step`` runs with the session's lock released (the window
    applies brush samples meanwhile; see :mod:`station.kiosk.session`), in the session's
    niced kernel thread (:meth:`StepLock.offload`, :mod:`station.kiosk.niced`)."""

    def __init__(self, backend: Any, session: StepLock) -> None:
        self._backend = backend
        self._session = session

    def __getattr__(self, name: str) -> Any:
        return getattr(self._backend, name)

    def step(self, *args: object, **kw: object) -> None:
        s = self._session
        s.inflight = True
        s.lock.release()
        try:
            s.offload(lambda: self._backend.step(*args, **kw))
        finally:
            s.lock.acquire()
            s.inflight = False
            s.lock.notify_all()

    def add_sources(self, *args: Any, **kw: Any) -> None:
        """The step's brush sources, added with the lock released where the session
        allows (:meth:`StepLock.add_unlocked`)."""
        self._session.add_unlocked(lambda: self._backend.add_sources(*args, **kw))


class SharedState:
    """A backend whose ``state()`` shares the live canvas arrays (small fields copied):
    what a deferred undo checkpoint holds until the canvas next changes."""

    def __init__(self, backend: Any, live: CanvasState) -> None:
        self._backend = backend
        self._live = live

    def __getattr__(self, name: str) -> Any:
        return getattr(self._backend, name)

    def state(self) -> CanvasState:
        kw: dict[str, Any] = {}
        for name in self._live.__dataclass_fields__:
            v = getattr(self._live, name)
            if isinstance(v, (list, dict)):
                v = json.loads(json.dumps(v))
            kw[name] = v
        return CanvasState(**kw)
