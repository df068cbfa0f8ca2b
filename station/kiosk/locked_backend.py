"""The canvas backend as the kiosk's session sees it: a step's kernel run in the niced
kernel thread (:class:`OffloadedKernel`; the step's canvas part runs with the session's
lock released, :meth:`station.kiosk.session.KioskSession.run_step`), and the live arrays
shared by a deferred undo checkpoint until the canvas next changes (:class:`SharedState`)."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from station.canvas.state import CanvasState


class OffloadedKernel:
    """A backend whose ``step`` (the kernel) runs where ``offload`` runs it: the session's
    niced kernel thread (:mod:`station.kiosk.niced`)."""

    def __init__(self, backend: Any, offload: Callable[[Callable[[], None]], None]) -> None:
        self._backend = backend
        self._offload = offload

    def __getattr__(self, name: str) -> Any:
        return getattr(self._backend, name)

    def step(self, *args: object, **kw: object) -> None:
        self._offload(lambda: self._backend.step(*args, **kw))


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
